"""``/pfield_manager``: the transport-free manipulator node (obstacles, goal, parameters, planning).

Topics in: ``/pfield/obstacles`` (ObstacleArray: add or replace by id; one bad obstacle rejects the whole
message), ``/pfield/planning_goal_pose`` (PoseStamped), ``/pfield/query_pose`` (PoseStamped: answers on
``/pfield/autonomy_vector``). Topics out: ``/pfield/planned_path`` (nav_msgs/Path), ``/pfield/markers``
(MarkerArray). Services: ``/pfield/plan_path``, ``/pfield/compute_autonomy_vector``,
``/pfield/remove_obstacles`` and ``/pfield/clear_obstacles`` (std_srvs/Trigger). Parameters: every
:class:`~pfield.field.FieldConfig` field plus ``dynamic_obstacle_timeout`` (s: ``Dynamic`` obstacles not
updated for this long are dropped), ``fixed_frame`` (the frame every pose is used in) and
``static_transforms`` (``{frame: {translation: [x, y, z], rotation: [qx, qy, qz, qw]}}``: the pose of each
other frame in the fixed frame). Poses in a message whose ``header.frame_id`` is such a frame are
transformed into the fixed frame (``T_fixed_x = T_fixed_frame * T_frame_x``); an empty frame_id means the
fixed frame; any other frame is refused with :class:`~pfield.errors.UnknownFrame`. PlanPath's poses carry no
header and are in the fixed frame.

State changes are all-or-nothing: every request is validated completely before anything is changed,
and planning works on a snapshot, so short calls (autonomy vector) keep answering during a long plan.
Planning behaviour follows the seed's PlanPath.srv: ``planning_method`` empty means task_space,
``max_iterations`` ≤ 0 means :data:`DEFAULT_MAX_ITERATIONS`; above :data:`MAX_ITERATIONS_CAP` is refused.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from pfield._validation import as_vector
from pfield.errors import InvalidInput, PfieldError
from pfield.field.config import FieldConfig
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces import nav_msgs, std_srvs, visualization_msgs
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.convert import obstacle_from_msg, plan_response, pose_from_msg, twist_stamped
from pfield.node import _planning
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec
from pfield.node._frames import StaticTransforms, parse_transforms, transforms_data
from pfield.node._markers import state_markers
from pfield.planning.global_search import check_global_options
from pfield.planning.task_space import DEFAULT_MAX_ITERATIONS
from pfield.spatial import Pose

__all__ = ["DEFAULT_MAX_ITERATIONS", "MAX_ITERATIONS_CAP", "ManagerNode", "ManagerParameters"]

_log = logging.getLogger(__name__)
MAX_ITERATIONS_CAP = 200_000
"""Largest accepted ``max_iterations`` (about 4000 s of motion at dt = 0.02 s): bounds a request's cost."""
TASK_SPACE, WHOLE_BODY = pfi.PLANNING_METHOD_TASK_SPACE, pfi.PLANNING_METHOD_WHOLE_BODY


@dataclass(frozen=True)
class ManagerParameters:
    """Node parameters that are not field parameters."""

    dynamic_obstacle_timeout: float = 2.0
    """s: a ``Dynamic`` obstacle not re-published for this long is removed (0 disables expiry)."""
    fixed_frame: str = "world"
    """The frame every pose is used in; messages in another frame need a ``static_transforms`` entry."""
    static_transforms: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    """``{frame: {translation: [x, y, z] (m), rotation: [qx, qy, qz, qw]}}``: each frame's pose in
    ``fixed_frame`` (entries may also be :class:`~pfield.spatial.Pose`; held as Poses after validation)."""
    global_fallback: bool = True
    """When the field alone stagnates or reaches the iteration limit, search globally and track the result."""
    global_time_limit: float = 2.0
    """s: wall-clock limit of that global search."""

    def __post_init__(self) -> None:
        timeout = self.dynamic_obstacle_timeout
        if isinstance(timeout, bool) or not isinstance(timeout, int | float) or not math.isfinite(timeout) \
                or timeout < 0:
            raise InvalidInput("dynamic_obstacle_timeout", timeout, "must be a finite number of seconds >= 0")
        if not isinstance(self.fixed_frame, str) or not self.fixed_frame:
            raise InvalidInput("fixed_frame", self.fixed_frame, "must be a non-empty frame name")
        object.__setattr__(self, "dynamic_obstacle_timeout", float(timeout))
        check_global_options(self.global_fallback, self.global_time_limit)
        object.__setattr__(self, "global_time_limit", float(self.global_time_limit))
        object.__setattr__(self, "static_transforms", parse_transforms(self.static_transforms, self.fixed_frame))


def _planning_method(value: str) -> str:
    """The request's ``planning_method`` (empty means task_space); anything else is refused."""
    method = value or TASK_SPACE
    if method not in (TASK_SPACE, WHOLE_BODY):
        raise InvalidInput("planning_method", method, f"expected {TASK_SPACE!r} or {WHOLE_BODY!r}")
    return method


@dataclass(frozen=True)
class _Held:
    obstacle: Any
    updated: float


class ManagerNode(Node):
    """The ``/pfield_manager`` node (see the module docstring).

    ``robot``: the :class:`~pfield.robot.RobotModel` of whole-body requests; ``config``: initial field
    parameters; ``resolver``: the :class:`~pfield.geometry.ResourceResolver` Mesh obstacles are loaded through
    (``package://`` paths and allowed roots; None allows the current directory only); ``csv_dir``: where
    every plan is saved as CSV (None: not saved).
    """

    name = "/pfield_manager"
    tick_period = 0.1

    def __init__(self, bus: Bus, robot: Any, *, config: FieldConfig | None = None,
                 parameters: ManagerParameters | None = None, resolver: Any = None,
                 csv_dir: Path | None = None) -> None:
        super().__init__(bus)
        self.robot = robot
        self.resolver = resolver
        self.csv_dir = csv_dir
        self._lock = threading.Lock()
        self._config = config or FieldConfig()
        self._params = parameters or ManagerParameters()
        self._obstacles: dict[str, _Held] = {}
        self._goal: Pose | None = None
        self._path_positions: Any = None
        self._field: Any = None
        self._plan_count = 0

    # ---- node contract ------------------------------------------------------------------------------
    def services(self) -> list[ServiceSpec]:
        return [
            ServiceSpec("/pfield/plan_path", "potential_fields_interfaces/srv/PlanPath", pfi.PlanPath_Request,
                        pfi.PlanPath_Response, self.plan_path, long_running=True),
            ServiceSpec("/pfield/compute_autonomy_vector", "potential_fields_interfaces/srv/ComputeAutonomyVector",
                        pfi.ComputeAutonomyVector_Request, pfi.ComputeAutonomyVector_Response,
                        self.compute_autonomy_vector),
            ServiceSpec("/pfield/remove_obstacles", "potential_fields_interfaces/srv/RemoveObstacles",
                        pfi.RemoveObstacles_Request, pfi.RemoveObstacles_Response, self.remove_obstacles),
            ServiceSpec("/pfield/clear_obstacles", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                        std_srvs.Trigger_Response, self.clear_obstacles),
        ]

    def subscriptions(self) -> list[SubscriptionSpec]:
        return [
            SubscriptionSpec("/pfield/obstacles", "potential_fields_interfaces/msg/ObstacleArray",
                             pfi.ObstacleArray, self.on_obstacles),
            SubscriptionSpec("/pfield/planning_goal_pose", "geometry_msgs/msg/PoseStamped", gm.PoseStamped,
                             self.on_goal),
            SubscriptionSpec("/pfield/query_pose", "geometry_msgs/msg/PoseStamped", gm.PoseStamped,
                             self.on_query_pose),
        ]

    def publications(self) -> list[PublicationSpec]:
        return [
            PublicationSpec("/pfield/planned_path", "nav_msgs/msg/Path", nav_msgs.Path),
            PublicationSpec("/pfield/markers", "visualization_msgs/msg/MarkerArray", visualization_msgs.MarkerArray),
            PublicationSpec("/pfield/autonomy_vector", "geometry_msgs/msg/TwistStamped", gm.TwistStamped),
        ]

    def get_parameters(self) -> dict[str, Any]:
        with self._lock:
            return self._config.as_dict() | {"dynamic_obstacle_timeout": self._params.dynamic_obstacle_timeout,
                                             "fixed_frame": self._params.fixed_frame,
                                             "global_fallback": self._params.global_fallback,
                                             "global_time_limit": self._params.global_time_limit,
                                             "static_transforms": transforms_data(self._params.static_transforms)}

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        own = {k: v for k, v in values.items() if k in ManagerParameters.__dataclass_fields__}
        field_values = {k: v for k, v in values.items() if k not in own}
        with self._lock:
            config = self._config.replace(**field_values) if field_values else self._config
            params = replace(self._params, **own)
            self._config, self._params, self._field = config, params, None
        self._publish_markers()
        return self.get_parameters()

    def tick(self, now: float) -> None:
        """Drop ``Dynamic`` obstacles older than ``dynamic_obstacle_timeout`` (monotonic seconds)."""
        with self._lock:
            timeout = self._params.dynamic_obstacle_timeout
            stale = [key for key, held in self._obstacles.items()
                     if timeout > 0 and held.obstacle.group == "Dynamic" and now - held.updated > timeout]
            for key in stale:
                del self._obstacles[key]
            if stale:
                self._field = None
        if stale:
            _log.info("dynamic obstacles expired: %s", ", ".join(stale))
            self._publish_markers()

    # ---- state --------------------------------------------------------------------------------------
    @property
    def config(self) -> FieldConfig:
        return self._config

    @property
    def goal(self) -> Pose | None:
        return self._goal

    def obstacles(self) -> list[Any]:
        """The obstacles held, in insertion order."""
        with self._lock:
            return [held.obstacle for held in self._obstacles.values()]

    def _frames(self) -> StaticTransforms:
        params = self._params
        return StaticTransforms(params.fixed_frame, params.static_transforms)

    def _snapshot(self) -> tuple[FieldConfig, Pose | None, list[Any]]:
        with self._lock:
            return self._config, self._goal, [held.obstacle for held in self._obstacles.values()]

    def _current_field(self) -> Any:
        """The field of the current state, rebuilt only after a change (None without a goal)."""
        with self._lock:
            if self._field is None and self._goal is not None:
                obstacles = [held.obstacle for held in self._obstacles.values()]
                self._field = _planning.make_field(self._config, self._goal, obstacles)
            return self._field

    def _publish_markers(self) -> None:
        config, goal, obstacles = self._snapshot()
        self.bus.publish("/pfield/markers", state_markers(self._params.fixed_frame, goal, obstacles,
                                                          config.influence_distance, self._path_positions))

    # ---- topic handlers -----------------------------------------------------------------------------
    def on_obstacles(self, message: pfi.ObstacleArray) -> None:
        """Add or replace obstacles by id; validates all of them before changing anything."""
        transform = self._frames().lookup("header.frame_id", message.header.frame_id)
        converted: dict[str, Any] = {}
        for i, item in enumerate(message.obstacles):
            if item.frame_id in converted:
                raise InvalidInput(f"obstacles[{i}].frame_id", item.frame_id, "duplicate id in one message")
            obstacle = obstacle_from_msg(item, self._make_mesh, f"obstacles[{i}]")
            converted[item.frame_id] = obstacle if transform is None else replace(obstacle,
                                                                                  pose=transform * obstacle.pose)
        now = time.monotonic()
        with self._lock:
            for key, obstacle in converted.items():
                self._obstacles[key] = _Held(obstacle, now)
            self._field = None
        self._publish_markers()

    def on_goal(self, message: gm.PoseStamped) -> None:
        transform = self._frames().lookup("header.frame_id", message.header.frame_id)
        goal = pose_from_msg(message.pose, "pose")
        goal = goal if transform is None else transform * goal
        with self._lock:
            self._goal, self._field = goal, None
        self._publish_markers()

    def on_query_pose(self, message: gm.PoseStamped) -> None:
        response = self.compute_autonomy_vector(pfi.ComputeAutonomyVector_Request(query_pose=message))
        self.bus.publish("/pfield/autonomy_vector", response.autonomy_vector)

    def _make_mesh(self, resource: str, scale_x: float, scale_y: float, scale_z: float) -> Any:
        try:
            return _planning.make_mesh(resource, (scale_x, scale_y, scale_z), self.resolver)
        except InvalidInput:
            raise
        except (PfieldError, OSError, ValueError) as exc:
            raise InvalidInput("mesh_resource", resource, str(exc)) from None

    # ---- services -----------------------------------------------------------------------------------
    def remove_obstacles(self, request: pfi.RemoveObstacles_Request) -> pfi.RemoveObstacles_Response:
        with self._lock:
            unknown = [key for key in request.frame_ids if key not in self._obstacles]
            if not unknown:
                for key in request.frame_ids:
                    self._obstacles.pop(key, None)
                self._field = None
            remaining = list(self._obstacles)
        if unknown:
            return pfi.RemoveObstacles_Response(success=False, remaining=remaining,
                                                message=f"unknown obstacle ids {unknown}; nothing removed")
        self._publish_markers()
        return pfi.RemoveObstacles_Response(success=True, remaining=remaining,
                                            message=f"removed {len(set(request.frame_ids))} obstacle(s)")

    def clear_obstacles(self, request: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
        with self._lock:
            count = len(self._obstacles)
            self._obstacles.clear()
            self._field = None
        self._publish_markers()
        return std_srvs.Trigger_Response(success=True, message=f"removed {count} obstacle(s)")

    def _plan_inputs(self, request: pfi.PlanPath_Request) -> _planning.PlanInputs:
        method = _planning_method(request.planning_method)
        dt, tolerance = request.delta_time, request.goal_tolerance
        if not (math.isfinite(dt) and dt > 0):
            raise InvalidInput("delta_time", dt, "must be > 0 s")
        if not (math.isfinite(tolerance) and tolerance > 0):
            raise InvalidInput("goal_tolerance", tolerance, "must be > 0 m")
        iterations = request.max_iterations if request.max_iterations > 0 else DEFAULT_MAX_ITERATIONS
        if iterations > MAX_ITERATIONS_CAP:
            raise InvalidInput("max_iterations", iterations,
                               f"must be <= {MAX_ITERATIONS_CAP} (0 means {DEFAULT_MAX_ITERATIONS})")
        goal = pose_from_msg(request.goal, "goal")
        start: Pose | None = None
        joints = None
        if method == WHOLE_BODY:
            joints = self.robot.check_joint_angles(request.starting_joint_angles, "starting_joint_angles")
        else:
            start = pose_from_msg(request.start, "start")
            if request.starting_joint_angles:
                joints = self.robot.check_joint_angles(request.starting_joint_angles, "starting_joint_angles")
        return _planning.PlanInputs(method, goal, start, joints, dt, tolerance, iterations)

    def plan_path(self, request: pfi.PlanPath_Request) -> pfi.PlanPath_Response:
        """Plan to ``request.goal`` (also the node's goal from now on); see PlanPath.srv for the fields."""
        inputs = self._plan_inputs(request)
        with self._lock:
            self._goal, self._field = inputs.goal, None
            config, params = self._config, self._params
            obstacles = [held.obstacle for held in self._obstacles.values()]
        path = _planning.run_plan(config, obstacles, self.robot, inputs, global_fallback=params.global_fallback,
                                  global_time_limit=params.global_time_limit)
        response = plan_response(path, self._params.fixed_frame)
        self._path_positions = path.positions
        self.bus.publish("/pfield/planned_path", response.end_effector_path)
        self._publish_markers()
        self._save_csv(path, inputs.method)
        return response

    def _save_csv(self, path: Any, method: str) -> None:
        if self.csv_dir is None:
            return
        with self._lock:
            self._plan_count += 1
            count = self._plan_count
        target = Path(self.csv_dir) / f"plan_{time.strftime('%Y%m%d_%H%M%S')}_{count:04d}_{method}.csv"
        target.parent.mkdir(parents=True, exist_ok=True)
        path.to_csv(target)
        _log.info("plan saved to %s", target)

    def compute_autonomy_vector(self, request: pfi.ComputeAutonomyVector_Request
                                ) -> pfi.ComputeAutonomyVector_Response:
        """The field's limited twist at the query pose (task_space) or at ``joint_angles`` (whole_body)."""
        method = _planning_method(request.planning_method)
        if not (math.isfinite(request.delta_time) and request.delta_time >= 0):
            raise InvalidInput("delta_time", request.delta_time, "must be >= 0 s")
        transform = self._frames().lookup("query_pose.header.frame_id", request.query_pose.header.frame_id)
        if method == WHOLE_BODY:
            q = self.robot.check_joint_angles(request.joint_angles, "joint_angles")
            qd = None
            if request.prev_joint_velocities:
                qd = as_vector("prev_joint_velocities", request.prev_joint_velocities, len(q))
            # An all-default query pose means "not given" (the seed's whole_body request may omit it).
            given = request.query_pose.pose != type(request.query_pose.pose)()
            pose = pose_from_msg(request.query_pose.pose, "query_pose.pose") if given else None
        else:
            pose = pose_from_msg(request.query_pose.pose, "query_pose.pose")
        if pose is not None and transform is not None:
            pose = transform * pose
        field = self._current_field()
        if field is None:
            raise InvalidInput("goal", None, "no goal yet: publish /pfield/planning_goal_pose or call plan_path")
        if method == WHOLE_BODY:
            twist = _planning.whole_body_twist(field, self.robot, q, qd, request.delta_time, pose)
        else:
            assert pose is not None
            twist = field.twist(pose)
        vector = twist_stamped(twist, self._params.fixed_frame, time.time())
        return pfi.ComputeAutonomyVector_Response(autonomy_vector=vector)
