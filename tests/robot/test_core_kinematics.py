"""The compiled core's robot kinematics and numba's twins give the same bits.

:class:`~pfield.robot.RobotModel` calls the core (``src/core/robot/kinematics``) for every kinematic quantity; the
numba kernels not yet ported (whole body, assistance, RRT, clearance) still inline :mod:`pfield.robot._kinematics`.
A Jacobian the planner uses and one a user asks for must not differ in the last digit, so each function is held
equal bit for bit (signed zeros included: the bytes are compared), on random configurations of robots with
revolute, continuous and prismatic joints, trees (the Panda's fingers branch off its hand, so some columns are
zero) and an end effector on the base. Both keep the numba kernels' operation order, and neither fuses
multiply-adds (CMakeLists.txt: -ffp-contract=off -mno-fma for src/core/robot).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest

from pfield._spatial_kernels import matrix_to_quat
from pfield.robot import RobotModel
from pfield.robot import _kinematics as kin
from pfield.robot.catalog import builtin_spec, example_robot_data_root
from pfield.robot.ik import solve_ik
from pfield.robot.model import LIMIT_TOLERANCE

UR5 = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "mbm" / "ur5"

# A rail (prismatic) carrying a tilted revolute joint, a prismatic slide on an oblique axis, a continuous wrist and
# a branch (a second prismatic finger off the wrist, not on the tool's path); placements with rotations.
RAIL_URDF = """<robot name='rail'>
  <link name='base'/><link name='carriage'/><link name='upper'/><link name='slide'/><link name='wrist'/>
  <link name='finger'/><link name='tool'/>
  <joint name='rail' type='prismatic'><parent link='base'/><child link='carriage'/>
    <origin xyz='0.1 -0.2 0.05' rpy='0 0 0.3'/><axis xyz='1 0 0'/>
    <limit lower='-0.5' upper='1.5' velocity='1' effort='1'/></joint>
  <joint name='shoulder' type='revolute'><parent link='carriage'/><child link='upper'/>
    <origin xyz='0 0 0.3' rpy='0.2 -0.1 0.4'/><axis xyz='0 0.6 0.8'/>
    <limit lower='-2' upper='2' velocity='1' effort='1'/></joint>
  <joint name='slide' type='prismatic'><parent link='upper'/><child link='slide'/>
    <origin xyz='0.25 0.01 -0.02' rpy='-0.3 0.5 0.1'/><axis xyz='0.36 0.48 0.8'/>
    <limit lower='0' upper='0.4' velocity='1' effort='1'/></joint>
  <joint name='wrist' type='continuous'><parent link='slide'/><child link='wrist'/>
    <origin xyz='0.05 0 0.1' rpy='1.2 0 -0.7'/><axis xyz='0 0 1'/><limit velocity='1' effort='1'/></joint>
  <joint name='finger' type='prismatic'><parent link='wrist'/><child link='finger'/>
    <origin xyz='0 0.03 0.02'/><axis xyz='0 1 0'/><limit lower='0' upper='0.04' velocity='1' effort='1'/></joint>
  <joint name='tool_mount' type='fixed'><parent link='wrist'/><child link='tool'/>
    <origin xyz='0.02 0.01 0.12' rpy='0.1 0.2 0.3'/></joint>
</robot>"""


@functools.cache
def _robot(name: str, tmp: Path) -> RobotModel:
    if name == "panda":
        return RobotModel.builtin("panda")
    if name == "panda-fingers":  # the URDF as it is: two prismatic fingers branching off the hand
        spec, root = builtin_spec("panda"), example_robot_data_root()
        return RobotModel.from_urdf(root / spec.urdf, spec.end_effector, {"example-robot-data": root})
    if name == "ur5":
        if not UR5.is_dir():
            pytest.skip("the UR5 of ../shared/benchmarks/mbm is not here")
        return RobotModel.from_urdf(UR5 / "ur5.urdf", "ee_link", {"meshes": UR5 / "meshes"})
    urdf = tmp / "rail.urdf"
    urdf.write_text(RAIL_URDF)
    return RobotModel.from_urdf(urdf, "base" if name == "rail-base" else "tool")


ROBOTS = ["panda", "panda-fingers", "ur5", "rail", "rail-base"]


@pytest.fixture(params=ROBOTS)
def robot(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> RobotModel:
    return _robot(request.param, tmp_path_factory.getbasetemp())


def _same(a: object, b: object) -> bool:
    """Equal to the bit (signed zeros and NaN payloads included)."""
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return x.shape == y.shape and x.tobytes() == y.tobytes()


def _configurations(robot: RobotModel, count: int, seed: int) -> np.ndarray:
    """Within the limits (continuous joints: ±π), beyond them, far out (sin/cos argument reduction) and zeros."""
    rng = np.random.default_rng(seed)
    lower, upper = np.maximum(robot.lower_limits, -math.pi), np.minimum(robot.upper_limits, math.pi)
    qs = rng.uniform(lower, upper, size=(count, robot.n_joints))
    qs[count // 2:] += rng.normal(scale=0.3, size=(count - count // 2, robot.n_joints))
    qs[-10:] = rng.uniform(-60.0, 60.0, size=(10, robot.n_joints))
    qs[0] = 0.0
    qs[1] = -0.0
    return qs


def _frames(robot: RobotModel, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    k, n = robot.kinematics, robot.n_joints
    rotations, origins = np.empty((n, 3, 3)), np.empty((n, 3))
    kin.joint_transforms(q, k.parents, k.place_rot, k.place_pos, k.axes, k.kinds, rotations, origins)
    return rotations, origins


def test_joint_transforms(robot: RobotModel) -> None:
    core = robot._core_kinematics
    for q in _configurations(robot, 300, 1):
        rotations, origins = _frames(robot, q)
        core_rotations, core_origins = core.joint_frames(q)
        assert _same(core_rotations, rotations) and _same(core_origins, origins), q


def test_frame_pose_and_transform_point(robot: RobotModel) -> None:
    core, n = robot._core_kinematics, robot.n_joints
    rng = np.random.default_rng(2)
    for q in _configurations(robot, 100, 2):
        rotations, origins = _frames(robot, q)
        for joint in range(-1, n):
            local_rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
            local_position = rng.normal(scale=0.3, size=3)
            rotation, position = kin.frame_pose(rotations, origins, joint, local_rotation, local_position)
            core_rotation, core_position = core.frame_pose(rotations, origins, joint, local_rotation, local_position)
            assert _same(core_rotation, rotation) and _same(core_position, position)
            point = np.empty(3)
            kin.transform_point_into(rotations, origins, joint, local_position, point)
            assert _same(core.frame_pose(rotations, origins, joint, np.eye(3), local_position)[1], point)


def test_point_jacobians(robot: RobotModel) -> None:
    core, k, n = robot._core_kinematics, robot.kinematics, robot.n_joints
    rng = np.random.default_rng(3)
    for q in _configurations(robot, 100, 3):
        rotations, origins = _frames(robot, q)
        for joint in range(-1, n):
            point = rng.normal(scale=0.5, size=3)
            expected = np.full((6, n), np.nan)
            kin.point_jacobian(rotations, origins, k.axes, k.kinds, k.support, joint, point, expected)
            assert _same(core.point_jacobian(rotations, origins, joint, point), expected)
            linear = np.full((3, n), np.nan)
            kin.linear_point_jacobian(rotations, origins, k.axes, k.kinds, k.support, joint, point[0], point[1],
                                      point[2], linear)
            assert _same(core.linear_point_jacobian(rotations, origins, joint, point), linear)


def test_end_effector_kinematics_and_the_public_methods(robot: RobotModel) -> None:
    core, k, n = robot._core_kinematics, robot.kinematics, robot.n_joints
    lower, upper = robot.lower_limits, robot.upper_limits
    for q in _configurations(robot, 300, 4):
        rotations, origins, jacobian = np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((6, n))
        rotation, position = kin.end_effector_kinematics(q, *k, rotations, origins, jacobian)
        core_rotation, core_position, core_jacobian = core.end_effector_kinematics(q)
        assert _same(core_rotation, rotation) and _same(core_position, position) and _same(core_jacobian, jacobian)
        if np.all((q >= lower) & (q <= upper)):
            pose = robot.forward_kinematics(q)
            assert _same(pose.position, position) and _same(pose.orientation, matrix_to_quat(rotation))
            assert _same(robot.jacobian(q), jacobian)
            assert _same(robot.joint_frames(q)[0], rotations) and _same(robot.joint_frames(q)[1], origins)


def test_end_effector_positions(robot: RobotModel) -> None:
    k = robot.kinematics
    qs = _configurations(robot, 200, 5)
    expected = np.empty((len(qs), 3))
    for row, q in enumerate(qs):
        rotations, origins = _frames(robot, q)
        expected[row] = kin.frame_pose(rotations, origins, k.ee_joint, k.ee_rot, k.ee_pos)[1]
    assert _same(robot.end_effector_positions(qs), expected)
    assert robot.end_effector_positions(qs[:0]).shape == (0, 3)


def test_check_limits(robot: RobotModel) -> None:
    """The verdict, the index and the clamped values (up to the first bad one) equal numba's."""
    core, n = robot._core_kinematics, robot.n_joints
    lower, upper = np.array(robot.lower_limits), np.array(robot.upper_limits)
    rng = np.random.default_rng(6)
    edges = np.stack([lower, upper, lower - LIMIT_TOLERANCE, upper + LIMIT_TOLERANCE, lower - 2 * LIMIT_TOLERANCE,
                      upper + 2 * LIMIT_TOLERANCE, lower - 0.5 * LIMIT_TOLERANCE, upper + 0.5 * LIMIT_TOLERANCE])
    specials = np.array([0.0, -0.0, math.nan, math.inf, -math.inf, 1e300])
    for trial in range(600):
        values = rng.uniform(np.maximum(lower, -4.0), np.minimum(upper, 4.0))
        for j in range(n):
            if rng.random() < 0.15:
                values[j] = rng.choice(edges[:, j])
            if rng.random() < 0.03:
                values[j] = rng.choice(specials)
        expected, got = values.copy(), values.copy()
        bad = kin.check_limits(expected, lower, upper, LIMIT_TOLERANCE)
        status, index = core.check_limits(got, LIMIT_TOLERANCE)
        if bad == -1:
            assert (status.name, index) == ("Ok", -1)
        elif bad <= -2:
            assert (status.name, index) == ("NotFinite", -2 - bad)
        else:
            assert (status.name, index) == ("BeyondLimits", bad)
        assert _same(got, expected), trial


@pytest.mark.parametrize("name", ["panda-fingers", "rail"])
def test_ik_with_prismatic_joints_and_branches(name: str, tmp_path_factory: pytest.TempPathFactory) -> None:
    robot = _robot(name, tmp_path_factory.getbasetemp())
    rng = np.random.default_rng(7)
    lower, upper = np.maximum(robot.lower_limits, -math.pi), np.minimum(robot.upper_limits, math.pi)
    reached = 0
    for _ in range(20):
        q = rng.uniform(lower, upper)
        seed = np.clip(q + rng.normal(scale=0.1, size=q.shape), robot.lower_limits, robot.upper_limits)
        result = solve_ik(robot, robot.forward_kinematics(q), seed)
        assert np.all(result.q >= robot.lower_limits) and np.all(result.q <= robot.upper_limits)
        reached += result.success
        if result.success:
            assert result.position_error <= 1e-4 and result.rotation_error <= 1e-3
    assert reached >= 15


def test_the_bound_robot_refuses_inconsistent_arrays(robot: RobotModel) -> None:
    from pfield._core import robot_kinematics as core_kinematics

    k, n = robot.kinematics, robot.n_joints
    with pytest.raises(ValueError, match="one row per joint"):
        core_kinematics.Robot(*k, robot.lower_limits[:-1], robot.upper_limits, LIMIT_TOLERANCE)
    with pytest.raises(ValueError, match="ee_joint"):
        core_kinematics.Robot(*k._replace(ee_joint=n), robot.lower_limits, robot.upper_limits, LIMIT_TOLERANCE)
    with pytest.raises(ValueError, match="joint"):
        robot._core_kinematics.point_jacobian(*_frames(robot, np.zeros(n)), n, np.zeros(3))
    with pytest.raises(ValueError, match="out"):
        robot._core_kinematics.jacobian(np.zeros(n), np.empty((6, n + 1)))
    out = np.full((6, n), 7.0)
    assert not robot._core_kinematics.jacobian(np.zeros(n + 1), out)  # the wrong count: Python words the error
    assert not robot._core_kinematics.jacobian(np.full(n, np.nan), out)
    assert np.all(out == 7.0)
