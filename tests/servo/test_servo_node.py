"""``/pfield_servo`` in process and over the HTTP node: Joy and twists in, joint commands and status out."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import httpx
import numpy as np
import pytest

from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces import std_msgs, trajectory_msgs
from pfield.interfaces._base import RosMessage
from pfield.interfaces.control_msgs import JointJog
from pfield.interfaces.sensor_msgs import JointState, Joy
from pfield.interfaces.std_srvs import SetBool_Request, Trigger_Request
from pfield.node._base import Bus
from pfield.node.manager import ManagerNode
from pfield.node.servo_node import STAMP_TRUSTED_AGE, ServoNode
from pfield.shared_control.servo import ServoStatus
from pfield.shared_control.servo_config import ServoConfig
from pfield.spatial import Twist
from pfield.transport.http import ServerThread, create_app


@pytest.fixture(scope="module")
def robot() -> Any:
    from pfield.robot import RobotModel

    return RobotModel.builtin("panda")


class Recorder:
    """Every message published on a bus, by topic."""

    def __init__(self, bus: Bus) -> None:
        self.messages: dict[str, list[RosMessage]] = {}
        bus.add_listener(lambda topic, message: self.messages.setdefault(topic, []).append(message))

    def last(self, topic: str) -> Any:
        return self.messages[topic][-1]


def make(robot: Any, **config: Any) -> tuple[ManagerNode, ServoNode, Recorder]:
    manager = ManagerNode(Bus(), robot)
    recorder = Recorder(manager.bus)
    return manager, ServoNode(manager.bus, manager, ServoConfig(**config)), recorder


def measured(robot: Any) -> JointState:
    q = robot.named_configuration("ready")
    return JointState(name=list(robot.joint_names), position=q.tolist())


@pytest.mark.parametrize("joint_topic", ["/joint_states", "/arm/joint_states"])
def test_the_servo_subscribes_the_joint_states_for_the_manager(robot: Any, joint_topic: str) -> None:
    """/joint_states (the default joint_topic) moves from the manager's subscriptions to the servo's (its own executor
    over ROS 2, ManagerNode.joint_states_subscriber); another joint_topic is subscribed beside the manager's. Either
    way a message on the servo's subscription lands in the manager's joint-state cache."""
    manager, servo, _ = make(robot, joint_topic=joint_topic)
    mine = {spec.topic: spec for spec in servo.subscriptions()}
    managers = {spec.topic for spec in manager.subscriptions()}
    assert joint_topic in mine
    assert ("/joint_states" in managers) == (joint_topic != "/joint_states")
    assert manager.joint_states_subscriber is (servo if joint_topic == "/joint_states" else manager)
    q = robot.named_configuration("ready")
    mine[joint_topic].handler(measured(robot))
    assert np.array_equal(manager.measured_joint_angles([], "joint_states"), q)
    alone = ManagerNode(Bus(), robot)  # no servo: the manager subscribes /joint_states itself
    assert "/joint_states" in {spec.topic for spec in alone.subscriptions()}


def test_joy_drives_the_servo_loop(robot: Any) -> None:
    manager, servo, recorder = make(robot, joy_device="gamepad", scale_linear=0.04, joy_deadman_button=4,
                                    incoming_command_timeout=0.05)
    out = servo.topics["command_out_topic"]
    servo.tick(time.monotonic())
    assert recorder.last(servo.topics["status_topic"]).data == ServoStatus.INVALID  # no joint state yet
    assert "no joint state" in recorder.last(servo.topics["status_text"]).data and out not in recorder.messages
    manager.on_joint_states(measured(robot))
    axes = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0]  # left stick pushed up: +x
    buttons = [0, 0, 0, 0, 1, 0]  # the dead-man button held
    for _ in range(40):
        manager.on_joint_states(measured(robot))
        servo.on_joy(Joy(axes=axes, buttons=buttons))
        time.sleep(0.002)
    command = recorder.last(out)
    assert isinstance(command, trajectory_msgs.JointTrajectory)
    assert command.joint_names == list(robot.joint_names)
    point = command.points[0]
    assert point.time_from_start.nanosec == 10_000_000 and len(point.positions) == len(point.velocities) == 7
    twist = robot.jacobian(point.positions) @ np.array(point.velocities)
    assert twist[0] > 0.0 and abs(twist[1]) < 0.05 * twist[0] and abs(twist[2]) < 0.05 * twist[0]
    assert recorder.last(servo.topics["status_topic"]).data == ServoStatus.NO_WARNING
    count = len(recorder.messages[out])
    servo.on_joy(Joy(axes=axes, buttons=[0] * 6))  # dead-man released: a zero command, the robot stops
    for _ in range(200):
        manager.on_joint_states(measured(robot))  # the driver keeps publishing
        servo.tick(time.monotonic())
        time.sleep(0.002)
    assert recorder.last(out).points[0].velocities == [0.0] * 7
    assert len(recorder.messages[out]) > count
    assert recorder.last(servo.topics["status_topic"]).data == ServoStatus.COMMAND_TIMEOUT
    settled = len(recorder.messages[out])
    servo.tick(time.monotonic() + 2.0)
    assert len(recorder.messages[out]) == settled  # stopped: nothing more is sent


def test_the_tick_waits_for_commands_that_come_every_period(robot: Any) -> None:
    """Commands at least every period drive the output: the tick steps only when one is half a period late; slower
    commands are filled in by the tick after 0.9 of a period (servo_node's Timing)."""
    period = 0.1
    twist = gm.TwistStamped.model_validate({"twist": {"linear": {"x": 0.02}}})
    for pause in (0.02, 0.25):  # a stream at 50 ms (< 1.2 periods), then one at 250 ms
        manager, servo, recorder = make(robot, publish_period=period, incoming_command_timeout=5.0)
        manager.on_joint_states(measured(robot))
        out = servo.topics["command_out_topic"]
        for _ in range(6):
            time.sleep(pause)
            servo.on_twist(twist)
        after = time.monotonic()  # at or after the last command's step
        count = len(recorder.messages[out])
        servo.tick(after + 0.95 * period)  # slow commands are filled in after 0.9 of a period
        if pause > period:
            assert len(recorder.messages[out]) == count + 1
            continue
        assert len(recorder.messages[out]) == count  # the next command of the stream is not late yet
        servo.tick(after + 1.6 * period)  # more than half a period late: the tick keeps the output going
        assert len(recorder.messages[out]) == count + 1


def test_float64_multi_array_carries_velocities_or_positions(robot: Any) -> None:
    for positions in (False, True):
        manager, servo, recorder = make(robot, command_out_type="std_msgs/Float64MultiArray",
                                        publish_joint_positions=positions, command_out_topic="/forward/commands")
        assert servo.publications()[0].type_name == "std_msgs/msg/Float64MultiArray"
        manager.on_joint_states(measured(robot))
        servo.on_twist(gm.TwistStamped.model_validate({"twist": {"linear": {"z": 0.02}}}))
        message = recorder.last("/forward/commands")
        assert isinstance(message, std_msgs.Float64MultiArray) and len(message.data) == 7
        q = robot.named_configuration("ready")
        if positions:
            assert np.abs(np.array(message.data) - q).max() < 0.01
        else:
            assert np.abs(message.data).max() < 1.0 and any(message.data)


def test_twists_in_the_tool_frame_and_refused_input(robot: Any) -> None:
    manager, servo, recorder = make(robot)
    manager.on_joint_states(measured(robot))
    servo.on_twist(gm.TwistStamped.model_validate({"header": {"frame_id": "panda_hand_tcp"},
                                                   "twist": {"linear": {"z": 0.02}}}))
    point = recorder.last(servo.topics["command_out_topic"]).points[0]
    twist = robot.jacobian(point.positions) @ np.array(point.velocities)
    assert twist[2] < 0.0  # the Panda's tool z points down at its ready pose: +z in the tool is -z in the world
    before = servo.servo._command
    bad: list[tuple[Any, type[Exception], str]] = [
        (lambda: servo.on_twist(gm.TwistStamped.model_validate({"header": {"frame_id": "camera"}})), UnknownFrame,
         "twist.header.frame_id"),
        (lambda: servo.on_twist(gm.TwistStamped.model_validate({"twist": {"angular": {"x": float("nan")}}})),
         InvalidInput, "twist.angular.x"),
        (lambda: servo.on_joy(Joy(axes=[0.0] * 3)), InvalidInput, "axes"),
        (lambda: servo.on_joy(Joy(axes=[float("inf")] * 6)), InvalidInput, r"axes\[0\]"),
    ]
    for call, error, field in bad:
        with pytest.raises(error, match=field):
            call()
    assert servo.servo._command is before


def test_a_stamped_command_is_as_old_as_its_stamp(robot: Any, caplog: pytest.LogCaptureFixture) -> None:
    """MoveIt Servo's rule: a non-zero ``header.stamp``, read against the node's ``stamp_clock`` (ROS time over
    rclpy), dates a command for ``incoming_command_timeout`` (0.1 s). One that waited in a queue for longer stops the
    arm instead of moving it; a zero stamp counts from the arrival, and so do a stamp ahead of the clock and one
    further behind it than STAMP_TRUSTED_AGE (another clock: simulated time), with a warning."""
    topic = "command_out_topic"

    def velocities_after(age: float | None, message: str, clock: float | None = None) -> np.ndarray:
        manager, servo, recorder = make(robot)
        if clock is not None:
            servo.stamp_clock = lambda: clock
        manager.on_joint_states(measured(robot))
        now = servo.stamp_clock()  # the stamp made just before the call: the node's own steps take milliseconds
        header = {} if age is None else {"stamp": std_msgs.Time.from_seconds(now - age).model_dump()}
        if message == "twist":
            servo.on_twist(gm.TwistStamped.model_validate({"header": header, "twist": {"linear": {"z": 0.05}}}))
        elif message == "joy":
            servo.on_joy(Joy.model_validate({"header": header, "axes": [0.0, 0.0, 0.5, 0.0, 0.0, 0.0]}))
        else:
            servo.on_joint_jog(JointJog.model_validate({"header": header, "joint_names": ["panda_joint7"],
                                                        "velocities": [0.3]}))
        statuses = [m.data for m in recorder.messages.get(servo.topics["status_topic"], [])]
        commands = recorder.messages.get(servo.topics[topic], [])  # none at all while the arm stands still
        velocities = np.array(commands[-1].points[0].velocities) if commands else np.zeros(robot.n_joints)
        assert (statuses[-1] == ServoStatus.COMMAND_TIMEOUT) == (not velocities.any()), (statuses, velocities)
        return velocities

    for message in ("twist", "joy", "jog"):
        assert velocities_after(None, message).any()  # no stamp: its arrival
        assert velocities_after(0.02, message).any()  # 20 ms old: within the timeout
        assert not velocities_after(0.5, message).any()  # waited 0.5 s somewhere: too old to move
        assert velocities_after(-5.0, message).any()  # ahead of the clock: from its arrival
        assert velocities_after(0.02, message, clock=1000.0).any()  # simulated time: read against the node's clock
        assert not velocities_after(0.5, message, clock=1000.0).any()
    caplog.clear()
    with caplog.at_level("WARNING", logger="pfield.node.servo_node"):
        assert velocities_after(STAMP_TRUSTED_AGE + 5.0, "twist").any()  # another clock: from its arrival
    assert "the publisher's clock is not this node's" in caplog.text


def test_a_joint_jog_drives_the_servo_loop_and_bad_jogs_are_refused(robot: Any) -> None:
    """control_msgs/JointJog on ``joint_command_in_topic`` (Servo's ``~/delta_joint_cmds``): the named joints at
    their velocities in any order, the others still; an unknown or repeated name, a count that does not match, a
    jog of displacements only or a non-finite velocity is refused by field and changes nothing; an empty jog holds."""
    manager, servo, recorder = make(robot, incoming_command_timeout=5.0)
    assert servo.topics["joint_command_in_topic"] == "/pfield_servo/delta_joint_cmds"
    assert servo.topics["joint_command_in_topic"] in {spec.topic for spec in servo.subscriptions()}
    manager.on_joint_states(measured(robot))
    jog = JointJog(joint_names=["panda_joint7", "panda_joint4"], velocities=[0.3, 0.02])
    for _ in range(150):  # 0.3 rad/s at 1.4 rad/s² takes 0.21 s
        servo.on_joint_jog(jog)
        time.sleep(0.002)
    point = recorder.last(servo.topics["command_out_topic"]).points[0]
    assert point.velocities == [0.0, 0.0, 0.0, 0.02, 0.0, 0.0, 0.3]
    assert recorder.last(servo.topics["status_topic"]).data == ServoStatus.NO_WARNING
    before = servo.servo._command
    bad: list[tuple[JointJog, str]] = [
        (JointJog(joint_names=["elbow"], velocities=[0.1]), "joint_jog.joint_names='elbow'"),
        (JointJog(joint_names=["panda_joint1", "panda_joint1"], velocities=[0.1, 0.1]), "named twice"),
        (JointJog(joint_names=["panda_joint1"], velocities=[0.1, 0.2]), "one velocity per joint name"),
        (JointJog(joint_names=["panda_joint1"], displacements=[0.1]), "displacements are not used"),
        (JointJog(joint_names=["panda_joint1"], velocities=[float("nan")]), r"joint_jog.velocities\[panda_joint1\]"),
    ]
    for message, words in bad:
        with pytest.raises(InvalidInput, match=words):
            servo.on_joint_jog(message)
    assert servo.servo._command is before
    servo.on_joint_jog(JointJog())  # an empty jog: every joint to stand still (as Servo takes it)
    assert servo.servo._command is not None and servo.servo._command.joints.tolist() == [0.0] * 7
    assert servo.get_parameters()["scale.joint"] == 0.5
    assert servo.set_parameters({"scale.joint": 0.2})["scale.joint"] == 0.2  # changes while the node runs


@pytest.fixture(scope="module")
def served(robot: Any) -> Iterator[tuple[ManagerNode, ServoNode, str]]:
    manager = ManagerNode(Bus(), robot)
    # a command stays fresh for 5 s: a loaded machine may take longer than Servo's 0.1 s between the last Joy
    # message and the test's read of the command topic, and a stale command is (rightly) a stop
    servo = ServoNode(manager.bus, manager, ServoConfig(joy_device="spacemouse", incoming_command_timeout=5.0))
    with ServerThread(create_app([manager, servo])) as server:
        yield manager, servo, server.url


def test_the_http_node_hosts_the_servo(served: tuple[ManagerNode, ServoNode, str], robot: Any) -> None:
    _, servo, url = served
    nodes = httpx.get(f"{url}/nodes").json()
    assert "/pfield_servo" in str(nodes)
    assert httpx.get(f"{url}/param/pfield_servo").json()["command_out_topic"] == servo.config.command_out_topic
    state = measured(robot).model_dump()
    assert httpx.post(f"{url}/topic/joint_states", json=state).status_code < 300
    joy = {"axes": [0.0, 0.0, 0.5, 0.0, 0.0, 0.0], "buttons": [0, 0]}
    for _ in range(5):
        assert httpx.post(f"{url}/topic/pfield_servo/joy", json=joy).status_code < 300
    command = httpx.get(f"{url}/topic/joint_trajectory_controller/joint_trajectory").json()
    velocities = np.array(command["points"][0]["velocities"])
    twist = robot.jacobian(command["points"][0]["positions"]) @ velocities
    assert twist[2] > 0.0  # spacemouse axis 2 up: +z
    refused = httpx.post(f"{url}/topic/pfield_servo/joy", json={"axes": [0.0], "buttons": []})
    assert refused.status_code == 400 and "axes" in refused.text
    deadline = time.monotonic() + 10.0  # the server's tick stops the robot once the command is stale
    while time.monotonic() < deadline:
        httpx.post(f"{url}/topic/joint_states", json=state)  # the driver keeps publishing
        status = httpx.get(f"{url}/topic/pfield_servo/status").json()
        if status["data"] == ServoStatus.COMMAND_TIMEOUT:
            break
        time.sleep(0.05)
    assert status["data"] == ServoStatus.COMMAND_TIMEOUT


def test_the_http_node_takes_joint_jogs(served: tuple[ManagerNode, ServoNode, str], robot: Any) -> None:
    """control_msgs/JointJog as JSON on the servo's joint_command_in_topic: the wrist jogged; a jog naming a joint the
    robot does not have is refused (400, the field named)."""
    _, _, url = served
    state = measured(robot).model_dump()
    jog = {"joint_names": ["panda_joint7"], "velocities": [0.2]}
    for _ in range(5):
        assert httpx.post(f"{url}/topic/joint_states", json=state).status_code < 300
        assert httpx.post(f"{url}/topic/pfield_servo/delta_joint_cmds", json=jog).status_code < 300
    command = httpx.get(f"{url}/topic/joint_trajectory_controller/joint_trajectory").json()
    velocities = command["points"][0]["velocities"]
    assert velocities[:6] == [0.0] * 6 and velocities[6] > 0.0
    refused = httpx.post(f"{url}/topic/pfield_servo/delta_joint_cmds",
                         json={"joint_names": ["wrist"], "velocities": [0.2]})
    assert refused.status_code == 400 and "joint_jog.joint_names" in refused.text


def test_pause_holds_the_arm_and_drops_commands_until_resumed(robot: Any) -> None:
    """MoveIt Servo's ``~/pause_servo`` (std_srvs/SetBool) and the older ``~/start_servo`` / ``~/stop_servo``
    (Trigger): pausing a moving arm sends one command holding the last commanded positions at zero velocity and says
    so on status_text; while paused commands and ticks send nothing; resumed, the loop starts from the measured
    joints."""
    manager, servo, recorder = make(robot, incoming_command_timeout=5.0)
    services = {spec.name: spec for spec in servo.services()}
    assert set(services) == {"/pfield_servo/pause_servo", "/pfield_servo/start_servo", "/pfield_servo/stop_servo"}
    out = servo.topics["command_out_topic"]
    manager.on_joint_states(measured(robot))
    twist = gm.TwistStamped.model_validate({"twist": {"linear": {"x": 0.03}}})
    for _ in range(20):
        servo.on_twist(twist)
        time.sleep(0.002)
    moving = recorder.last(out).points[0]
    answer = services["/pfield_servo/pause_servo"].handler(SetBool_Request(data=True))
    assert answer.success and servo.paused
    hold = recorder.last(out).points[0]
    assert hold.velocities == [0.0] * 7 and hold.positions == moving.positions
    assert recorder.last(servo.topics["status_text"]).data.startswith("PAUSED")
    count = len(recorder.messages[out])
    for _ in range(10):
        servo.on_twist(twist)
        servo.on_joint_jog(JointJog(joint_names=["panda_joint1"], velocities=[0.2]))
        servo.tick(time.monotonic() + 1.0)
    assert len(recorder.messages[out]) == count and servo.servo._command is None
    assert servo.step(time.monotonic() + 2.0) is None and len(recorder.messages[out]) == count  # no step while paused
    servo.servo.command(Twist((0.03, 0.0, 0.0)), time.monotonic())  # a command that slipped in while pausing ...
    assert services["/pfield_servo/stop_servo"].handler(Trigger_Request()).success and servo.paused  # idempotent
    assert len(recorder.messages[out]) == count
    assert services["/pfield_servo/start_servo"].handler(Trigger_Request()).message == "running"
    assert not servo.paused and servo.servo._command is None  # ... is dropped on resume
    servo.on_twist(twist)
    resumed = recorder.last(out).points[0]
    ready = robot.named_configuration("ready")
    assert len(recorder.messages[out]) == count + 1
    moved = np.abs(np.array(hold.positions) - ready).max()  # the joints commanded before the pause
    assert moved > 1e-4 and np.abs(np.array(resumed.positions) - ready).max() < moved / 4  # from the measured joints
    assert services["/pfield_servo/pause_servo"].handler(SetBool_Request(data=False)).message == "running"


@pytest.mark.parametrize("error", [ModuleNotFoundError, AttributeError])
def test_a_subscription_whose_interface_is_not_built_is_skipped(robot: Any, error: type[Exception],
                                                                 monkeypatch: pytest.MonkeyPatch,
                                                                 caplog: pytest.LogCaptureFixture) -> None:
    """Over ROS 2, a servo input whose message package is missing (no control_msgs) or older (a control_msgs built
    before JointJog) is not subscribed, with a warning; the other inputs' classes still resolve."""
    pytest.importorskip("rclpy")
    from pfield.transport import ros2

    _, servo, _ = make(robot)
    specs = {spec.type_name: spec for spec in servo.subscriptions()}

    def refuse_joint_jog(type_name: str) -> type:
        if type_name == "control_msgs/msg/JointJog":  # a new error per call: none outlives the test with its frames
            raise error(f"control_msgs has no {type_name}")
        return object

    monkeypatch.setattr(ros2, "interface_class", refuse_joint_jog)
    with caplog.at_level("WARNING", logger=ros2.__name__):
        assert ros2.subscription_class(specs["control_msgs/msg/JointJog"]) is None
        assert ros2.subscription_class(specs["geometry_msgs/msg/TwistStamped"]) is object
    assert "/pfield_servo/delta_joint_cmds: control_msgs/msg/JointJog is not available" in caplog.text
