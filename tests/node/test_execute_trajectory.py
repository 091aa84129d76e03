"""``/pfield/execute_trajectory`` of the transport-free manager: without the ROS 2 transport (the HTTP node) it
answers that execution needs ROS 2; bad input is refused before anything; the controller's action name is a
parameter. The ROS 2 behaviour is tested in tests/transport/test_ros2_execute.py."""

from __future__ import annotations

import pytest

from pfield.errors import InvalidInput
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.node._base import Bus
from pfield.node.manager import ManagerNode
from pfield.robot import RobotModel


@pytest.fixture(scope="module")
def node() -> ManagerNode:
    return ManagerNode(Bus(), RobotModel.builtin("xarm7"))


def test_service_is_declared_long_running(node: ManagerNode) -> None:
    spec = next(s for s in node.services() if s.name == "/pfield/execute_trajectory")
    assert spec.type_name == "potential_fields_interfaces/srv/ExecuteTrajectory"
    assert spec.long_running and spec.cancellable


def test_without_ros2_it_says_what_to_do(node: ManagerNode) -> None:
    answer = node.execute_trajectory(pfi.ExecuteTrajectory_Request())
    assert (answer.success, answer.outcome) == (False, "")
    assert "pfield ros2 node" in answer.error_message


def test_bad_goal_time_tolerance_is_refused(node: ManagerNode) -> None:
    with pytest.raises(InvalidInput) as error:
        node.execute_trajectory(pfi.ExecuteTrajectory_Request(goal_time_tolerance=-1.0))
    assert error.value.field == "goal_time_tolerance"


def test_controller_action_parameter(node: ManagerNode) -> None:
    assert node.get_parameters()["trajectory_controller_action"] == \
        "/joint_trajectory_controller/follow_joint_trajectory"
    before = node.get_parameters()
    with pytest.raises(InvalidInput) as error:
        node.set_parameters({"trajectory_controller_action": "/"})
    assert error.value.field == "trajectory_controller_action"
    assert node.get_parameters() == before
    node.set_parameters({"trajectory_controller_action": "/arm_controller/follow_joint_trajectory"})
    assert node.get_parameters()["trajectory_controller_action"] == "/arm_controller/follow_joint_trajectory"
    node.set_parameters({"trajectory_controller_action": before["trajectory_controller_action"]})
