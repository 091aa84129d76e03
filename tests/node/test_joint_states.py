"""``/joint_states`` replaces ``joint_angles`` on the manager; operator twists in the end-effector frame."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import message_from_yaml
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.geometry_msgs import PoseStamped
from pfield.interfaces.sensor_msgs import JointState
from pfield.node._base import Bus
from pfield.node.manager import ManagerNode
from pfield.robot.model import MEASURED_BOUNDS_ERROR
from pfield.spatial import rotate_vectors

Q = [0.0, -0.3, 0.0, 0.6, 0.0, 0.9, 0.0]
BALL = "{obstacles: [{frame_id: ball, type: Sphere, group: Static, pose: {position: {x: 0.5, y: 0.0, z: 0.3}}, " \
       "radius: 0.05}]}"


@pytest.fixture(scope="module")
def robot() -> Any:
    from pfield.robot import RobotModel

    return RobotModel.builtin("xarm7")


@pytest.fixture
def node(robot: Any) -> ManagerNode:
    manager = ManagerNode(Bus(), robot)
    manager.on_obstacles(message_from_yaml(pfi.ObstacleArray, BALL))
    manager.on_goal(message_from_yaml(PoseStamped, "{pose: {position: {x: 0.4, y: 0.2, z: 0.4}}}"))
    return manager


def joint_states(robot: Any, q: list[float]) -> JointState:
    """``q`` as a driver might publish it: reversed order, with a gripper joint the model does not have."""
    names = [*reversed(robot.joint_names), "drive_joint"]
    return JointState(name=names, position=[*reversed(q), 0.4], velocity=[0.0] * 8)


def whole_body(**fields: Any) -> dict[str, Any]:
    return {"planning_method": "whole_body", "delta_time": 0.02} | fields


def test_joint_states_replace_joint_angles(node: ManagerNode, robot: Any) -> None:
    node.on_joint_states(joint_states(robot, Q))
    assert node.joint_states.held is not None and node.joint_states.held.positions.tolist() == Q
    for service, model in ((node.compute_autonomy_vector, pfi.ComputeAutonomyVector_Request),
                           (node.compute_assistance, pfi.ComputeAssistance_Request)):
        node.on_joint_states(joint_states(robot, Q))  # a driver publishes every few ms: fresh under any load
        implicit = service(model.model_validate(whole_body()))
        explicit = service(model.model_validate(whole_body(joint_angles=Q)))
        assert implicit.autonomy_vector.twist == explicit.autonomy_vector.twist
        assert implicit.autonomy_vector.twist != type(implicit.autonomy_vector.twist)()
    node.on_joint_states(joint_states(robot, Q))
    plan = node.plan_path(pfi.PlanPath_Request.model_validate({"planning_method": "whole_body", "max_iterations": 50}))
    assert plan.joint_trajectory.points[0].positions == pytest.approx(Q)


def test_task_space_without_a_query_pose_is_answered_at_the_measured_pose(node: ManagerNode, robot: Any) -> None:
    node.on_joint_states(joint_states(robot, Q))
    pose = robot.forward_kinematics(Q)
    given = {"query_pose": {"pose": {"position": dict(zip("xyz", pose.position.tolist(), strict=True)),
                                     "orientation": dict(zip("xyzw", pose.orientation.tolist(), strict=True))}}}
    implicit = node.compute_autonomy_vector(pfi.ComputeAutonomyVector_Request())
    explicit = node.compute_autonomy_vector(pfi.ComputeAutonomyVector_Request.model_validate(given))
    assert implicit.autonomy_vector.twist == explicit.autonomy_vector.twist


def test_missing_or_stale_joint_states_say_what_to_do(node: ManagerNode, robot: Any) -> None:
    request = pfi.ComputeAutonomyVector_Request.model_validate(whole_body())
    with pytest.raises(InvalidInput, match="no joint state received yet: publish sensor_msgs/JointState on "
                                           "/joint_states"):
        node.compute_autonomy_vector(request)
    message = joint_states(robot, Q)
    node.joint_states.update(message.name, message.position, message.velocity, now=time.monotonic() - 5.0)
    with pytest.raises(InvalidInput, match=r"is 5(\.\d+)? s old, beyond joint_state_timeout = 1 s"):
        node.compute_autonomy_vector(request)
    with pytest.raises(InvalidInput, match="starting_joint_angles"):
        node.plan_path(pfi.PlanPath_Request.model_validate({"planning_method": "whole_body"}))
    node.set_parameters({"joint_state_timeout": 0.0})  # 0: any age
    assert node.compute_autonomy_vector(request).autonomy_vector.header.frame_id == "world"
    with pytest.raises(InvalidInput, match="joint_state_timeout"):
        node.set_parameters({"joint_state_timeout": -1.0})
    assert node.get_parameters()["joint_state_timeout"] == 0.0


def test_refused_joint_states_are_named_where_a_request_needs_one(node: ManagerNode, robot: Any) -> None:
    """Messages that arrive and are refused are not a silent driver: the request's error says how many were refused
    and why the last was; a good message clears that."""
    request = pfi.ComputeAutonomyVector_Request.model_validate(whole_body())
    wrong = joint_states(robot, Q).model_copy(update={"name": ["joint1"], "position": [0.0], "velocity": []})
    for _ in range(3):
        with pytest.raises(InvalidInput):
            node.on_joint_states(wrong)
    with pytest.raises(InvalidInput, match=r"no joint state taken yet: 3 message\(s\) on /joint_states were refused, "
                                           r"the last: joint_states.name=.*lacks the joints"):
        node.compute_autonomy_vector(request)
    message = joint_states(robot, Q)
    node.joint_states.update(message.name, message.position, message.velocity, now=time.monotonic() - 5.0)
    with pytest.raises(InvalidInput) as fresh:  # the good one, stale: no refusal since it
        node.compute_autonomy_vector(request)
    assert "refused" not in str(fresh.value) and "is the robot driver running?" in str(fresh.value)
    with pytest.raises(InvalidInput):
        node.on_joint_states(wrong)
    with pytest.raises(InvalidInput, match=r"beyond joint_state_timeout = 1 s; 1 message\(s\) on /joint_states were "
                                           r"refused since, the last: joint_states.name"):
        node.compute_autonomy_vector(request)


@pytest.mark.parametrize(("fields", "field", "reason"), [
    ({"name": ["joint1"], "position": [0.0], "velocity": []}, "joint_states.name", "lacks the joints"),
    ({"position": [0.0] * 7}, "joint_states.position", "one value per name"),
    ({"velocity": [0.0] * 3}, "joint_states.velocity", "empty or have one value per name"),
    ({"position": [float("nan")] + [0.0] * 7}, "joint_states.position", "finite"),
    ({"position": [0.0] * 6 + [9.0, 0.0]}, r"joint_states.position\[0\]", "outside the limits"),
])
def test_bad_joint_states_are_refused_whole(node: ManagerNode, robot: Any, fields: dict[str, Any], field: str,
                                            reason: str) -> None:
    node.on_joint_states(joint_states(robot, Q))
    before = node.joint_states.held
    message = joint_states(robot, Q).model_copy(update=fields)
    with pytest.raises(InvalidInput, match=field) as error:
        node.on_joint_states(message)
    assert reason in str(error.value) and node.joint_states.held is before


def test_a_measured_position_just_past_a_limit_is_taken_at_the_limit(node: ManagerNode, robot: Any) -> None:
    # a robot held at a limit reports positions past it; up to MEASURED_BOUNDS_ERROR they count as at the limit
    lower = float(robot.lower_limits[3])
    past = list(Q)
    past[3] = lower - 0.9e-3
    node.on_joint_states(joint_states(robot, past))
    held = node.joint_states.held
    assert held is not None and held.positions[3] == lower
    assert list(held.positions[:3]) == list(Q[:3]) and list(held.positions[4:]) == list(Q[4:])
    past[3] = lower - MEASURED_BOUNDS_ERROR - 1e-3  # farther: the state is wrong, refused whole
    with pytest.raises(InvalidInput, match=r"joint_states.position\[3\]") as error:
        node.on_joint_states(joint_states(robot, past))
    assert "outside the limits" in str(error.value) and node.joint_states.held is held


def test_duplicate_joint_names_are_refused(node: ManagerNode, robot: Any) -> None:
    names = [*robot.joint_names, "joint1"]
    with pytest.raises(InvalidInput, match="named twice"):
        node.on_joint_states(JointState(name=names, position=[0.0] * 8))
    assert node.joint_states.held is None


def test_a_twist_in_the_end_effector_frame_is_rotated_by_forward_kinematics(node: ManagerNode, robot: Any) -> None:
    """The operator's tool-frame twist equals the world twist R·v, R = FK(q)'s rotation (exact)."""
    q = [0.3, -0.2, 0.4, 0.7, -0.5, 0.9, 1.1]
    tool = {"linear": {"x": 0.01, "y": -0.02, "z": 0.015}, "angular": {"x": 0.1, "y": 0.0, "z": -0.2}}
    orientation = robot.forward_kinematics(q).orientation
    linear = rotate_vectors(orientation, [0.01, -0.02, 0.015])
    angular = rotate_vectors(orientation, [0.1, 0.0, -0.2])
    world = {"linear": dict(zip("xyz", linear.tolist(), strict=True)),
             "angular": dict(zip("xyz", angular.tolist(), strict=True))}
    in_tool = node.compute_assistance(pfi.ComputeAssistance_Request.model_validate(whole_body(
        joint_angles=q, arbitration="safety_only", user_command={"header": {"frame_id": "link_eef"}, "twist": tool})))
    in_world = node.compute_assistance(pfi.ComputeAssistance_Request.model_validate(whole_body(
        joint_angles=q, arbitration="safety_only", user_command={"twist": world})))
    assert in_tool.joint_velocities == pytest.approx(in_world.joint_velocities, abs=1e-12)
    assert in_tool.blended_command.twist == in_world.blended_command.twist or np.allclose(
        [in_tool.blended_command.twist.linear.x, in_tool.blended_command.twist.angular.z],
        [in_world.blended_command.twist.linear.x, in_world.blended_command.twist.angular.z], atol=1e-12)
    # the rotation is not the identity here: the tool-frame numbers differ from the world's
    assert abs(linear[0] - 0.01) > 1e-3
    # the same holds from the measured joints, and in task space from the query pose's orientation
    node.on_joint_states(joint_states(robot, q))
    measured = node.compute_assistance(pfi.ComputeAssistance_Request.model_validate(whole_body(
        arbitration="safety_only", user_command={"header": {"frame_id": "link_eef"}, "twist": tool})))
    assert measured.joint_velocities == pytest.approx(in_world.joint_velocities, abs=1e-12)


def test_other_frames_are_still_refused(node: ManagerNode) -> None:
    before = node.state
    with pytest.raises(UnknownFrame, match=r"user_command\.header\.frame_id='link5': twists must be given in the "
                                           r"fixed frame 'world', the end-effector frame 'link_eef', or a frame"):
        node.compute_assistance(pfi.ComputeAssistance_Request.model_validate(whole_body(
            joint_angles=Q, user_command={"header": {"frame_id": "link5"}})))
    with pytest.raises(InvalidInput, match=r"joint_angles"):  # an end-effector twist with no joints to rotate it by
        node.compute_assistance(pfi.ComputeAssistance_Request.model_validate(whole_body(
            user_command={"header": {"frame_id": "link_eef"}})))
    assert node.state is before
