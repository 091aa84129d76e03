"""Parts of the ROS 2 host that need no DDS traffic: failure responses, the bus publisher thread and the
parameter callbacks."""

from __future__ import annotations

import math
import threading
from typing import Any

from ros2_helpers.support import require_ros2_python

require_ros2_python()

from geometry_msgs.msg import PoseStamped as RosPoseStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

import pfield.interfaces.potential_fields_interfaces as pfi  # noqa: E402
from pfield.interfaces import std_srvs  # noqa: E402
from pfield.interfaces.geometry_msgs import PoseStamped  # noqa: E402
from pfield.interfaces.std_msgs import Header  # noqa: E402
from pfield.node._base import Bus  # noqa: E402
from pfield.node.manager import ManagerNode  # noqa: E402
from pfield.transport._ros2_params import _validate, _widen  # noqa: E402
from pfield.transport._ros2_publisher import BusPublisher  # noqa: E402
from pfield.transport.ros2 import DROP_LOG_PERIOD, DropLog, _failure_response  # noqa: E402


def test_failure_responses_carry_the_reason_where_the_type_can() -> None:
    reason = "planning_method='sideways': expected 'task_space' or 'whole_body'"
    assert _failure_response(pfi.PlanPath_Response, reason) == pfi.PlanPath_Response(success=False,
                                                                                      error_message=reason)
    assert _failure_response(pfi.RemoveObstacles_Response, reason) == pfi.RemoveObstacles_Response(message=reason)
    assert _failure_response(std_srvs.Trigger_Response, reason) == std_srvs.Trigger_Response(message=reason)
    # FindValidPose: LETHAL (mbf's "nothing found"), never the default FREE
    assert _failure_response(pfi.FindValidPose_Response, reason).state == pfi.FindValidPose_Response.LETHAL
    # no error field: the default response (a zero twist, no autonomy)
    assert _failure_response(pfi.ComputeAutonomyVector_Response, reason) == pfi.ComputeAutonomyVector_Response()


def _stamped(frame: str) -> PoseStamped:
    return PoseStamped(header=Header(frame_id=frame))


def test_bus_publisher_sends_the_newest_message_per_topic() -> None:
    sent: list[str] = []
    busy, release = threading.Event(), threading.Event()

    def publish(message: RosPoseStamped) -> None:
        busy.set()
        release.wait(5.0)  # hold the thread so that later messages pile up
        sent.append(message.header.frame_id)

    publisher = BusPublisher()
    publisher.register("/pose", RosPoseStamped, publish)
    publisher.start()
    publisher.enqueue("/pose", _stamped("first"))
    assert busy.wait(5.0)
    for frame in ("second", "third"):  # while "first" is being published
        publisher.enqueue("/pose", _stamped(frame))
    publisher.enqueue("/not_registered", _stamped("ignored"))
    release.set()
    publisher.stop(5.0)
    assert sent == ["first", "third"]  # "second" was superseded before it was sent


def test_bus_publisher_survives_a_failing_publish() -> None:
    sent: list[str] = []
    failed = threading.Event()

    def publish(message: RosPoseStamped) -> None:
        if message.header.frame_id == "boom":
            failed.set()
            raise RuntimeError("publisher failed")
        sent.append(message.header.frame_id)

    publisher = BusPublisher()
    publisher.register("/pose", RosPoseStamped, publish)
    publisher.start()
    publisher.enqueue("/pose", _stamped("boom"))
    assert failed.wait(5.0)
    publisher.enqueue("/pose", _stamped("after"))
    publisher.stop(5.0)
    assert sent == ["after"]


def test_bus_publisher_publishes_what_is_pending_at_stop() -> None:
    sent: list[str] = []
    publisher = BusPublisher()
    publisher.register("/pose", RosPoseStamped, lambda message: sent.append(message.header.frame_id))
    publisher.enqueue("/pose", _stamped("last words"))
    publisher.start()
    publisher.stop(5.0)
    assert sent == ["last words"]


class _DoublesNode:
    """What the pre-set callback reads of an rclpy node: every parameter is declared as a double."""

    def has_parameter(self, name: str) -> bool:
        return True

    def get_parameter(self, name: str) -> Parameter:
        return Parameter(name, Parameter.Type.DOUBLE, 0.1)


def test_an_integer_beyond_a_double_is_refused_by_the_node_not_raised() -> None:
    """Issue 31 F3 over ROS 2: ``float(10**400)`` in the pre-set callback raised out of ``set_parameters``."""
    node = ManagerNode(Bus(), robot=None)
    before = node.get_parameters()
    ros_node: Any = _DoublesNode()
    widened = _widen(ros_node, [Parameter("influence_distance", value=-(10**400))])
    assert widened[0].type_ == Parameter.Type.DOUBLE and widened[0].value == -math.inf
    result = _validate(node, frozenset(before), widened)
    assert not result.successful and result.reason.startswith("influence_distance=")
    assert node.get_parameters() == before
    assert _widen(ros_node, [Parameter("influence_distance", value=1)])[0].value == 1.0


def test_dropped_messages_are_warned_once_a_period_with_a_count(caplog: Any) -> None:
    """A 500 Hz driver naming a joint wrongly wrote 500 warnings a second: now each kind of refusal (the field its
    error names, and its reason) the first time at once, then once a period saying how many more of it were
    dropped."""
    from pfield.errors import InvalidInput

    drops = DropLog("/joint_states")
    with caplog.at_level("WARNING", logger="pfield.transport.ros2"):
        for k in range(1000):  # two periods of messages every 0.01 s, every tenth with another fault
            field = "joint_states.position" if k % 10 else "joint_states.name"
            drops.dropped(InvalidInput(field, k, "bad"), now=100.0 + 0.01 * k)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 2 * math.ceil(1000 * 0.01 / DROP_LOG_PERIOD)  # each kind once a period
    assert lines[0] == "/joint_states: dropped message: joint_states.name=0: bad"
    assert lines[1] == "/joint_states: dropped message: joint_states.position=1: bad"
    assert lines[2] == "/joint_states: dropped message: joint_states.name=500: bad (49 more like it dropped since " \
        "the last warning)"
    assert lines[3].startswith("/joint_states: dropped message: joint_states.position=501: bad (449 more like it")
