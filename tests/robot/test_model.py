"""RobotModel: loading, the compiled kinematics against pinocchio, Jacobians against finite differences."""

from __future__ import annotations

import math
import shutil
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from pfield import errors
from pfield.robot import RobotModel
from pfield.robot.catalog import example_robot_data_root
from pfield.spatial import Pose

Q0 = np.array([0.0, -0.6, 0.0, 0.9, 0.0, 1.5, 0.0])


def _random_configurations(robot: RobotModel, count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lower = np.maximum(robot.lower_limits, -np.pi)
    upper = np.minimum(robot.upper_limits, np.pi)
    return rng.uniform(lower, upper, size=(count, robot.n_joints))


def test_xarm_joints_limits_and_reference_fk(xarm: RobotModel) -> None:
    assert xarm.joint_names == tuple(f"joint{i}" for i in range(1, 8))
    assert xarm.end_effector == "link_eef"
    np.testing.assert_allclose(xarm.lower_limits[[1, 3, 5]], [-2.059, -0.19198, -1.69297])
    np.testing.assert_allclose(xarm.upper_limits[[1, 3, 5]], [2.0944, 3.927, np.pi])
    np.testing.assert_allclose(xarm.velocity_limits, 3.14)
    pose = xarm.forward_kinematics(Q0)
    np.testing.assert_allclose(pose.position, [0.30101404, 0.00000346, 0.49454543], atol=1e-6)
    # REFERENCE: "tool down" — the tool z axis points along world −z
    np.testing.assert_allclose(pose.rotation[:, 2], [0.0, 0.0, -1.0], atol=1e-4)


def test_panda_has_seven_arm_joints_and_tcp(panda: RobotModel) -> None:
    assert panda.joint_names == tuple(f"panda_joint{i}" for i in range(1, 8))
    assert panda.end_effector == "panda_hand_tcp"
    q = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    model = panda.pinocchio_model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    hand = data.oMf[model.getFrameId("panda_hand")]
    tcp = panda.forward_kinematics(q)
    # the TCP lies 0.1034 m along the hand's z axis
    np.testing.assert_allclose(tcp.position, hand.translation + 0.1034 * hand.rotation[:, 2], atol=1e-12)


@pytest.mark.parametrize("name", ["xarm7", "panda"])
def test_compiled_kinematics_equal_pinocchio(name: str, xarm: RobotModel, panda: RobotModel) -> None:
    robot = xarm if name == "xarm7" else panda
    model, core = robot.pinocchio_model, robot._core_kinematics
    data = model.createData()
    frame = model.getFrameId(robot.end_effector)
    worst_pose, worst_jac = 0.0, 0.0
    for q in _random_configurations(robot, 1000, seed=1):
        rot, pos, jac = core.end_effector_kinematics(q)
        origins = core.joint_frames(q)[1]
        reference = pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)
        placement = data.oMf[frame]
        worst_pose = max(worst_pose, np.abs(pos - placement.translation).max(), np.abs(rot - placement.rotation).max())
        worst_jac = max(worst_jac, np.abs(jac - reference).max())
        for j in range(robot.n_joints):  # every joint frame, not only the end effector
            worst_pose = max(worst_pose, np.abs(origins[j] - data.oMi[j + 1].translation).max())
    assert worst_pose < 1e-9
    assert worst_jac < 1e-9


@pytest.mark.parametrize("name", ["xarm7", "panda"])
def test_jacobian_equals_finite_differences(name: str, xarm: RobotModel, panda: RobotModel) -> None:
    robot = xarm if name == "xarm7" else panda
    h = 1e-6
    for q in _random_configurations(robot, 20, seed=2):
        q = np.clip(q, robot.lower_limits + 2 * h, robot.upper_limits - 2 * h)
        jac = robot.jacobian(q)
        base = robot.forward_kinematics(q)
        for j in range(robot.n_joints):
            step = np.zeros(robot.n_joints)
            step[j] = h
            plus, minus = robot.forward_kinematics(q + step), robot.forward_kinematics(q - step)
            np.testing.assert_allclose(jac[:3, j], (plus.position - minus.position) / (2 * h), atol=1e-7)
            # angular column: rotation vector of R(q + h) R(q)^T divided by h (world frame)
            delta = pin.log3(plus.rotation @ base.rotation.T)
            np.testing.assert_allclose(jac[3:, j], delta / h, atol=1e-5)


def test_from_urdf_with_package_paths_and_srdf(tmp_path: Path) -> None:
    root = example_robot_data_root()
    # a user copy of the URDF elsewhere, its package:// URIs resolved through package_paths
    urdf = tmp_path / "arm.urdf"
    shutil.copy(root / "robots/xarm_description/urdf/xarm7.urdf", urdf)
    robot = RobotModel.from_urdf(urdf, end_effector="link7", package_paths={"example-robot-data": root},
                                 srdf=root / "robots/xarm_description/srdf/xarm7.srdf")
    builtin = RobotModel.builtin("xarm7")
    assert robot.forward_kinematics(Q0).isclose(builtin.forward_kinematics(Q0), atol=1e-12)
    assert robot.disabled_pairs is not None and frozenset(("link1", "link2")) in robot.disabled_pairs
    assert len(robot.collision_model.geometryObjects) == 8


def test_unknown_builtin_lists_known_names() -> None:
    with pytest.raises(errors.InvalidInput, match=r"panda.*xarm7") as info:
        RobotModel.builtin("ur5")
    assert info.value.field == "robot"


def test_a_near_miss_of_a_builtin_name_is_named() -> None:
    with pytest.raises(errors.InvalidInput, match=r"unknown built-in robot \(did you mean 'panda'\?\); known: panda, "):
        RobotModel.builtin("Panada")


def test_the_constructor_given_a_path_points_to_from_urdf() -> None:
    """``RobotModel("robot.urdf", ...)`` is a natural first guess: it is refused naming the constructors to use."""
    with pytest.raises(errors.InvalidInput, match=r"RobotModel.from_urdf\(path, end_effector=LINK\) or "
                                                  r"RobotModel.builtin\(name\)") as info:
        RobotModel("robot.urdf", end_effector="tool0")  # type: ignore[arg-type]
    assert info.value.field == "loaded"


def test_unreadable_urdf(tmp_path: Path) -> None:
    with pytest.raises(errors.ResourceNotFound, match="urdf"):
        RobotModel.from_urdf(tmp_path / "missing.urdf", end_effector="tool")
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'/><joint name='j' type='revolute'>")
    with pytest.raises(errors.PfieldError):
        RobotModel.from_urdf(broken, end_effector="a")


def test_missing_package_root_is_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AMENT_PREFIX_PATH", "")
    root = example_robot_data_root()
    with pytest.raises(errors.ResourceNotFound, match="example-robot-data"):
        RobotModel.from_urdf(root / "robots/xarm_description/urdf/xarm7.urdf", end_effector="link_eef")


def test_missing_end_effector_lists_links() -> None:
    root = example_robot_data_root()
    with pytest.raises(errors.InvalidInput, match="link_eef") as info:
        RobotModel.from_urdf(root / "robots/xarm_description/urdf/xarm7.urdf", end_effector="gripper",
                             package_paths={"example-robot-data": root})
    assert info.value.field == "end_effector"
    with pytest.raises(errors.InvalidInput, match="a joint, not a link") as info:  # as RobotDescription asks
        RobotModel.from_urdf(root / "robots/xarm_description/urdf/xarm7.urdf", end_effector="joint7",
                             package_paths={"example-robot-data": root})
    assert info.value.field == "end_effector"


@pytest.mark.parametrize(
    ("q", "field"),
    [
        ([0.0] * 6, "joint_angles"),
        ([0.0] * 8, "joint_angles"),
        ([0.0, float("nan"), 0, 0, 0, 0, 0], "joint_angles"),
        ([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, float("inf")], "joint_angles"),
        ([0.0, 2.5, 0.0, 0.0, 0.0, 0.0, 0.0], "joint_angles[1]"),
        ([0.0, 0.0, 0.0, -0.5, 0.0, 0.0, 0.0], "joint_angles[3]"),
    ],
)
def test_bad_joint_angles_are_rejected(xarm: RobotModel, q: list[float], field: str) -> None:
    with pytest.raises(errors.InvalidInput) as info:
        xarm.forward_kinematics(q)
    assert info.value.field == field
    with pytest.raises(errors.InvalidInput):
        xarm.jacobian(q)


def test_float32_rounding_at_a_limit_is_clamped(xarm: RobotModel) -> None:
    q = Q0.copy()
    q[1] = float(np.float32(xarm.upper_limits[1])) + 5e-5
    at_limit = Q0.copy()
    at_limit[1] = xarm.upper_limits[1]
    assert xarm.forward_kinematics(q) == xarm.forward_kinematics(at_limit)


def test_forward_kinematics_returns_pose(xarm: RobotModel) -> None:
    pose = xarm.forward_kinematics(Q0)
    assert isinstance(pose, Pose)
    positions = xarm.end_effector_positions(np.stack([Q0, Q0]))
    np.testing.assert_allclose(positions, [pose.position, pose.position], atol=1e-12)


def test_mesh_uris_go_through_the_obstacle_resolver(tmp_path: Path) -> None:
    from pfield.geometry import ResourceResolver

    root = example_robot_data_root()
    resolver = ResourceResolver(package_paths={"example-robot-data": root})
    robot = RobotModel.from_urdf(root / "robots/xarm_description/urdf/xarm7.urdf", end_effector="link_eef",
                                 resolver=resolver)
    assert robot.collision_model.geometryObjects[0].meshPath.startswith(str(root))
    # a mesh outside the allowed places is refused, whatever pinocchio would do with it
    outside = tmp_path / "arm.urdf"
    outside.write_text(
        "<robot name='arm'><link name='base'><collision><geometry><mesh filename='/etc/passwd'/></geometry>"
        "</collision></link><link name='tool'/><joint name='j1' type='revolute'><parent link='base'/>"
        "<child link='tool'/><axis xyz='0 0 1'/><limit lower='-1' upper='1' velocity='1' effort='1'/></joint>"
        "</robot>")
    with pytest.raises(errors.ResourceNotAllowed):
        RobotModel.from_urdf(outside, end_effector="tool")


def test_named_configurations_come_from_the_srdf_group_states() -> None:
    """MoveIt-style named targets: the SRDF's group states, plus the Panda's ``ready`` alias."""
    from pfield.robot import RobotModel

    panda = RobotModel.builtin("panda")
    ready = (0.0, -0.785398, 0.0, -2.35619, 0.0, 1.5707, 0.785398)  # panda.srdf, group state "default"
    np.testing.assert_array_equal(panda.named_configuration("ready"), ready)
    np.testing.assert_array_equal(panda.named_configuration("default"), ready)
    assert sorted(panda.named_configurations()) == ["default", "ready"]
    xarm = RobotModel.builtin("xarm7")
    np.testing.assert_array_equal(xarm.named_configuration("hold-up"), (0, 0, 0, 0, 0, -1.5708, 0))
    np.testing.assert_array_equal(xarm.named_configuration("home"), np.zeros(7))
    with pytest.raises(errors.InvalidInput, match="known: hold-up, home") as info:
        xarm.named_configuration("ready")
    assert info.value.field == "name"


def test_named_configurations_of_a_urdf_with_an_srdf(tmp_path) -> None:
    from pfield.robot import RobotModel
    from pfield.robot.catalog import example_robot_data_root

    root = example_robot_data_root()
    srdf = tmp_path / "arm.srdf"
    srdf.write_text(
        '<robot name="xarm7"><group_state name="bent" group="xarm7">'
        + "".join(f'<joint name="joint{i}" value="{0.1 * i}"/>' for i in range(1, 8))
        + '</group_state><group_state name="partial" group="wrist"><joint name="joint7" value="1"/></group_state>'
        + '<group_state name="odd" group="xarm7"><joint name="joint1" value="x"/></group_state>'
        + '<group_state name="wide" group="xarm7">'
        + "".join(f'<joint name="joint{i}" value="{9.0 if i == 1 else 0.0}"/>' for i in range(1, 8))
        + '</group_state></robot>')
    robot = RobotModel.from_urdf(root / "robots/xarm_description/urdf/xarm7.urdf", "link_eef",
                                 {"example-robot-data": root}, srdf=srdf)
    assert list(robot.named_configurations()) == ["bent"]  # states of other groups / bad values are skipped
    np.testing.assert_allclose(robot.named_configuration("bent"), 0.1 * np.arange(1, 8))
    with pytest.raises(errors.InvalidInput) as info:  # outside the limits: skipped at load, and said so when asked
        robot.named_configuration("wide")
    assert "the SRDF's group state 'wide' was skipped when" in info.value.reason and "joint1" in info.value.reason
    assert list(robot.skipped_group_states) == ["wide"]
    from pfield.cli._manipulator import start_joints

    with pytest.raises(errors.InvalidInput) as info:  # pfield plan --start-joints wide says the same
        start_joints(robot, "wide")
    assert info.value.field == "--start-joints" and "was skipped when" in info.value.reason
    no_srdf = RobotModel.from_urdf(root / "robots/xarm_description/urdf/xarm7.urdf", "link_eef",
                                   {"example-robot-data": root})
    assert no_srdf.named_configurations() == {}
    with pytest.raises(errors.InvalidInput, match="known: none"):
        no_srdf.named_configuration("home")


def test_mid_configuration_is_the_middle_of_each_range_and_zero_for_a_continuous_joint(tmp_path: Path) -> None:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        "<robot name='arm'><link name='base'/><link name='l1'/><link name='tool'/>"
        "<joint name='j1' type='revolute'><parent link='base'/><child link='l1'/><axis xyz='0 0 1'/>"
        "<limit lower='-1' upper='0.5' velocity='1' effort='1'/></joint>"
        "<joint name='j2' type='continuous'><parent link='l1'/><child link='tool'/><origin xyz='0.1 0 0'/>"
        "<axis xyz='0 0 1'/><limit velocity='1' effort='1'/></joint></robot>")
    robot = RobotModel.from_urdf(urdf, end_effector="tool")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no inf - inf on the continuous joint
        middle = robot.mid_configuration
    assert middle.tolist() == [-0.25, 0.0]
    middle[0] = 9.0  # a fresh array: the robot's own is untouched
    assert robot.mid_configuration[0] == -0.25


@pytest.mark.parametrize("angle", [0.0, 0.5, -2.0, 3.0])
def test_a_locked_continuous_joint_is_turned_by_its_angle(tmp_path: Path, angle: float) -> None:
    """pinocchio keeps a continuous joint as (cos θ, sin θ): the locked value is the angle θ (it was written into
    the cos slot, which scaled the rotation: a quaternion of norm 0.71 at 0, a link fit that failed)."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        "<robot name='arm'><link name='base'/>"
        "<link name='l1'><collision><origin xyz='0.1 0 0'/><geometry><box size='0.2 0.04 0.04'/></geometry>"
        "</collision></link><link name='tool'/>"
        "<joint name='j1' type='continuous'><parent link='base'/><child link='l1'/><axis xyz='0 0 1'/>"
        "<limit velocity='1' effort='1'/></joint>"
        "<joint name='j2' type='revolute'><parent link='l1'/><child link='tool'/><origin xyz='0.2 0 0'/>"
        "<axis xyz='0 1 0'/><limit lower='-1' upper='1' velocity='1' effort='1'/></joint></robot>")
    free = RobotModel.from_urdf(urdf, end_effector="tool")
    locked = RobotModel.from_urdf(urdf, end_effector="tool", locked_joints={"j1": angle})
    assert locked.joint_names == ("j2",)
    for q2 in (-0.7, 0.0, 0.4):
        pose, expected = locked.forward_kinematics([q2]), free.forward_kinematics([angle, q2])
        np.testing.assert_allclose(pose.position, expected.position, atol=1e-12)
        np.testing.assert_allclose(abs(np.dot(pose.orientation, expected.orientation)), 1.0, atol=1e-12)
    np.testing.assert_allclose(locked.forward_kinematics([0.0]).position, [0.2 * math.cos(angle),
                                                                            0.2 * math.sin(angle), 0.0], atol=1e-12)


def test_a_joint_of_several_degrees_of_freedom_is_locked_at_its_neutral_configuration(tmp_path: Path) -> None:
    """The loader asks to lock a planar or floating joint; one value cannot say where, so it is held at pinocchio's
    neutral configuration, given as 0; another value is refused saying so."""
    urdf = tmp_path / "base.urdf"
    urdf.write_text(
        "<robot name='base'><link name='world'/><link name='body'/><link name='l1'><collision><origin xyz='0.1 0 0'/>"
        "<geometry><box size='0.2 0.04 0.04'/></geometry></collision></link><link name='tool'/>"
        "<joint name='float' type='planar'><parent link='world'/><child link='body'/></joint>"
        "<joint name='j1' type='revolute'><parent link='body'/><child link='l1'/><axis xyz='0 0 1'/>"
        "<limit lower='-1' upper='1' velocity='1' effort='1'/></joint>"
        "<joint name='j2' type='fixed'><parent link='l1'/><child link='tool'/><origin xyz='0.2 0 0'/></joint></robot>")
    with pytest.raises(errors.InvalidInput, match="lock it"):
        RobotModel.from_urdf(urdf, end_effector="tool")
    robot = RobotModel.from_urdf(urdf, end_effector="tool", locked_joints={"float": 0.0})
    assert robot.joint_names == ("j1",)
    np.testing.assert_allclose(robot.forward_kinematics([0.5]).position, [0.2 * math.cos(0.5), 0.2 * math.sin(0.5),
                                                                          0.0], atol=1e-12)
    with pytest.raises(errors.InvalidInput, match="neutral configuration only: give 0") as info:
        RobotModel.from_urdf(urdf, end_effector="tool", locked_joints={"float": 0.3})
    assert info.value.field == "locked_joints['float']"


def test_end_effector_positions_of_any_array_layout() -> None:
    """A planned path's joint array is read-only; lists and Fortran-ordered arrays are accepted too."""
    robot = RobotModel.builtin("xarm7")
    qs = np.stack([robot.mid_configuration, np.zeros(7), robot.mid_configuration + 0.1])
    frozen = qs.copy()
    frozen.setflags(write=False)
    expected = np.array([robot.forward_kinematics(q).position for q in qs])
    for values in (qs, frozen, qs.tolist(), np.asfortranarray(qs)):
        np.testing.assert_allclose(robot.end_effector_positions(values), expected, atol=1e-12)


def test_a_urdf_with_a_gazebo_plugin_loads_and_only_mesh_files_are_resolved() -> None:
    """example-robot-data's UR URDFs name ``<plugin filename="libgazebo_ros_control.so">``: not a mesh, and no file
    of the robot's; the loader resolves ``<mesh filename=…>`` alone (it used to refuse the robot for that plugin)."""
    root = example_robot_data_root()
    urdf = root / "robots/ur_description/urdf/ur5_robot.urdf"
    assert 'filename="libgazebo_ros_control.so"' in urdf.read_text()
    robot = RobotModel.from_urdf(urdf, end_effector="tool0", package_paths={"example-robot-data": root})
    assert robot.n_joints == 6
    q = np.array([0.3, -1.2, 1.4, -1.7, -1.57, 0.2])
    data = robot.pinocchio_model.createData()
    pin.framesForwardKinematics(robot.pinocchio_model, data, robot.pinocchio_configuration(q))
    expected = data.oMf[robot.pinocchio_model.getFrameId("tool0")]
    assert np.allclose(robot.forward_kinematics(q).position, expected.translation, atol=1e-12)
