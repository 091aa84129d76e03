"""The compiled core's robot kinematics (``src/core/robot/kinematics``): pinocchio's frames and Jacobians, finite
differences, and numba's bits.

:class:`~pfield.robot.RobotModel` and every planner call the core for every kinematic quantity. It replaced the numba
kernels of ``pfield.robot._kinematics`` (issue 32) to the bit, signed zeros included, so no planner's exact figure
moved; those kernels are gone. Each function is checked here against an oracle that needs no numba — pinocchio's
joint and end-effector placements and its frame Jacobian, the rotation-and-translation formula of a frame pose,
central differences of a point fixed to a link, the limits rule written out in Python — and its outputs are held to
numba's bits by digests: the first 16 hex digits of the sha256 of every output on the seeded configurations, per
robot, computed from the core after checking, configuration by configuration, that numba's kernels gave the same
bytes. The robots have revolute, continuous and prismatic joints, trees (the Panda's fingers branch off its hand, so
some columns are zero) and an end effector on the base; the configurations lie within the limits, beyond them and
far out (sin/cos argument reduction: the digests hold on this machine class's libm).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from digests import digest
from pfield.errors import InvalidInput
from pfield.robot import RobotModel
from pfield.robot.catalog import builtin_spec, example_robot_data_root
from pfield.robot.ik import solve_ik
from pfield.robot.model import LIMIT_TOLERANCE
from pfield.spatial import quaternion_from_matrix

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
def name(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture
def robot(name: str, tmp_path_factory: pytest.TempPathFactory) -> RobotModel:
    return _robot(name, tmp_path_factory.getbasetemp())


def _same(a: object, b: object) -> bool:
    """Equal to the bit (signed zeros and NaN payloads included)."""
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return x.shape == y.shape and x.tobytes() == y.tobytes()


def _digest(values: Iterator[Any]) -> str:
    """The first 16 hex digits of :func:`digests.digest`."""
    return digest(values)[:16]


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
    return robot._core_kinematics.joint_frames(q)  # type: ignore[no-any-return]


def _pinocchio(robot: RobotModel, q: np.ndarray) -> tuple[Any, Any, np.ndarray]:
    """Pinocchio's model, its data after the forward kinematics of q (frames updated) and the end effector's frame
    Jacobian (world-aligned at the frame's origin), joint j being pinocchio's joint j + 1."""
    model = robot.pinocchio_model
    data = model.createData()
    configuration = robot.pinocchio_configuration(q)
    pin.framesForwardKinematics(model, data, configuration)  # every joint (the Jacobian updates only its chain)
    jacobian = pin.computeFrameJacobian(model, data, configuration, model.getFrameId(robot.end_effector),
                                        pin.LOCAL_WORLD_ALIGNED)
    return model, data, jacobian


# numba's outputs (pfield.robot._kinematics) on each test's seeded inputs, digested per robot after the core was
# checked equal to them to the byte, input by input
FRAMES_DIGESTS = {"panda": "dafe13f57d03e139", "panda-fingers": "f9c36c0bf404af17", "ur5": "dab7069042d9c113",
                  "rail": "e6d185653320160a", "rail-base": "e6d185653320160a"}
FRAME_POSE_DIGESTS = {"panda": "c554d64ff8351760", "panda-fingers": "ae4a216f3833e457", "ur5": "ffd09b198f93a092",
                      "rail": "ab83d05f3613df71", "rail-base": "ab83d05f3613df71"}
POINT_JACOBIAN_DIGESTS = {"panda": "d1d1251b06f162b2", "panda-fingers": "5ab48fa2babb4e15", "ur5": "ad5bf2ed597bc93a",
                          "rail": "5658e0817a944613", "rail-base": "5658e0817a944613"}
END_EFFECTOR_DIGESTS = {"panda": "8f7aaefa73ea90c1", "panda-fingers": "9fe55a7381aedb23", "ur5": "0951a8ec62a035a1",
                        "rail": "38b2ca2eb7f79dc1", "rail-base": "37f7bfa4913e7fbe"}
POSITIONS_DIGESTS = {"panda": "58742ffe6a1c6cc9", "panda-fingers": "00025a8c120cedf1", "ur5": "eb5ea6bfe4a0eea5",
                     "rail": "7ec9164a83efee29", "rail-base": "e71ca216a3f62305"}
CHECK_LIMITS_DIGESTS = {"panda": "99b064d0f390d787", "panda-fingers": "3e21a97a2443b804", "ur5": "f0bdf65ef97c5900",
                        "rail": "1311a6694eb8c18a", "rail-base": "1311a6694eb8c18a"}


def _joint_frames(robot: RobotModel) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    for q in _configurations(robot, 300, 1):
        yield q, *_frames(robot, q)


def test_joint_frames_are_pinocchios(robot: RobotModel, name: str) -> None:
    scale = 1e-12 * (1.0 + 60.0)  # far out, a prismatic joint moves its child 60 m
    assert robot.pinocchio_model.njoints == robot.n_joints + 1
    for q, rotations, origins in _joint_frames(robot):
        _, data, _ = _pinocchio(robot, q)
        for j in range(robot.n_joints):
            np.testing.assert_allclose(rotations[j], data.oMi[j + 1].rotation, rtol=0, atol=1e-13)
            np.testing.assert_allclose(origins[j], data.oMi[j + 1].translation, rtol=0, atol=scale)
    assert _digest(value for _, rotations, origins in _joint_frames(robot) for value in (rotations, origins)) \
        == FRAMES_DIGESTS[name]


def _frame_poses(robot: RobotModel) -> Iterator[tuple[np.ndarray, np.ndarray, int, np.ndarray, np.ndarray,
                                                      tuple[np.ndarray, np.ndarray]]]:
    """(rotations, origins, joint, local rotation, local position, pose) of a random placement on every joint."""
    core, n = robot._core_kinematics, robot.n_joints
    rng = np.random.default_rng(2)
    for q in _configurations(robot, 100, 2):
        rotations, origins = _frames(robot, q)
        for joint in range(-1, n):
            local_rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
            local_position = rng.normal(scale=0.3, size=3)
            yield rotations, origins, joint, local_rotation, local_position, core.frame_pose(
                rotations, origins, joint, local_rotation, local_position)


def test_frame_pose_is_the_joint_frame_times_the_placement(robot: RobotModel, name: str) -> None:
    """R = R_j R_local, p = R_j p_local + o_j (the base's frame the identity); a point's transform is the pose's."""
    core = robot._core_kinematics
    for rotations, origins, joint, local_rotation, local_position, (rotation, position) in _frame_poses(robot):
        frame = (np.eye(3), np.zeros(3)) if joint < 0 else (rotations[joint], origins[joint])
        np.testing.assert_allclose(rotation, frame[0] @ local_rotation, rtol=0, atol=1e-15)
        np.testing.assert_allclose(position, frame[0] @ local_position + frame[1], rtol=0,
                                   atol=1e-15 * (1 + np.abs(frame[1]).max()))
        assert _same(core.frame_pose(rotations, origins, joint, np.eye(3), local_position)[1], position)
    assert _digest(value for *_, pose in _frame_poses(robot) for value in pose) == FRAME_POSE_DIGESTS[name]


def _point_jacobians(robot: RobotModel) -> Iterator[tuple[np.ndarray, int, np.ndarray, np.ndarray, np.ndarray]]:
    """(q, joint, world point, 6 x n point Jacobian, 3 x n linear one) of a random point on every joint's link."""
    core, n = robot._core_kinematics, robot.n_joints
    rng = np.random.default_rng(3)
    for q in _configurations(robot, 100, 3):
        rotations, origins = _frames(robot, q)
        for joint in range(-1, n):
            point = rng.normal(scale=0.5, size=3)
            yield q, joint, point, core.point_jacobian(rotations, origins, joint, point), \
                core.linear_point_jacobian(rotations, origins, joint, point)


def test_point_jacobians_are_finite_differences(robot: RobotModel, name: str) -> None:
    """The point fixed to joint's link at the world point p moves at J_lin q̇ and the link turns at J_ang q̇: central
    differences of the point's world position and of the link's rotation (its rotation vector), every joint; the
    linear rows are point_jacobian's."""
    h = 1e-6
    for count, (q, joint, point, jacobian, linear) in enumerate(_point_jacobians(robot)):
        assert _same(linear, jacobian[:3])
        if joint < 0:
            assert not jacobian.any()  # the base does not move
            continue
        if count % 4:  # differences for every fourth: each takes 2n kinematics
            continue
        rotations, origins = _frames(robot, q)
        local = rotations[joint].T @ (point - origins[joint])
        for j in range(robot.n_joints):
            step = np.zeros(robot.n_joints)
            step[j] = h
            (r_plus, o_plus), (r_minus, o_minus) = _frames(robot, q + step), _frames(robot, q - step)
            moved = (r_plus[joint] @ local + o_plus[joint] - r_minus[joint] @ local - o_minus[joint]) / (2 * h)
            np.testing.assert_allclose(jacobian[:3, j], moved, rtol=0, atol=1e-6 * (1 + np.abs(local).max()))
            turned = pin.log3(r_plus[joint] @ r_minus[joint].T) / (2 * h)
            np.testing.assert_allclose(jacobian[3:, j], turned, rtol=0, atol=1e-6)
    assert _digest(value for *_, jacobian, linear in _point_jacobians(robot) for value in (jacobian, linear)) \
        == POINT_JACOBIAN_DIGESTS[name]


def _end_effector(robot: RobotModel) -> Iterator[tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]]:
    for q in _configurations(robot, 300, 4):
        yield q, robot._core_kinematics.end_effector_kinematics(q)


def test_end_effector_kinematics_are_pinocchios_and_the_public_methods(robot: RobotModel, name: str) -> None:
    lower, upper = robot.lower_limits, robot.upper_limits
    frame = robot.pinocchio_model.getFrameId(robot.end_effector)
    for q, (rotation, position, jacobian) in _end_effector(robot):
        _, data, reference = _pinocchio(robot, q)
        np.testing.assert_allclose(rotation, data.oMf[frame].rotation, rtol=0, atol=1e-13)
        np.testing.assert_allclose(position, data.oMf[frame].translation, rtol=0, atol=1e-12 * 61.0)
        np.testing.assert_allclose(jacobian, reference, rtol=0, atol=1e-12 * 61.0)
        if np.all((q >= lower) & (q <= upper)):
            pose = robot.forward_kinematics(q)
            assert _same(pose.position, position)
            np.testing.assert_allclose(pose.orientation, quaternion_from_matrix(rotation), rtol=0, atol=1e-15)
            assert _same(robot.jacobian(q), jacobian)
            rotations, origins = _frames(robot, q)
            assert _same(robot.joint_frames(q)[0], rotations) and _same(robot.joint_frames(q)[1], origins)
    assert _digest(value for _, outputs in _end_effector(robot) for value in outputs) == END_EFFECTOR_DIGESTS[name]


def test_condition_number_is_the_jacobians_singular_value_ratio(robot: RobotModel, name: str) -> None:
    """κ = σ_max/σ_min of the end-effector Jacobian (MoveIt Servo's singularity measure, from a 6×6 eigenproblem in
    the core) against numpy's SVD on the seeded configurations within the limits; a rank-deficient Jacobian (an arm
    with fewer than 6 joints, or at a singularity) has κ = inf or beyond 1e7; a refused q is refused by field."""
    lower, upper = robot.lower_limits, robot.upper_limits
    checked = 0
    for q, (_, _, jacobian) in _end_effector(robot):
        if not np.all((q >= lower) & (q <= upper)):
            continue
        singular = np.linalg.svd(jacobian, compute_uv=False)
        kappa = robot.condition_number(q)
        if robot.n_joints >= 6 and singular[-1] > 1e-6 * singular[0]:
            assert kappa == pytest.approx(singular[0] / singular[-1], rel=1e-9)
        else:
            assert kappa == math.inf or kappa > 1e7
        checked += 1
    assert checked >= 3
    with pytest.raises(InvalidInput, match="joint_angles"):
        robot.condition_number(np.full(robot.n_joints, math.nan))


def test_end_effector_positions(robot: RobotModel, name: str) -> None:
    k, core = robot.kinematics, robot._core_kinematics
    qs = _configurations(robot, 200, 5)
    expected = np.empty((len(qs), 3))
    for row, q in enumerate(qs):
        rotations, origins = _frames(robot, q)
        expected[row] = core.frame_pose(rotations, origins, k.ee_joint, k.ee_rot, k.ee_pos)[1]
    positions = robot.end_effector_positions(qs)
    assert _same(positions, expected)
    assert robot.end_effector_positions(qs[:0]).shape == (0, 3)
    assert _digest(iter([positions])) == POSITIONS_DIGESTS[name]


def _check_limits_reference(values: np.ndarray, lower: np.ndarray, upper: np.ndarray, tolerance: float) -> int:
    """The rule in Python: clamp onto [lower, upper] in place up to the first bad value; −1 if none, else its index
    (beyond a limit by more than ``tolerance``) or −2 − index (not finite)."""
    for i, v in enumerate(values):
        if not math.isfinite(v):
            return -2 - i
        if v < lower[i] - tolerance or v > upper[i] + tolerance:
            return i
        values[i] = min(max(v, lower[i]), upper[i])
    return -1


def _limit_checks(robot: RobotModel) -> Iterator[tuple[np.ndarray, np.ndarray, Any, int]]:
    """(values, clamped, status, index) of 600 random vectors, some values at, within and beyond the tolerance, some
    not finite."""
    core, n = robot._core_kinematics, robot.n_joints
    lower, upper = np.array(robot.lower_limits), np.array(robot.upper_limits)
    rng = np.random.default_rng(6)
    edges = np.stack([lower, upper, lower - LIMIT_TOLERANCE, upper + LIMIT_TOLERANCE, lower - 2 * LIMIT_TOLERANCE,
                      upper + 2 * LIMIT_TOLERANCE, lower - 0.5 * LIMIT_TOLERANCE, upper + 0.5 * LIMIT_TOLERANCE])
    specials = np.array([0.0, -0.0, math.nan, math.inf, -math.inf, 1e300])
    for _ in range(600):
        values = rng.uniform(np.maximum(lower, -4.0), np.minimum(upper, 4.0))
        for j in range(n):
            if rng.random() < 0.15:
                values[j] = rng.choice(edges[:, j])
            if rng.random() < 0.03:
                values[j] = rng.choice(specials)
        clamped = values.copy()
        status, index = core.check_limits(clamped, LIMIT_TOLERANCE)
        yield values, clamped, status, index


def test_check_limits(robot: RobotModel, name: str) -> None:
    """The verdict, the index and the clamped values (up to the first bad one) are the rule's."""
    lower, upper = np.array(robot.lower_limits), np.array(robot.upper_limits)
    record: list[Any] = []
    for values, clamped, status, index in _limit_checks(robot):
        expected = values.copy()
        bad = _check_limits_reference(expected, lower, upper, LIMIT_TOLERANCE)
        if bad == -1:
            assert (status.name, index) == ("Ok", -1)
        elif bad <= -2:
            assert (status.name, index) == ("NotFinite", -2 - bad)
        else:
            assert (status.name, index) == ("BeyondLimits", bad)
        assert _same(clamped, expected)
        record += [clamped, np.int64(index)]
    assert _digest(iter(record)) == CHECK_LIMITS_DIGESTS[name]


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
    from pfield._core import robot as bound

    k, n = robot.kinematics, robot.n_joints
    limits = (robot.velocity_limits, robot.acceleration_limits)
    with pytest.raises(ValueError, match="one entry per joint"):
        bound.Robot(*k, robot.lower_limits[:-1], robot.upper_limits, *limits)
    with pytest.raises(ValueError, match="ee_joint"):
        bound.Robot(*k._replace(ee_joint=n), robot.lower_limits, robot.upper_limits, *limits)
    with pytest.raises(ValueError, match="joint"):
        robot._core_kinematics.point_jacobian(*_frames(robot, np.zeros(n)), n, np.zeros(3))
    with pytest.raises(ValueError, match="out"):
        robot._core_kinematics.jacobian(np.zeros(n), np.empty((6, n + 1)))
    out = np.full((6, n), 7.0)
    assert not robot._core_kinematics.jacobian(np.zeros(n + 1), out)  # the wrong count: Python words the error
    assert not robot._core_kinematics.jacobian(np.full(n, np.nan), out)
    assert np.all(out == 7.0)
