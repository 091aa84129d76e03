"""``/base_controller``: topics in, ``/cmd_vel`` out on ticks, parameters, bad input rejected with state kept."""

from __future__ import annotations

import math
import re

import pytest

from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces import std_srvs
from pfield.interfaces.nav_msgs import Odometry
from pfield.interfaces.sensor_msgs import LaserScan
from pfield.interfaces.std_msgs import Header
from pfield.mobile.controller import ControllerState
from pfield.mobile.sim import integrate_pose
from pfield.node._base import Bus
from pfield.node.base_controller import BaseControllerNode


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def node():
    clock = FakeClock()
    node = BaseControllerNode(Bus(), rate=20.0, clock=clock)
    node.set_parameters({"kr_height": 0.0, "max_linear_acceleration": 0.0, "max_angular_acceleration": 0.0})
    node.clock = clock
    return node


def _tick(node, seconds):
    for _ in range(round(seconds / node.tick_period)):
        node.clock.now += node.tick_period
        node.tick(node.clock.now)
    return node.bus.latest("/cmd_vel")


def _goal(x, y, frame="odom"):
    return gm.PointStamped.model_validate({"header": {"frame_id": frame}, "point": {"x": x, "y": y}})


def _odom(x, y, yaw, frame="odom", scale=1.0):
    orientation = {"z": scale * math.sin(yaw / 2), "w": scale * math.cos(yaw / 2)}
    return Odometry.model_validate({"header": {"frame_id": frame}, "child_frame_id": "base_link",
                                    "pose": {"pose": {"position": {"x": x, "y": y}, "orientation": orientation}}})


def _follow_with_slip(node, goal, slip, seconds, odometry):
    """A robot that moves ``slip`` times the commanded velocity; its true pose is published on /odom."""
    true_pose = [0.0, 0.0, 0.0]
    node.on_goal(_goal(*goal))
    for _ in range(round(seconds / node.tick_period)):
        if odometry:
            node.on_odom(_odom(*true_pose))
        node.clock.now += node.tick_period
        node.tick(node.clock.now)
        twist = node.bus.latest("/cmd_vel")
        command = (slip * twist.linear.x, slip * twist.linear.y, slip * twist.angular.z)
        true_pose = integrate_pose(true_pose, command, node.tick_period).tolist()
    return true_pose


def test_contract_names_and_types(node):
    assert node.name == "/base_controller" and node.tick_period == pytest.approx(0.05)
    assert {(s.topic, s.type_name) for s in node.subscriptions()} == {
        ("/goal_point", "geometry_msgs/msg/PointStamped"), ("/scan", "sensor_msgs/msg/LaserScan"),
        ("/cmd_vel_teleop", "geometry_msgs/msg/Twist"), ("/odom", "nav_msgs/msg/Odometry")}
    assert [(p.topic, p.type_name) for p in node.publications()] == [("/cmd_vel", "geometry_msgs/msg/Twist")]


def test_goal_point_is_followed_until_reached(node):
    node.on_goal(_goal(1.0, 0.0))
    twist = _tick(node, 0.1)
    assert twist.linear.x > 0.0 and node.state == ControllerState.FOLLOWING
    _tick(node, 10.0)
    assert node.state == ControllerState.REACHED and node.goal is None
    assert math.hypot(node.pose[0] - 1.0, node.pose[1]) <= 0.1
    assert node.bus.latest("/cmd_vel") == gm.Twist()


def test_goal_in_base_frame_is_relative_to_the_robot(node):
    node.on_goal(_goal(1.0, 0.0))
    _tick(node, 10.0)
    node.on_goal(_goal(0.0, 2.0, frame="base_link"))
    assert node.goal.tolist() == pytest.approx([node.pose[0], node.pose[1] + 2.0])


def test_odometry_drives_the_pose_so_a_slipping_robot_reaches_the_goal(node):
    true_pose = _follow_with_slip(node, (1.0, 0.5), slip=0.6, seconds=15.0, odometry=True)
    assert node.state == ControllerState.REACHED
    assert math.hypot(true_pose[0] - 1.0, true_pose[1] - 0.5) <= 0.1
    # the last command is zero (the robot did not move after the last odometry), and the node's pose is that
    # odometry, not its own integration of the commands
    assert node.bus.latest("/cmd_vel") == gm.Twist()
    assert node.pose.tolist() == true_pose


def test_dead_reckoning_alone_stops_short_of_the_goal_on_a_slipping_robot(node):
    true_pose = _follow_with_slip(node, (1.0, 0.5), slip=0.6, seconds=15.0, odometry=False)
    assert node.state == ControllerState.REACHED  # the node believes it arrived …
    assert math.hypot(true_pose[0] - 1.0, true_pose[1] - 0.5) > 0.3  # … the robot did not


def test_odometry_pose_and_yaw_from_the_quaternion(node):
    node.on_odom(_odom(2.0, -1.0, 0.7, scale=2.0))  # a non-unit quaternion gives the same yaw
    assert node.pose.tolist() == pytest.approx([2.0, -1.0, 0.7], abs=1e-12)
    _tick(node, 0.5)
    assert node.pose.tolist() == pytest.approx([2.0, -1.0, 0.7], abs=1e-12)  # no dead-reckoning on top
    node.on_goal(_goal(1.0, 0.0, frame="base_link"))
    assert node.goal.tolist() == pytest.approx([2.0 + math.cos(0.7), -1.0 + math.sin(0.7)])
    node.on_odom(_odom(0.5, 0.25, -math.pi / 2, frame=""))
    assert node.pose.tolist() == pytest.approx([0.5, 0.25, -math.pi / 2], abs=1e-12)


def test_bad_odometry_is_rejected_and_state_kept(node):
    node.on_teleop(gm.Twist(linear=gm.Vector3(x=0.2)))
    for bad, error, field in ((_odom(1.0, 0.0, 0.0, frame="map"), UnknownFrame, "header.frame_id"),
                              (_odom(math.nan, 0.0, 0.0), InvalidInput, "pose.pose"),
                              (_odom(0.0, math.inf, 0.0), InvalidInput, "pose.pose"),
                              (_odom(0.0, 0.0, 0.0, scale=0.0), InvalidInput, "pose.pose.orientation")):
        before = node.pose
        with pytest.raises(error, match=re.escape(field)):
            node.on_odom(bad)
        assert node.pose.tolist() == before.tolist()
    _tick(node, 0.5)
    assert node.pose[0] == pytest.approx(0.2 * 0.45)  # still dead-reckoning (9 periods): no odometry accepted
    node.set_parameters({"odom_frame": "world"})
    with pytest.raises(UnknownFrame, match=r"header\.frame_id"):
        node.on_odom(_odom(3.0, 0.0, 0.0, frame="odom"))
    node.on_odom(_odom(3.0, 0.0, 0.0, frame="world"))
    assert node.pose.tolist() == [3.0, 0.0, 0.0]


def test_bad_goal_is_rejected_and_goal_kept(node):
    node.on_goal(_goal(3.0, 0.0))
    with pytest.raises(UnknownFrame):
        node.on_goal(_goal(0.0, 0.0, frame="map"))
    with pytest.raises(InvalidInput, match="point"):
        node.on_goal(_goal(math.nan, 0.0))
    assert node.goal.tolist() == [3.0, 0.0]


def test_scan_sets_obstacles_and_bad_scan_keeps_them(node):
    node.set_parameters({"kr_height": 1.0, "kr_dist": 0.5, "kr_slope": 10.0})
    scan = LaserScan.model_validate({"header": {"frame_id": "laser"}, "angle_min": -math.pi,
                                     "angle_increment": math.pi / 2, "range_min": 0.1, "range_max": 5.0,
                                     "ranges": [2.0, 2.0, 0.6, 2.0]})
    node.on_scan(scan)
    node.on_teleop(gm.Twist(linear=gm.Vector3(x=0.5)))
    slowed = _tick(node, 0.05)
    assert 0.0 < slowed.linear.x < 0.5  # an obstacle 0.6 m ahead pushes back on the operator
    points = node.obstacle_points
    assert points.shape == (4, 2)
    bad = scan.model_copy(update={"range_min": 6.0})
    with pytest.raises(InvalidInput, match="range_max"):
        node.on_scan(bad)
    with pytest.raises(UnknownFrame):
        node.on_scan(scan.model_copy(update={"header": Header(frame_id="camera")}))
    assert (node.obstacle_points == points).all()


def test_teleop_has_priority_then_stale_input_gives_zero(node):
    node.on_teleop(gm.Twist(linear=gm.Vector3(x=0.2, y=-0.1), angular=gm.Vector3(z=0.3)))
    twist = _tick(node, 0.05)
    assert (twist.linear.x, twist.linear.y, twist.angular.z) == pytest.approx((0.2, -0.1, 0.3))
    assert node.state == ControllerState.TELEOP
    stale = _tick(node, 1.0)
    assert stale == gm.Twist() and node.state == ControllerState.TIMEOUT
    with pytest.raises(InvalidInput):
        node.on_teleop(gm.Twist(linear=gm.Vector3(x=math.inf)))


def test_parameters_are_validated_all_or_nothing(node):
    before = node.get_parameters()
    assert before["attraction"] == "power" and before["drive"] == "holonomic" and before["odom_frame"] == "odom"
    for bad in ({"kr_slope": 0.0}, {"ka": 2.0, "min_spd_norm": 5.0}, {"no_such": 1}, {"ka": True},
                {"drive": "walking"}, {"base_frame": ""}, {"ka": 1.0, "teleop_timeout": -1.0}):
        with pytest.raises(InvalidInput):
            node.set_parameters(bad)
        assert node.get_parameters() == before
    after = node.set_parameters({"ka": 1.0, "attraction": "linear", "drive": "diff_drive", "base_frame": "base"})
    assert (after["ka"], after["attraction"], after["drive"], after["base_frame"]) == (1.0, "linear", "diff_drive",
                                                                                        "base")


def test_cancel_goal_service(node):
    node.on_goal(_goal(3.0, 0.0))
    (service,) = node.services()
    assert service.name == "/base_controller/cancel_goal"
    response = service.handler(std_srvs.Trigger_Request())
    assert response.success and node.goal is None
    assert _tick(node, 0.1) == gm.Twist()


def test_served_over_http_on_loopback():
    """The node behind the real HTTP transport: goal in, cmd_vel out on ticks, bad input answered 4xx."""
    import time

    import httpx

    from pfield.transport.http import ServerThread, create_app

    node = BaseControllerNode(Bus(), rate=50.0)
    with ServerThread(create_app([node])) as server, httpx.Client(base_url=server.url, timeout=5.0) as client:
        scan = '{"angle_min": -3.14159, "angle_increment": 1.5708, "range_max": 5.0, ' \
               '"ranges": [Infinity, 4.0, NaN, 4.0]}'
        assert client.post("/topic/scan", content=scan, headers={"content-type": "application/json"}).is_success
        goal = {"header": {"frame_id": "odom"}, "point": {"x": 50.0, "y": 0.0}}
        assert client.post("/topic/goal_point", json=goal).is_success
        deadline = time.monotonic() + 10.0
        speed = 0.0
        while speed <= 0.0 and time.monotonic() < deadline:
            speed = client.get("/topic/cmd_vel").json()["linear"]["x"]
        assert speed > 0.0
        bad_goal = {"header": {"frame_id": "map"}, "point": {"x": 1.0}}
        assert client.post("/topic/goal_point", json=bad_goal).status_code in (400, 422)
        assert node.goal.tolist() == [50.0, 0.0]
        assert client.put("/param/base_controller", json={"kr_slope": -1.0}).status_code in (400, 422)
        assert client.put("/param/base_controller", json={"drive": "diff_drive"}).json()["drive"] == "diff_drive"
        assert client.get("/param/base_controller").json()["kr_slope"] == 30.0
        odom = {"header": {"frame_id": "odom"}, "pose": {"pose": {"position": {"x": 2.0, "y": 0.5}}}}
        assert client.post("/topic/odom", json=odom).is_success
        assert node.pose.tolist() == [2.0, 0.5, 0.0]
        odom["header"]["frame_id"] = "map"
        assert client.post("/topic/odom", json=odom | {"pose": {}}).status_code in (400, 422)
        assert node.pose.tolist() == [2.0, 0.5, 0.0]
