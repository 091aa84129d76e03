"""Named layouts: every packed structure is one (name, shape) spec, packing and views follow from it, and what
Python packs for the compiled core is what the core reads, by name."""

from __future__ import annotations

import numpy as np
import pytest

from pfield._layout import Layout
from pfield.field import FieldConfig
from pfield.field.config import PARAM_NAMES, PARAMS
from pfield.planning import PlanOptions
from pfield.planning import _whole_body_layout as wb
from pfield.planning.whole_body import WholeBodyOptions, kernel_parameters


def test_layout_offsets_pack_and_views_round_trip() -> None:
    layout = Layout("demo", [("a", ("n", 3)), ("s", ()), ("b", (2, "m"))])
    assert layout.dims == ("n", "m") and layout.size(n=2, m=4) == 6 + 1 + 8
    assert layout.offsets(n=2, m=4) == {"a": (0, 6), "s": (6, 7), "b": (7, 15)}
    values = {"a": np.arange(6.0).reshape(2, 3), "s": 7.5, "b": -np.arange(8.0).reshape(2, 4)}
    flat = layout.pack(values, n=2, m=4)
    views = layout.unpack(flat, n=2, m=4)
    np.testing.assert_array_equal(views["a"], values["a"])
    np.testing.assert_array_equal(views["b"], values["b"])
    fixed = Layout("fixed", [("v", (3,)), ("s", ()), ("m", (2, 2))])
    vector, scalar, matrix = fixed.read(np.arange(8.0))
    assert scalar == 3.0 and isinstance(scalar, float)
    np.testing.assert_array_equal(vector, [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(matrix, [[4.0, 5.0], [6.0, 7.0]])
    views["a"][1, 2] = 100.0  # views write through to the flat array
    assert flat[5] == 100.0
    with pytest.raises(KeyError):
        layout.pack({"a": values["a"]}, n=2, m=4)
    with pytest.raises(ValueError):
        layout.span("b")  # symbolic offset
    with pytest.raises(ValueError):
        Layout("twice", [("a", ()), ("a", ())])


def test_the_field_parameters_are_packed_by_name() -> None:
    config = FieldConfig(attractive_gain=2.0, stagnation_progress=0.02)
    assert PARAMS.names == PARAM_NAMES
    packed = config.packed()
    for name in PARAM_NAMES:
        assert packed[PARAMS.index(name)] == getattr(config, name)


def test_the_whole_body_parameters_are_packed_by_name() -> None:
    config = FieldConfig(damper_gain=0.7)
    plan = PlanOptions(dt=0.02, goal_tolerance=0.003).resolved(config)
    params = kernel_parameters(config, plan, WholeBodyOptions(damping=2e-3))
    assert params.shape == (wb.N_PARAMS,)
    assert params[wb.XI] == 0.7 and params[wb.DT] == 0.02 and params[wb.TOL] == 0.003
    assert params[wb.DAMPING] == 2e-3 and params[wb.STAG_STEPS] == plan.stagnation_steps
    assert params[wb.ROT_TOL] == config.rotation_tolerance


def test_the_typed_views_have_exactly_the_layouts_entries() -> None:
    assert wb.StepResult._fields == wb.STEP_OUT.names


def test_the_packed_robot_and_scene_are_what_the_core_reads_by_name() -> None:
    """RobotArrays, PackedObstacles and Scene bind into the core's Robot, Obstacles and Scene keyword for keyword
    (the C++ structs are the layouts' truth: a field renamed or moved on either side fails here), and the core
    reads the sizes Python packed."""
    from pfield._core import robot as core
    from pfield.geometry import Obstacle, Sphere, pack_obstacles
    from pfield.planning.whole_body import make_scene, pack_robot
    from pfield.robot import RobotModel
    from pfield.spatial import Pose

    robot = RobotModel.builtin("xarm7")
    arrays = pack_robot(robot, FieldConfig(), WholeBodyOptions())
    scene = make_scene(pack_obstacles([Obstacle("ball", Sphere(0.1), Pose((0.4, 0.0, 0.3)))]), arrays,
                       np.zeros(7), 0.01)
    bound = core.Robot(**arrays._asdict())
    assert (bound.joint_count, bound.capsule_count, bound.pair_count, bound.primitive_count) == (
        7, len(arrays.cap_r), len(arrays.self_pairs), len(arrays.prim_r))
    obstacles = core.Obstacles(**scene.packed._asdict(), centres=scene.centres, bounds=scene.bounds)
    assert obstacles.count == 1
    fields = {name: value for name, value in scene._asdict().items() if name not in ("packed", "centres", "bounds")}
    assert core.Scene(robot=bound, obstacles=obstacles, **fields).robot is bound


def test_step_result_reads_the_slots_by_name() -> None:
    row = np.arange(wb.OUT_SIZE + 3, dtype=np.float64)
    result = wb.StepResult.of(row)
    np.testing.assert_array_equal(result.twist, row[0:6])
    np.testing.assert_array_equal(result.orientation, row[9:13])
    assert result.clearance == row[wb.OUT_CLEARANCE] and result.nearest_self_pair == row[wb.OUT_SIZE - 1]
