"""The self pairs' tables (``src/core/robot/pair_tables.hpp``, issue 34): a pair whose links move apart by one or two
joints keeps its fitted distance on a grid over them, and the global search's state check asks the table first.

* a table's verdict is the primitives' own (oracle: ``fitted_self_clearances_at`` at the same configuration), at
  needs on both sides of the distance and right at it;
* its weights bound how fast the pair's distance changes with the tabulated joints (finite differences over random
  configurations), and only the joints that move one link alone count;
* the UR5's forearm and wrist 2, 4 mm apart at the median configuration, are decided by their table in most
  configurations (why the tables exist);
* a search checks the same states and finds the same path with the tables as without them;
* tables made from another robot, or weights of the wrong shape, are refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from core_scenes import robot, ur5_problem
from pfield._core import robot as core
from pfield._core import robot_distance as distance
from pfield._core import rrt
from pfield.field.config import FieldConfig
from pfield.geometry import pack_obstacles
from pfield.planning import _whole_body_core
from pfield.planning._whole_body_core import core_robot, core_scene
from pfield.planning.whole_body import WholeBodyOptions, make_scene, pack_robot

CLEAR, BELOW, UNKNOWN = core.PairVerdict.Clear, core.PairVerdict.Below, core.PairVerdict.Unknown


def _packed(name: str) -> tuple[object, object]:
    arrays = pack_robot(robot(name), FieldConfig(), WholeBodyOptions())
    return arrays, core_robot(arrays)


def _fresh_tables(name: str) -> tuple[object, object]:
    """The robot packed with new tables of its own (every cell unfilled), not the ones its plans share."""
    arrays, _ = _packed(name)
    bare = arrays._replace(pair_tables=None)
    tables = core.PairTables(core.Robot(*bare), _whole_body_core.pair_weights(robot(name), arrays))
    return arrays._replace(pair_tables=tables), tables


def _tabulated(tables: object) -> list[int]:
    return [k for k in range(tables.pair_count) if tables.axes(k)]


def _pair(arrays: object, first: str, second: str) -> int:
    names = robot("ur5").geometry.link_names
    pairs = [tuple(names[l] for l in pair) for pair in arrays.self_pairs]
    return pairs.index((first, second))


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_a_tables_verdict_is_the_primitives_own(name: str) -> None:
    arrays, bound = _packed(name)
    tables = arrays.pair_tables
    tabulated = _tabulated(tables)
    assert tabulated, "some self pair moves apart by one or two joints"
    model = robot(name)
    rng = np.random.default_rng(5)
    said = {CLEAR: 0, BELOW: 0, UNKNOWN: 0}
    for q in rng.uniform(model.lower_limits, model.upper_limits, (400, model.n_joints)):
        exact = np.asarray(distance.fitted_self_clearances_at(bound, q))
        for k in tabulated:
            for need in (0.0, 0.003, exact[k], exact[k] + 1e-6, exact[k] - 1e-6, exact[k] + 0.01, exact[k] - 0.01):
                verdict = tables.verdict(k, q, need)
                said[verdict] += 1
                # the search's own form of the primitives' verdict: their distance below need, with need as cutoff
                below = distance.fitted_self_clearances_at(bound, q, need)[k] < need
                assert below == (exact[k] < need)
                if verdict == CLEAR:
                    assert not below, (k, q, need)
                elif verdict == BELOW:
                    assert below, (k, q, need)
    assert said[CLEAR] > 0 and said[BELOW] > 0 and said[UNKNOWN] > 0  # every verdict was exercised


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_weights_bound_how_fast_a_tabulated_pair_moves(name: str) -> None:
    """|D(q') - D(q)| <= sum_j w_j |q'_j - q_j| for q' differing from q in the pair's tabulated joints; a table's
    cells tile its joints' ranges (one turn for a revolute joint whose range exceeds it); the other joints do not
    move the pair."""
    arrays, bound = _packed(name)
    tables = arrays.pair_tables
    model = robot(name)
    rng = np.random.default_rng(6)
    for k in _tabulated(tables):
        axes = tables.axes(k)
        for axis in axes:
            span = 2 * np.pi if axis.turns else model.upper_limits[axis.joint] - model.lower_limits[axis.joint]
            assert axis.origin == model.lower_limits[axis.joint]
            assert axis.cells * axis.width == pytest.approx(span, rel=1e-12)
        joints = [axis.joint for axis in axes]
        weights = np.array([axis.weight for axis in axes])
        for q in rng.uniform(model.lower_limits, model.upper_limits, (40, model.n_joints)):
            moved = q.copy()
            moved[joints] = np.clip(q[joints] + rng.normal(scale=0.05, size=len(joints)),
                                    model.lower_limits[joints], model.upper_limits[joints])
            d0, d1 = (distance.fitted_self_clearances_at(bound, v, np.inf)[k] for v in (q, moved))
            assert abs(d1 - d0) <= weights @ np.abs(moved[joints] - q[joints]) + 1e-12
            others = q.copy()
            rest = [j for j in range(model.n_joints) if j not in joints]
            others[rest] = rng.uniform(model.lower_limits[rest], model.upper_limits[rest])
            assert distance.fitted_self_clearances_at(bound, others, np.inf)[k] == pytest.approx(d0, abs=1e-12)


def test_the_ur5_forearm_and_wrist_2_are_decided_by_their_table() -> None:
    """The pair the UR5's checks spent most on (its SRDF keeps it; its fitted primitives 4 mm apart at the median
    configuration, so no capsule bound decides it) depends on wrist 1 and wrist 2 alone; its table answers "at least
    0" (the search's self need) without the primitives in most configurations."""
    arrays, tables = _fresh_tables("ur5")
    k = _pair(arrays, "forearm_link", "wrist_2_link")
    assert [axis.joint for axis in tables.axes(k)] == [3, 4]  # wrist_1_joint, wrist_2_joint
    assert tables.filled(k) == 0
    model = robot("ur5")
    rng = np.random.default_rng(7)
    verdicts = [tables.verdict(k, q, 0.0) for q in rng.uniform(model.lower_limits, model.upper_limits, (1000, 6))]
    assert verdicts.count(UNKNOWN) < 0.3 * len(verdicts)
    assert 0 < tables.filled(k) <= 1000  # a cell is measured once, when first met


@pytest.mark.parametrize(("scene", "index"), [("cage_ur5", 5), ("bookshelf_small_ur5", 9)])
def test_a_search_checks_the_same_states_with_its_tables(scene: str, index: int) -> None:
    """Every verdict of a table is the primitives' own, so RRT-Connect from one seed checks the same states and
    finds the same path with the tables as without them."""
    arrays, fresh = _fresh_tables("ur5")
    obstacles, start, goal = ur5_problem(scene, index)
    outcomes = []
    for tables in (None, fresh):
        packed = arrays._replace(pair_tables=tables)
        scene_arrays = make_scene(pack_obstacles(obstacles), packed)._replace(fitted_self=True)
        checker = rrt.Checker(core_scene(packed, scene_arrays), 0.003, 0.03)
        trees = rrt.Trees(start, goal[None], 20000, 11)
        lower, upper = robot("ur5").lower_limits, robot("ur5").upper_limits
        status, path = checker.connect(trees, lower, upper, 1.0, 40000, None, None)
        outcomes.append((status, path, checker.states_checked))
    (status, path, checked), (status_t, path_t, checked_t) = outcomes
    assert status == status_t and checked == checked_t
    np.testing.assert_array_equal(path, path_t)
    assert fresh.filled(_pair(arrays, "forearm_link", "wrist_2_link")) > 0  # the search asked the table


def test_tables_of_another_robot_or_of_wrong_weights_are_refused() -> None:
    panda, _ = _packed("panda")
    ur5, _ = _packed("ur5")
    with pytest.raises(ValueError, match="pair_tables: made from another robot"):
        core.Robot(*panda._replace(pair_tables=ur5.pair_tables))
    with pytest.raises(ValueError, match=r"pair_tables: expected a robot\.PairTables"):
        core.Robot(*ur5._replace(pair_tables="tables"))
    pairs = len(ur5.self_pairs)
    with pytest.raises(ValueError, match=rf"weights: expected shape \(self pairs, joints\) = \({pairs}, 6\), "
                                         r"got \(3, 6\)"):
        core.PairTables(core.Robot(*ur5._replace(pair_tables=None)), np.zeros((3, 6)))
    tables = ur5.pair_tables
    with pytest.raises(ValueError, match=rf"pair: expected a self pair's index, 0 to {pairs} \(excluded\), got "
                                         rf"{pairs}"):
        tables.verdict(pairs, np.zeros(6), 0.0)
    with pytest.raises(ValueError, match="q: expected one value per joint"):
        tables.verdict(0, np.zeros(5), 0.0)
    # a configuration beyond a tabulated joint's limits, or not a number there, is the primitives' to decide
    k = _pair(ur5, "forearm_link", "wrist_2_link")
    for value in (4.0, -4.0, np.nan, np.inf):
        assert tables.verdict(k, np.array([0.0, 0.0, 0.0, value, 0.0, 0.0]), 0.0) == UNKNOWN


def test_one_robot_keeps_one_set_of_tables() -> None:
    """Plans of a robot share its tables' cells (the searches of a batch fill them once)."""
    first, _ = _packed("ur5")
    again = pack_robot(robot("ur5"), FieldConfig(max_angular_acceleration=2.0), WholeBodyOptions())
    assert again.pair_tables is first.pair_tables
    assert _whole_body_core.pair_tables(robot("ur5"), again) is first.pair_tables
