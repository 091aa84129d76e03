"""A small test-only node implementing the transport-free contract, served over ROS 2.

It exercises every part of the transport without the planners: a long-running service
(``/pfield/plan_path`` answers a straight line after ``plan_seconds``), a short one
(``/pfield/compute_autonomy_vector``: ``gain * (goal - query)`` with its norm limited to
``max_linear_velocity``), a service with ``success``/``message`` (``/pfield/remove_obstacles``),
subscriptions with validation (``/pfield/obstacles``, ``/pfield/planning_goal_pose``), publications
(``/pfield/planned_path``, ``/pfield/markers``: one marker per obstacle), validated parameters, and a
tick that expires ``Dynamic`` obstacles after ``dynamic_obstacle_timeout`` seconds.

Run: ``python echo_node.py [--ros-args ...]`` (serves until SIGINT).
"""

from __future__ import annotations

import logging
import math
import sys
import threading
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

import pfield.interfaces.potential_fields_interfaces as pfi
from pfield.errors import InvalidInput
from pfield.interfaces.geometry_msgs import Point, Pose, PoseStamped, Twist, TwistStamped, Vector3
from pfield.interfaces.nav_msgs import Path
from pfield.interfaces.std_msgs import Header
from pfield.interfaces.visualization_msgs import Marker, MarkerArray
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec
from pfield.transport.ros2 import run

SIZES = {"Sphere": ("radius",), "Box": ("length", "width", "height"), "Cylinder": ("radius", "height"),
         "Ellipsoid": ("semi_x", "semi_y", "semi_z"), "Capsule": ("radius", "height"),
         "Mesh": ("scale_x", "scale_y", "scale_z")}


class EchoNode(Node):
    name = "/pfield_manager"
    tick_period = 0.05

    def __init__(self, bus: Bus) -> None:
        super().__init__(bus)
        self._lock = threading.Lock()
        self._obstacles: dict[str, tuple[pfi.Obstacle, float]] = {}
        self._goal = np.array([0.5, 0.2, 0.4])
        self._params: dict[str, Any] = {"gain": 1.0, "max_linear_velocity": 0.05, "plan_seconds": 0.0,
                                        "dynamic_obstacle_timeout": 0.5, "fixed_frame": "world",
                                        "path_points": 20, "use_limits": True, "weights": [1.0, 2.0]}

    def services(self) -> list[ServiceSpec]:
        return [
            ServiceSpec("/pfield/plan_path", "potential_fields_interfaces/srv/PlanPath", pfi.PlanPath_Request,
                        pfi.PlanPath_Response, self.plan_path, long_running=True),
            ServiceSpec("/pfield/compute_autonomy_vector", "potential_fields_interfaces/srv/ComputeAutonomyVector",
                        pfi.ComputeAutonomyVector_Request, pfi.ComputeAutonomyVector_Response, self.autonomy),
            ServiceSpec("/pfield/remove_obstacles", "potential_fields_interfaces/srv/RemoveObstacles",
                        pfi.RemoveObstacles_Request, pfi.RemoveObstacles_Response, self.remove),
        ]

    def subscriptions(self) -> list[SubscriptionSpec]:
        return [
            SubscriptionSpec("/pfield/obstacles", "potential_fields_interfaces/msg/ObstacleArray",
                             pfi.ObstacleArray, self.on_obstacles),
            SubscriptionSpec("/pfield/planning_goal_pose", "geometry_msgs/msg/PoseStamped", PoseStamped,
                             self.on_goal),
        ]

    def publications(self) -> list[PublicationSpec]:
        return [PublicationSpec("/pfield/planned_path", "nav_msgs/msg/Path", Path),
                PublicationSpec("/pfield/markers", "visualization_msgs/msg/MarkerArray", MarkerArray)]

    def get_parameters(self) -> dict[str, Any]:
        with self._lock:
            return dict(self._params)

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        for name, value in values.items():
            if name not in self._params:
                raise InvalidInput(name, value, "unknown parameter")
            if name in ("gain", "max_linear_velocity", "plan_seconds", "dynamic_obstacle_timeout") and not (
                    isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise InvalidInput(name, value, "must be a finite number >= 0")
        with self._lock:
            self._params.update(values)
            return dict(self._params)

    def on_obstacles(self, message: pfi.ObstacleArray) -> None:
        for index, obstacle in enumerate(message.obstacles):
            if obstacle.type not in SIZES:
                raise InvalidInput(f"obstacles[{index}].type", obstacle.type, f"one of {sorted(SIZES)}")
            for size in SIZES[obstacle.type]:
                value = getattr(obstacle, size)
                if not value > 0:
                    raise InvalidInput(f"obstacles[{index}].{size}", value, "must be > 0")
        with self._lock:
            for obstacle in message.obstacles:
                self._obstacles[obstacle.frame_id] = (obstacle, time.monotonic())
        self._publish_markers()

    def on_goal(self, message: PoseStamped) -> None:
        position = message.pose.position
        self._goal = np.array([position.x, position.y, position.z])

    def _publish_markers(self) -> None:
        with self._lock:
            ids = sorted(self._obstacles)
        markers = [Marker(header=Header(frame_id="world"), ns=frame_id, id=i, type=Marker.SPHERE)
                   for i, frame_id in enumerate(ids)]
        self.bus.publish("/pfield/markers", MarkerArray(markers=markers))

    def plan_path(self, request: pfi.PlanPath_Request) -> pfi.PlanPath_Response:
        if request.planning_method not in ("", "task_space", "whole_body"):
            raise InvalidInput("planning_method", request.planning_method, "task_space or whole_body")
        params = self.get_parameters()
        if params["plan_seconds"] > 0:  # tells a client that the slow plan has started
            self.bus.publish("/pfield/planned_path", Path(header=Header(frame_id="planning")))
            time.sleep(params["plan_seconds"])
        start, goal = request.start.position, request.goal.position
        poses = []
        for s in np.linspace(0.0, 1.0, int(params["path_points"])):
            point = Point(x=start.x + s * (goal.x - start.x), y=start.y + s * (goal.y - start.y),
                          z=start.z + s * (goal.z - start.z))
            poses.append(PoseStamped(header=Header(frame_id="world"), pose=Pose(position=point)))
        path = Path(header=Header(frame_id="world"), poses=poses)
        self.bus.publish("/pfield/planned_path", path)
        return pfi.PlanPath_Response(success=True, end_effector_path=path)

    def autonomy(self, request: pfi.ComputeAutonomyVector_Request) -> pfi.ComputeAutonomyVector_Response:
        params = self.get_parameters()
        if request.query_pose.header.frame_id not in ("", params["fixed_frame"]):
            raise InvalidInput("query_pose.header.frame_id", request.query_pose.header.frame_id, "unknown frame")
        p = request.query_pose.pose.position
        velocity = params["gain"] * (self._goal - np.array([p.x, p.y, p.z]))
        norm = float(np.linalg.norm(velocity))
        if params["use_limits"] and norm > params["max_linear_velocity"]:
            velocity *= params["max_linear_velocity"] / norm
        twist = Twist(linear=Vector3(x=velocity[0], y=velocity[1], z=velocity[2]))
        return pfi.ComputeAutonomyVector_Response(
            autonomy_vector=TwistStamped(header=Header(frame_id="world"), twist=twist))

    def remove(self, request: pfi.RemoveObstacles_Request) -> pfi.RemoveObstacles_Response:
        with self._lock:
            unknown = [i for i in request.frame_ids if i not in self._obstacles]
            if unknown:
                raise InvalidInput("frame_ids", unknown, "unknown obstacle ids")
            for frame_id in request.frame_ids:
                del self._obstacles[frame_id]
            remaining = sorted(self._obstacles)
        self._publish_markers()
        return pfi.RemoveObstacles_Response(success=True, message="removed", remaining=remaining)

    def tick(self, now: float) -> None:
        timeout = self.get_parameters()["dynamic_obstacle_timeout"]
        with self._lock:
            expired = [k for k, (o, t) in self._obstacles.items() if o.group == "Dynamic" and now - t > timeout]
            for frame_id in expired:
                del self._obstacles[frame_id]
        if expired:
            self._publish_markers()


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    run([EchoNode(Bus())], args=sys.argv[1:])
