"""PlannedPath: shape validation, derived views and the CSV round trip."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from pfield.errors import InvalidInput
from pfield.planning import PlannedPath


def _path(count: int = 3, **overrides: object) -> PlannedPath:
    values: dict[str, object] = {
        "success": True,
        "failure_reason": "",
        "times": np.arange(count) * 0.01,
        "positions": np.linspace((0, 0, 0), (1, 2, 3), count),
        "orientations": np.tile((0.0, 0.0, 0.0, 1.0), (count, 1)),
        "twists": np.ones((count, 6)) * 0.1,
        "clearances": np.full(count, math.inf),
        "iterations": count - 1,
    }
    values.update(overrides)
    return PlannedPath(**values)  # type: ignore[arg-type]


def test_views_and_immutability() -> None:
    path = _path()
    assert len(path) == 3
    assert path.poses[2].position.tolist() == [1.0, 2.0, 3.0]
    assert path.final_pose.isclose(path.poses[-1])
    assert path.duration == pytest.approx(0.02)
    assert path.twist_list[0].angular.tolist() == [0.1, 0.1, 0.1]
    with pytest.raises(ValueError):
        path.positions[0, 0] = 5.0


@pytest.mark.parametrize(
    ("field", "value"),
    [("positions", np.zeros((3, 2))), ("orientations", np.zeros((2, 4))), ("twists", np.zeros(6)),
     ("clearances", np.zeros(4)), ("times", np.zeros(0))],
)
def test_inconsistent_shapes_are_rejected(field: str, value: object) -> None:
    with pytest.raises(InvalidInput) as info:
        _path(**{field: value})
    assert info.value.field == field


def test_repr_is_a_summary_not_the_arrays() -> None:
    from pfield.planning.status import PlanStatus

    assert repr(_path(count=201)) == "PlannedPath(REACHED by field: 201 waypoints over 2 s, min clearance inf m)"
    failed = _path(success=False, failure_reason="stagnation: no progress", status=PlanStatus.STAGNATION,
                   joint_names=("a", "b"), joint_positions=np.array([[0.0, 0.0], [0.3, 0.4], [0.3, 0.4]]),
                   clearances=np.array([0.2, 0.05, 0.1]))
    assert repr(failed) == ("PlannedPath(STAGNATION by field: 3 waypoints over 0.02 s, 2 joints, joint path 0.5 rad, "
                            "min clearance 0.05 m; stagnation: no progress)")


def test_success_with_a_reason_is_rejected() -> None:
    with pytest.raises(InvalidInput, match="failure_reason"):
        _path(failure_reason="stagnation")


def test_csv_round_trip_with_joints(tmp_path: Path) -> None:
    joints = np.arange(6.0).reshape(3, 2) / 7.0
    path = _path(joint_names=("a", "b"), joint_positions=joints, joint_velocities=-joints,
                 clearances=np.array([0.1, math.inf, 0.3]))
    target = path.to_csv(tmp_path / "plan.csv")
    with target.open() as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == path.csv_header()
    assert rows[0][-4:] == ["position_a", "position_b", "velocity_a", "velocity_b"]
    table = np.array([[float(v) for v in row] for row in rows[1:]])
    assert table.shape == (3, 19)
    np.testing.assert_array_equal(table[:, 1:4], path.positions)
    np.testing.assert_array_equal(table[:, 15:17], joints)
    assert math.isinf(table[1, 14])


def test_joint_arrays_must_match_the_names() -> None:
    with pytest.raises(InvalidInput, match="joint_positions"):
        _path(joint_names=("a",), joint_positions=np.zeros((3, 2)))


def test_status_and_planner() -> None:
    from pfield.planning import PlanStatus

    assert _path().status == PlanStatus.REACHED and _path().planner == "field"
    failed = _path(success=False, failure_reason="stagnation", status=PlanStatus.STAGNATION, planner="field+global")
    assert failed.status is PlanStatus.STAGNATION and failed.planner == "field+global"
    assert _path(success=False, failure_reason="x", status=1).status is PlanStatus.STAGNATION
    for changes, name in (({"success": False, "failure_reason": "x"}, "status"),
                          ({"status": PlanStatus.COLLISION}, "status"),
                          ({"success": False, "failure_reason": "x", "status": 99}, "status"),
                          ({"planner": "rrt"}, "planner")):
        with pytest.raises(InvalidInput) as info:
            _path(**changes)
        assert info.value.field == name
