"""Named kernel layouts: every packed structure is one (name, shape) spec; packing and views follow from it."""

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
    assert wb.Workspace._fields == wb.WORKSPACE.names
    robot_fields = set(wb.ROBOT_FLOATS.names) | set(wb.ROBOT_INTS.names) | {"ee_joint"}
    assert set(wb.RobotArrays._fields) == robot_fields
    assert set(wb.Scene._fields) == set(wb.SCENE_FLOATS.names) | {"packed"}


def test_step_result_reads_the_slots_by_name() -> None:
    row = np.arange(wb.OUT_SIZE + 3, dtype=np.float64)
    result = wb.StepResult.of(row)
    np.testing.assert_array_equal(result.twist, row[0:6])
    np.testing.assert_array_equal(result.orientation, row[9:13])
    assert result.clearance == row[wb.OUT_CLEARANCE] and result.nearest_self_pair == row[wb.OUT_SIZE - 1]


def test_the_compiled_workspaces_follow_the_layout() -> None:
    n, caps, obstacles, pairs, prims = 7, 8, 3, 5, 11
    m = caps * obstacles + pairs + 2 * n
    dims = {"n": n, "caps": caps, "m": m, "prims": prims}
    shapes = {name: tuple(dims[d] if isinstance(d, str) else d for d in shape) for name, shape in wb.WORKSPACE.entries}
    allocated = wb.make_workspace(n, caps, obstacles, pairs, prims)  # one array per entry (the planning loop)
    for name, view in allocated._asdict().items():
        assert view.shape == (shapes[name] or (1,)), name
    work = np.zeros(wb.WORKSPACE.size(**dims))
    viewed = wb.workspace_views(work, n, caps, m, prims)  # views of one buffer (the autonomy step)
    offsets = wb.WORKSPACE.offsets(**dims)
    base = work.__array_interface__["data"][0]
    for name, view in viewed._asdict().items():
        start, _ = offsets[name]
        assert view.shape == (shapes[name] or (1,)), name
        assert view.__array_interface__["data"][0] - base == 8 * start, name


def test_the_compiled_robot_views_round_trip_the_packed_robot() -> None:
    from pfield.planning._whole_body_flat import FlatStep
    from pfield.planning.whole_body import make_scene, pack_robot
    from pfield.robot import RobotModel

    robot = RobotModel.builtin("xarm7")
    arrays = pack_robot(robot, FieldConfig(), WholeBodyOptions())
    scene = make_scene(None, arrays)
    flat = FlatStep(arrays, scene)
    n, caps, _, pairs, _, ee, prims = (int(v) for v in flat.dims)
    viewed = wb.robot_views(flat.floats, flat.ints, n, caps, pairs, prims, caps + 1, ee)
    for name, value in arrays._asdict().items():
        np.testing.assert_array_equal(getattr(viewed, name), value, err_msg=name)


def test_the_unowned_copies_view_the_same_memory() -> None:
    """``unowned_robot``/``unowned_scene``/``unowned_workspace`` keep every field's memory, shape and values
    (writes go through), and a named tuple whose fields the layouts do not cover exactly is refused."""
    from pfield._layout import compile_unowned
    from pfield.geometry import Obstacle, Sphere, pack_obstacles
    from pfield.planning.whole_body import make_scene, pack_robot
    from pfield.robot import RobotModel
    from pfield.spatial import Pose

    robot = RobotModel.builtin("xarm7")
    arrays = pack_robot(robot, FieldConfig(), WholeBodyOptions())
    scene = make_scene(pack_obstacles([Obstacle("ball", Sphere(0.1), Pose((0.4, 0.0, 0.3)))]), arrays)
    workspace = wb.make_workspace(7, len(arrays.cap_r), 1, len(arrays.self_pairs), len(arrays.prim_r))
    pairs = [(arrays, wb.unowned_robot(arrays)), (scene, wb.unowned_scene(scene)),
             (scene.packed, wb.unowned_scene(scene).packed), (workspace, wb.unowned_workspace(workspace))]
    for owner, view in pairs:
        for name, value in owner._asdict().items():
            if isinstance(value, np.ndarray):
                seen = getattr(view, name)
                assert seen.shape == value.shape and seen.dtype == value.dtype, name
                assert seen.size == 0 or seen.ctypes.data == value.ctypes.data, name
                np.testing.assert_array_equal(seen, value, err_msg=name)
    assert wb.unowned_robot(arrays).ee_joint == arrays.ee_joint
    wb.unowned_workspace(workspace).out[:] = 7.0
    assert np.all(workspace.out == 7.0)
    with pytest.raises(ValueError, match="not covered exactly"):
        compile_unowned("partial", wb.Scene, {"unowned": [wb.SCENE_FLOATS]}, {})
