"""``/pfield_manager``: the transport-free manipulator node (obstacles, goal, parameters, planning).

Topics in: ``/pfield/obstacles`` (ObstacleArray: add or replace by id; one bad obstacle rejects the whole
message), ``/pfield/planning_goal_pose`` (PoseStamped), ``/pfield/query_pose`` (PoseStamped: answers on
``/pfield/autonomy_vector``). Topics out: ``/pfield/planned_path`` (nav_msgs/Path), ``/pfield/markers``
(MarkerArray). Services: ``/pfield/plan_path``, ``/pfield/compute_autonomy_vector``,
``/pfield/compute_assistance`` (shared control, :mod:`pfield.shared_control`), ``/pfield/remove_obstacles`` and
``/pfield/clear_obstacles`` (std_srvs/Trigger). ``Dynamic`` obstacles get a velocity estimated from successive
poses (:mod:`pfield.node.obstacle_motion`) or given on ``/pfield/obstacle_velocities``
(ObstacleVelocityArray: every id must be held, or nothing changes); only the assistance uses it. Parameters: every
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
``max_iterations`` ≤ 0 means :data:`DEFAULT_MAX_ITERATIONS`; above :data:`MAX_ITERATIONS_CAP` is refused. A
``delta_time`` or ``goal_tolerance`` of 0 (what ROS fills in for a field left out) means
:data:`DEFAULT_DELTA_TIME` / :data:`DEFAULT_GOAL_TOLERANCE`, the values of the seed's examples.

Bounded work (each limit refused with ``InvalidInput`` naming the field, the value and the limit, before
anything runs or changes): at most :data:`MAX_OBSTACLES` obstacles; Mesh files up to the
``max_mesh_file_size`` parameter; ``delta_time`` in [:data:`MIN_DELTA_TIME`, :data:`MAX_DELTA_TIME`] s with
``max_iterations · delta_time`` representable as a ``builtin_interfaces/Time`` (int32 seconds); a plan's
estimated work ``max_iterations × max(1, obstacles)`` ≤ :data:`MAX_PLAN_WORK`; poses within
:data:`~pfield.interfaces.convert.MAX_COORDINATE` m with a normalisable quaternion.

State: one immutable :class:`~pfield.node._manager_state.ManagerState` swapped under the node's lock; the
potential field and the markers are memoised on its version. A plan changes the goal (and the path shown
in the markers) only when it completes: a refused, failing with an exception, or cancelled plan leaves the
node as it was.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from pfield import safety
from pfield._validation import as_vector, finite, in_range
from pfield.errors import InvalidInput, PfieldError
from pfield.field.config import FieldConfig
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces import nav_msgs, sensor_msgs, std_srvs, visualization_msgs
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.convert import (
    obstacle_from_msg,
    plan_response,
    pose_from_msg,
    twist_stamped,
    twist_stamped_fields,
)
from pfield.node import _planning
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec
from pfield.node._frames import transforms_data
from pfield.node._joint_states import JOINT_STATES_TOPIC, JointStateCache, rotate_twist
from pfield.node._manager_state import MAX_OBSTACLES, ManagerParameters, ManagerState, Memo, manager_table
from pfield.node._markers import state_markers
from pfield.node.obstacle_motion import updated_held
from pfield.planning.cancel import CancelToken
from pfield.planning.task_space import DEFAULT_MAX_ITERATIONS
from pfield.shared_control.assistance import (
    ARBITRATIONS,
    AssistanceOptions,
    AssistanceScene,
    task_space_assistance,
    whole_body_assistance,
)
from pfield.spatial import Pose, Twist, rotate_vectors

__all__ = ["DEFAULT_DELTA_TIME", "DEFAULT_GOAL_TOLERANCE", "DEFAULT_MAX_ITERATIONS", "MAX_DELTA_TIME",
           "MAX_ITERATIONS_CAP", "MAX_OBSTACLES", "MAX_PLAN_WORK", "MIN_DELTA_TIME", "ManagerNode",
           "ManagerParameters"]

_log = logging.getLogger(__name__)
MAX_ITERATIONS_CAP = 200_000
"""Largest accepted ``max_iterations`` (about 4000 s of motion at dt = 0.02 s): bounds a request's cost."""
MIN_DELTA_TIME, MAX_DELTA_TIME = 1e-6, 10.0
"""s: the accepted ``delta_time`` of a plan (a 1 MHz to 0.1 Hz control rate covers every real controller;
below 1 µs the waypoints' nanosecond stamps would no longer be distinct)."""
DEFAULT_DELTA_TIME = 0.02
"""s: the step of a plan whose request leaves ``delta_time`` at 0 (the seed's examples use 0.02 s)."""
DEFAULT_GOAL_TOLERANCE = 0.01
"""m: the goal tolerance of a plan whose request leaves ``goal_tolerance`` at 0 (the seed's examples)."""
MAX_PLAN_WORK = 50_000_000
"""Largest ``max_iterations × max(1, obstacles)`` of one plan (obstacle-steps): e.g. 200 000 iterations
among 250 obstacles or 30 000 among 1666. With the compiled core a task-space step costs about 0.04 µs per sphere
and up to about 2 µs per 448-triangle mesh (``make bench`` of 2026-12-07: bench_task_space, bench_field), so a capped
plan takes a few seconds among spheres and up to a minute or two among meshes, off the event loop."""
QUICK_CALL_SECONDS = 0.5e-3
"""s: a control-loop call (autonomy vector, assistance) that took at most this long is *quick*: the next one
of its kind, on the same derived state and no more obstacles, may be answered on the transport's event loop
(:attr:`~pfield.node._base.ServiceSpec.quick`). The first of a kind (kernels may still compile), one after a
goal or obstacle change (the field is rebuilt) and any slower one always run on the calls thread, so a loop
stall is bounded by one call that was measured quick."""
TrajectoryExecutor = Callable[[Any, str, float, CancelToken | None], pfi.ExecuteTrajectory_Response]
"""(trajectory_msgs/JointTrajectory model, action name, goal_time_tolerance s, cancel) -> the service's answer."""
_INT32_SECONDS = 2**31 - 1
_CANCELLED = pfi.PlanPath_Response(success=False, error_message="cancelled: the caller went away")
TASK_SPACE, WHOLE_BODY = pfi.PLANNING_METHOD_TASK_SPACE, pfi.PLANNING_METHOD_WHOLE_BODY


def _cost_key(kind: str, request: Any, state: ManagerState) -> tuple[str, str, bool]:
    """The calls whose cost :attr:`ManagerNode._call_costs` keeps together: (service, planning_method, has a
    goal)."""
    return kind, request.planning_method, state.goal is not None


def _planning_method(value: str) -> str:
    """The request's ``planning_method`` (empty means task_space); anything else is refused."""
    method = value or TASK_SPACE
    if method not in (TASK_SPACE, WHOLE_BODY):
        raise InvalidInput("planning_method", method, f"expected {TASK_SPACE!r} or {WHOLE_BODY!r}")
    return method


def _plan_duration(delta_time: float, iterations: int) -> float:
    """``delta_time`` checked: in range, and ``iterations · delta_time`` fits a Time's int32 seconds."""
    dt = in_range("delta_time", delta_time, MIN_DELTA_TIME, MAX_DELTA_TIME, "s")
    if iterations * dt > _INT32_SECONDS:
        raise InvalidInput("delta_time", delta_time, f"{iterations} steps of it exceed a builtin_interfaces/Time "
                           f"(int32 seconds, {_INT32_SECONDS} s)")
    return dt


class ManagerNode(Node):
    """The ``/pfield_manager`` node (see the module docstring).

    ``robot``: the :class:`~pfield.robot.RobotModel` of whole-body requests; ``config``: initial field
    parameters; ``resolver``: the :class:`~pfield.geometry.ResourceResolver` Mesh obstacles are loaded through
    (``package://`` paths and allowed roots; None allows the current directory only); ``csv_dir``: where
    every plan is saved as CSV (None: not saved); ``assistance``: the laws' options of ``compute_assistance``
    (its ``arbitration`` is the default of an empty request field).
    """

    name = "/pfield_manager"
    tick_period = 0.1

    def __init__(self, bus: Bus, robot: Any, *, config: FieldConfig | None = None,
                 parameters: ManagerParameters | None = None, resolver: Any = None,
                 csv_dir: Path | None = None, assistance: AssistanceOptions | None = None) -> None:
        super().__init__(bus)
        self.robot = robot
        self.resolver = resolver
        self.csv_dir = csv_dir
        self.parameter_table = manager_table(self.name)
        self._lock = threading.Lock()
        parameters = parameters or ManagerParameters()
        if assistance is not None:  # the options' arbitration is the parameter's initial value
            parameters = replace(parameters, assistance_arbitration=assistance.arbitration)
        self._state = ManagerState(config or FieldConfig(), parameters)
        self._field: Memo[Any] = Memo(lambda s: None if s.goal is None else
                                      _planning.make_field(s.config, s.goal, s.obstacle_list()),
                                      depends=("config", "goal", "obstacles"))
        self._markers: Memo[visualization_msgs.MarkerArray] = Memo(
            lambda s: state_markers(s.params.fixed_frame, s.goal, s.obstacle_list(), s.config.influence_distance,
                                    s.path_positions))
        self.assistance_options = assistance or AssistanceOptions()
        self._scene: Memo[AssistanceScene] = Memo(self._make_scene, depends=("config", "goal", "obstacles"))
        self._plan_count = 0
        self.joint_states = JointStateCache(robot)
        """The latest ``/joint_states`` (:mod:`pfield.node._joint_states`): what a request without joint angles uses."""
        self.joint_states_subscriber: Node = self
        """The node whose subscription feeds :attr:`joint_states` from ``/joint_states`` (into :meth:`on_joint_states`):
        this one, or the servo hosted beside it (:class:`pfield.node.servo_node.ServoNode`), which then takes it over
        so that a joint state is handled on the servo's own executor thread, one at a time with its commands, and
        never wakes the executor shared by the other nodes (whose wake-up and hand-over of the GIL delayed the command
        that followed a joint state by up to 10-17 ms on a 2-core machine, ``benchmarks/bench_servo.py``)."""
        self._call_costs: dict[tuple[str, str, bool], tuple[int, float]] = {}
        """(service, planning_method, has a goal) → (obstacle count, s) of the last such call answered."""

    # ---- node contract ------------------------------------------------------------------------------
    def services(self) -> list[ServiceSpec]:
        return [
            ServiceSpec("/pfield/plan_path", "potential_fields_interfaces/srv/PlanPath", pfi.PlanPath_Request,
                        pfi.PlanPath_Response, self.plan_path, long_running=True, cancellable=True),
            ServiceSpec("/pfield/compute_autonomy_vector", "potential_fields_interfaces/srv/ComputeAutonomyVector",
                        pfi.ComputeAutonomyVector_Request, pfi.ComputeAutonomyVector_Response,
                        # not long_running (nor is compute_assistance): a control loop calling them at rate
                        # must not queue behind plans
                        self.compute_autonomy_vector, quick=self._quick("autonomy", self._field)),
            ServiceSpec("/pfield/compute_assistance", "potential_fields_interfaces/srv/ComputeAssistance",
                        pfi.ComputeAssistance_Request, pfi.ComputeAssistance_Response, self.compute_assistance,
                        quick=self._quick("assistance", self._scene)),
            ServiceSpec("/pfield/remove_obstacles", "potential_fields_interfaces/srv/RemoveObstacles",
                        pfi.RemoveObstacles_Request, pfi.RemoveObstacles_Response, self.remove_obstacles,
                        long_running=True),
            ServiceSpec("/pfield/clear_obstacles", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                        std_srvs.Trigger_Response, self.clear_obstacles, long_running=True),
            *self._execution_services(),
        ]

    def subscriptions(self) -> list[SubscriptionSpec]:
        return [
            SubscriptionSpec("/pfield/obstacles", "potential_fields_interfaces/msg/ObstacleArray",
                             pfi.ObstacleArray, self.on_obstacles),
            SubscriptionSpec("/pfield/planning_goal_pose", "geometry_msgs/msg/PoseStamped", gm.PoseStamped,
                             self.on_goal),
            SubscriptionSpec("/pfield/query_pose", "geometry_msgs/msg/PoseStamped", gm.PoseStamped,
                             self.on_query_pose),
            SubscriptionSpec("/pfield/obstacle_velocities", "potential_fields_interfaces/msg/ObstacleVelocityArray",
                             pfi.ObstacleVelocityArray, self.on_obstacle_velocities),
            *([SubscriptionSpec(JOINT_STATES_TOPIC, "sensor_msgs/msg/JointState", sensor_msgs.JointState,
                                self.on_joint_states)] if self.joint_states_subscriber is self else []),
        ]

    def publications(self) -> list[PublicationSpec]:
        return [
            PublicationSpec("/pfield/planned_path", "nav_msgs/msg/Path", nav_msgs.Path),
            PublicationSpec("/pfield/markers", "visualization_msgs/msg/MarkerArray", visualization_msgs.MarkerArray),
            PublicationSpec("/pfield/autonomy_vector", "geometry_msgs/msg/TwistStamped", gm.TwistStamped),
        ]

    def get_parameters(self) -> dict[str, Any]:
        state = self._state
        params = state.params
        return state.config.as_dict() | {"dynamic_obstacle_timeout": params.dynamic_obstacle_timeout,
                                         "fixed_frame": params.fixed_frame,
                                         "static_transforms": transforms_data(params.static_transforms),
                                         "max_mesh_file_size": params.max_mesh_file_size,
                                         "global_fallback": params.global_fallback,
                                         "global_time_limit": params.global_time_limit,
                                         "assistance_arbitration": params.assistance_arbitration,
                                         "joint_state_timeout": params.joint_state_timeout,
                                         "trajectory_controller_action": params.trajectory_controller_action}

    def describe_parameters(self) -> dict[str, dict[str, Any]]:
        return self.parameter_table.describe()

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        checked = self.parameter_table.check(values)
        own = {k: v for k, v in checked.items() if k in ManagerParameters.__dataclass_fields__}
        field_values = {k: v for k, v in checked.items() if k not in own}
        with self._lock:
            state = self._state
            config = state.config.replace(**field_values) if field_values else state.config
            params = replace(state.params, **own)
            self._state = state.evolve(config=config, params=params)
        self._publish_markers()
        return self.get_parameters()

    def tick(self, now: float) -> None:
        """Drop ``Dynamic`` obstacles older than ``dynamic_obstacle_timeout`` (monotonic seconds)."""
        with self._lock:
            state = self._state
            timeout = state.params.dynamic_obstacle_timeout
            stale = [key for key, held in state.obstacles.items()
                     if timeout > 0 and held.obstacle.group == "Dynamic" and now - held.updated > timeout]
            if stale:
                self._state = state.evolve(obstacles={k: v for k, v in state.obstacles.items() if k not in stale})
        if stale:
            _log.info("dynamic obstacles expired: %s", ", ".join(stale))
            self._publish_markers()

    # ---- state --------------------------------------------------------------------------------------
    @property
    def state(self) -> ManagerState:
        """The current state snapshot (immutable)."""
        return self._state

    @property
    def config(self) -> FieldConfig:
        return self._state.config

    @property
    def goal(self) -> Pose | None:
        return self._state.goal

    def obstacles(self) -> list[Any]:
        """The obstacles held, in insertion order."""
        return self._state.obstacle_list()

    def markers(self) -> visualization_msgs.MarkerArray:
        """The markers of the current state (memoised on its version)."""
        return self._markers.get(self._state)

    def _current_field(self) -> Any:
        """The field of the current state, rebuilt only after a change (None without a goal)."""
        return self._field.get(self._state)

    def _publish_markers(self) -> None:
        self.bus.publish("/pfield/markers", self.markers())

    # ---- topic handlers -----------------------------------------------------------------------------
    def on_obstacles(self, message: pfi.ObstacleArray) -> None:
        """Add or replace obstacles by id; validates all of them (and the count cap) before changing anything."""
        state = self._state
        transform = state.params.frames().lookup("header.frame_id", message.header.frame_id)
        ids = [item.frame_id for item in message.obstacles]
        self._check_count(state, ids)
        converted: dict[str, Any] = {}
        for i, item in enumerate(message.obstacles):
            if item.frame_id in converted:
                raise InvalidInput(f"obstacles[{i}].frame_id", item.frame_id, "duplicate id in one message")
            obstacle = obstacle_from_msg(item, self._make_mesh, f"obstacles[{i}]")
            converted[item.frame_id] = obstacle if transform is None else replace(obstacle,
                                                                                  pose=transform * obstacle.pose)
        now = time.monotonic()
        with self._lock:
            state = self._state
            self._check_count(state, ids)  # again: another message may have added obstacles meanwhile
            timeout = state.params.dynamic_obstacle_timeout
            held = dict(state.obstacles) | {key: updated_held(state.obstacles.get(key), obstacle, now, timeout)
                                            for key, obstacle in converted.items()}
            self._state = state.evolve(obstacles=held)
        self._publish_markers()

    def on_obstacle_velocities(self, message: pfi.ObstacleVelocityArray) -> None:
        """Explicit obstacle velocities (m/s): every id must be held and every value finite, else nothing changes."""
        state = self._state
        transform = state.params.frames().lookup("header.frame_id", message.header.frame_id)
        given: dict[str, tuple[float, float, float]] = {}
        for i, item in enumerate(message.velocities):
            if item.frame_id not in state.obstacles:
                raise InvalidInput(f"velocities[{i}].frame_id", item.frame_id, "no obstacle with this id is held")
            if item.frame_id in given:
                raise InvalidInput(f"velocities[{i}].frame_id", item.frame_id, "duplicate id in one message")
            linear = [finite(f"velocities[{i}].linear.{axis}", getattr(item.linear, axis)) for axis in "xyz"]
            linear = safety.check_obstacle_velocity(f"velocities[{i}].linear", linear).tolist()
            if transform is not None:
                linear = [float(x) for x in rotate_vectors(transform.orientation, linear)]
            given[item.frame_id] = (linear[0], linear[1], linear[2])
        with self._lock:
            state = self._state
            missing = [key for key in given if key not in state.obstacles]
            if missing:
                raise InvalidInput("velocities", missing, "obstacles removed meanwhile; nothing changed")
            held = dict(state.obstacles) | {key: replace(state.obstacles[key], velocity=v, explicit=True)
                                            for key, v in given.items()}
            self._state = state.evolve(obstacles=held)

    @staticmethod
    def _check_count(state: ManagerState, ids: list[str]) -> None:
        total = len(state.obstacles) + len(set(ids) - set(state.obstacles))
        if len(ids) > MAX_OBSTACLES or total > MAX_OBSTACLES:
            raise InvalidInput("obstacles", f"{len(ids)} obstacles", f"would hold {max(total, len(ids))} obstacles, "
                               f"above the cap of {MAX_OBSTACLES} (the node holds {len(state.obstacles)}); "
                               "remove some first")

    def on_joint_states(self, message: sensor_msgs.JointState) -> None:
        """The robot's measured joints (any order, extra joints ignored; refused whole when one is bad)."""
        self.joint_states.update(message.name, message.position, message.velocity)

    def measured_joint_angles(self, given: Any, field: str, state: ManagerState | None = None) -> Any:
        """``given`` validated, or when it is empty the latest ``/joint_states`` within ``joint_state_timeout``."""
        if len(given):
            return self.robot.check_joint_angles(given, field)
        max_age = (state or self._state).params.joint_state_timeout
        return self.joint_states.latest(max_age, field).positions

    def on_goal(self, message: gm.PoseStamped) -> None:
        transform = self._state.params.frames().lookup("header.frame_id", message.header.frame_id)
        goal = pose_from_msg(message.pose, "pose")
        goal = goal if transform is None else transform * goal
        with self._lock:
            self._state = self._state.evolve(goal=goal)
        self._publish_markers()

    def on_query_pose(self, message: gm.PoseStamped) -> None:
        response = self.compute_autonomy_vector(pfi.ComputeAutonomyVector_Request(query_pose=message))
        self.bus.publish("/pfield/autonomy_vector", response.autonomy_vector)

    def _make_mesh(self, resource: str, scale_x: float, scale_y: float, scale_z: float) -> Any:
        try:
            return _planning.make_mesh(resource, (scale_x, scale_y, scale_z), self.resolver,
                                       self._state.params.max_mesh_file_size)
        except InvalidInput:
            raise
        except (PfieldError, OSError, ValueError) as exc:
            raise InvalidInput("mesh_resource", resource, str(exc)) from None

    # ---- services -----------------------------------------------------------------------------------
    def remove_obstacles(self, request: pfi.RemoveObstacles_Request) -> pfi.RemoveObstacles_Response:
        with self._lock:
            state = self._state
            unknown = [key for key in request.frame_ids if key not in state.obstacles]
            if not unknown and request.frame_ids:
                gone = set(request.frame_ids)
                state = self._state = state.evolve(obstacles={k: v for k, v in state.obstacles.items()
                                                              if k not in gone})
            remaining = list(state.obstacles)
        if unknown:
            return pfi.RemoveObstacles_Response(success=False, remaining=remaining,
                                                message=f"unknown obstacle ids {unknown}; nothing removed")
        if request.frame_ids:
            self._publish_markers()
        return pfi.RemoveObstacles_Response(success=True, remaining=remaining,
                                            message=f"removed {len(set(request.frame_ids))} obstacle(s)")

    def clear_obstacles(self, request: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
        with self._lock:
            state = self._state
            count = len(state.obstacles)
            self._state = state.evolve(obstacles={})
        self._publish_markers()
        return std_srvs.Trigger_Response(success=True, message=f"removed {count} obstacle(s)")

    def _plan_inputs(self, request: pfi.PlanPath_Request, obstacle_count: int) -> _planning.PlanInputs:
        """The whole request validated (nothing is changed before this returns)."""
        method = _planning_method(request.planning_method)
        iterations = request.max_iterations if request.max_iterations > 0 else DEFAULT_MAX_ITERATIONS
        if iterations > MAX_ITERATIONS_CAP:
            raise InvalidInput("max_iterations", iterations,
                               f"must be <= {MAX_ITERATIONS_CAP} (0 means {DEFAULT_MAX_ITERATIONS})")
        if iterations * max(1, obstacle_count) > MAX_PLAN_WORK:
            largest = MAX_PLAN_WORK // max(1, obstacle_count)
            raise InvalidInput("max_iterations", iterations, f"{iterations} iterations among {obstacle_count} "
                               f"obstacles exceed the work cap of {MAX_PLAN_WORK} obstacle-steps: with these "
                               f"obstacles, max_iterations <= {largest} passes (or remove obstacles)")
        dt = _plan_duration(request.delta_time or DEFAULT_DELTA_TIME, iterations)
        tolerance = request.goal_tolerance if request.goal_tolerance != 0 else DEFAULT_GOAL_TOLERANCE
        if not (math.isfinite(tolerance) and tolerance > 0):
            raise InvalidInput("goal_tolerance", tolerance, f"must be > 0 m (0 means {DEFAULT_GOAL_TOLERANCE} m)")
        goal = pose_from_msg(request.goal, "goal")
        start: Pose | None = None
        joints = None
        if method == WHOLE_BODY:
            joints = self.measured_joint_angles(request.starting_joint_angles, "starting_joint_angles")
        else:
            start = pose_from_msg(request.start, "start")
            if request.starting_joint_angles:
                joints = self.robot.check_joint_angles(request.starting_joint_angles, "starting_joint_angles")
        return _planning.PlanInputs(method, goal, start, joints, dt, tolerance, iterations)

    def plan_path(self, request: pfi.PlanPath_Request, cancel: CancelToken | None = None) -> pfi.PlanPath_Response:
        """Plan to ``request.goal`` (also the node's goal from now on); see PlanPath.srv for the fields.

        The goal and the markers' path change only when the plan completes: a refused request, a plan that
        raises or one ``cancel``\\ led (the caller went away) leaves the node's state as it was."""
        state = self._state
        inputs = self._plan_inputs(request, len(state.obstacles))
        if cancel is not None and cancel.cancelled:
            return _CANCELLED.model_copy()
        params = state.params
        path = _planning.run_plan(state.config, state.obstacle_list(), self.robot, inputs, cancel=cancel,
                                  global_fallback=params.global_fallback, global_time_limit=params.global_time_limit)
        if cancel is not None and cancel.cancelled:
            return _CANCELLED.model_copy()
        response = plan_response(path, state.params.fixed_frame)
        with self._lock:
            self._state = self._state.evolve(goal=inputs.goal, path_positions=path.positions)
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

    # ---- trajectories out: /pfield/execute_trajectory (FollowJointTrajectory) ----------------------------
    trajectory_executor: TrajectoryExecutor | None = None
    """Runs a trajectory on a controller's FollowJointTrajectory action: set by the ROS 2 transport
    (:mod:`pfield.transport.trajectory_client`); None (the HTTP node) answers that execution needs ROS 2."""

    def _execution_services(self) -> list[ServiceSpec]:
        return [ServiceSpec("/pfield/execute_trajectory", "potential_fields_interfaces/srv/ExecuteTrajectory",
                            pfi.ExecuteTrajectory_Request, pfi.ExecuteTrajectory_Response, self.execute_trajectory,
                            long_running=True, cancellable=True)]

    def execute_trajectory(self, request: pfi.ExecuteTrajectory_Request,
                           cancel: CancelToken | None = None) -> pfi.ExecuteTrajectory_Response:
        """Execute ``request.trajectory`` on ``request.controller_action`` (empty: the
        ``trajectory_controller_action`` parameter) and answer with the controller's result (ExecuteTrajectory.srv).

        The call lasts as long as the trajectory (it is long-running: other services keep answering); ``cancel``
        (the caller went away) cancels the goal. Bad input raises :class:`InvalidInput` before anything is sent."""
        action = request.controller_action or self._state.params.trajectory_controller_action
        tolerance = in_range("goal_time_tolerance", request.goal_time_tolerance, 0.0, 3600.0, "s")
        executor = self.trajectory_executor
        if executor is None:
            return pfi.ExecuteTrajectory_Response(
                success=False, error_message="trajectory execution needs the ROS 2 transport (FollowJointTrajectory "
                "is a ROS 2 action): serve with `pfield ros2 node`, or use `pfield ros2 execute`")
        return executor(request.trajectory, action, tolerance, cancel)

    def compute_autonomy_vector(self, request: pfi.ComputeAutonomyVector_Request
                                ) -> pfi.ComputeAutonomyVector_Response:
        """The field's limited twist at the query pose (task_space) or at ``joint_angles`` (whole_body)."""
        started, state = time.perf_counter(), self._state
        method, dt, q, qd, pose = self._query(request, state)
        field = self._field.get(state)
        if field is None:
            raise InvalidInput("goal", None, "no goal yet: publish /pfield/planning_goal_pose or call plan_path")
        if method == WHOLE_BODY:
            twist = _planning.whole_body_twist(field, self.robot, q, qd, dt, pose)
        else:
            assert pose is not None
            twist = field.twist(pose)
        vector = twist_stamped(twist, state.params.fixed_frame, self.stamp_clock())
        response = pfi.ComputeAutonomyVector_Response(autonomy_vector=vector)
        self._answered("autonomy", request, state, started)
        return response

    def _quick(self, kind: str, memo: Memo[Any]) -> Any:
        """The :attr:`ServiceSpec.quick` test of one control-loop service (see :data:`QUICK_CALL_SECONDS`)."""
        def quick(request: Any) -> bool:
            state = self._state
            last = self._call_costs.get(_cost_key(kind, request, state))
            return (last is not None and last[1] <= QUICK_CALL_SECONDS and len(state.obstacles) <= last[0]
                    and memo.ready(state))
        return quick

    def _answered(self, kind: str, request: Any, state: ManagerState, started: float) -> None:
        """Record what a control-loop call of ``kind`` cost (for :meth:`_quick`)."""
        self._call_costs[_cost_key(kind, request, state)] = (len(state.obstacles), time.perf_counter() - started)

    def _query(self, request: Any, state: ManagerState) -> tuple[str, float, Any, Any, Pose | None]:
        """The ComputeAutonomyVector fields of ``request`` validated: (method, dt, q, q̇_prev, pose)."""
        method = _planning_method(request.planning_method)
        dt = in_range("delta_time", request.delta_time, 0.0, MAX_DELTA_TIME, "s")
        q = qd = None
        frames = state.params.frames()
        transform = frames.lookup("query_pose.header.frame_id", request.query_pose.header.frame_id)
        if method == WHOLE_BODY:
            q = self.measured_joint_angles(request.joint_angles, "joint_angles", state)
            qd = None
            if request.prev_joint_velocities:
                qd = as_vector("prev_joint_velocities", request.prev_joint_velocities, len(q))
            # An all-default query pose means "not given" (the seed's whole_body request may omit it).
            given = request.query_pose.pose != type(request.query_pose.pose)()
            pose = pose_from_msg(request.query_pose.pose, "query_pose.pose") if given else None
        elif request.query_pose.pose == type(request.query_pose.pose)() and self.joint_states.held is not None:
            # task space without a query pose: the end effector where the measured joints put it
            q = self.measured_joint_angles(request.joint_angles, "joint_angles", state)
            pose = self.robot.forward_kinematics(q)
            transform = None
        else:
            pose = pose_from_msg(request.query_pose.pose, "query_pose.pose")
        if pose is not None and transform is not None:
            pose = transform * pose
        return method, dt, q, qd, pose

    def assistance_scene(self) -> AssistanceScene:
        """The assistance's scene of the current state (obstacles, their velocities, goal, field parameters),
        memoised: what the servo loop steps against."""
        return self._scene.get(self._state)

    def _make_scene(self, state: ManagerState) -> AssistanceScene:
        velocities = {key: held.velocity for key, held in state.obstacles.items() if any(held.velocity)}
        field = self._field.get(state)
        return AssistanceScene(field=field, config=state.config, obstacles=state.obstacle_list(),
                               velocities=velocities, options=self.assistance_options)

    def compute_assistance(self, request: pfi.ComputeAssistance_Request) -> pfi.ComputeAssistance_Response:
        """Shared control at the query pose or joint angles: see ComputeAssistance.srv and :mod:`pfield.shared_control`.

        Works without a goal (``FLAG_NO_GOAL``: zero autonomy vector, α = 0, the operator's command with its
        approach limited). ``user_command`` in another frame is rotated into the fixed frame; its stamp (when
        non-zero) dates it for ``FLAG_STALE_INPUT``.
        """
        started, state = time.perf_counter(), self._state
        method, dt, q, qd, pose = self._query(request, state)
        if request.arbitration and request.arbitration not in ARBITRATIONS:
            raise InvalidInput("arbitration", request.arbitration, f"expected one of {list(ARBITRATIONS)} or empty")
        arbitration = request.arbitration or state.params.assistance_arbitration
        user = request.user_command
        command = self.operator_twist(user, state, q, pose)
        age = self.stamp_age(user.header.stamp)
        scene = self._scene.get(state)
        if method == WHOLE_BODY:
            answer = whole_body_assistance(scene, self.robot, q, command, arbitration,
                                           prev_joint_velocities=qd, dt=dt, input_age=age)
        else:
            assert pose is not None
            answer = task_space_assistance(scene, pose, command, arbitration, input_age=age)
        frame, now = state.params.fixed_frame, self.stamp_clock()
        response = pfi.ComputeAssistance_Response.model_validate({  # one validation pass for the whole answer
            "autonomy_vector": twist_stamped_fields(answer.autonomy_vector, frame, now),
            "joint_velocities": np.asarray(answer.joint_velocities, dtype=float).tolist(),
            "blended_command": twist_stamped_fields(answer.blended_command, frame, now),
            "alpha": answer.alpha, "speed_scale": answer.speed_scale,
            "nearest_obstacle_id": answer.nearest_obstacle_id, "nearest_distance": answer.nearest_distance,
            "nearest_normal": _xyz(answer.nearest_normal), "robot_point": _xyz(answer.robot_point),
            "obstacle_point": _xyz(answer.obstacle_point), "time_to_collision": answer.time_to_collision,
            "flags": answer.flags, "message": answer.message})
        self._answered("assistance", request, state, started)
        return response


    def operator_twist(self, user: gm.TwistStamped, state: ManagerState, q: Any = None,
                       pose: Pose | None = None, field: str = "user_command") -> Twist:
        """An operator's twist in the fixed frame: given in it (or ``""``), in a static frame (rotated by its
        transform), or in the robot's end-effector frame (rotated by FK(``q``), else by the task-space ``pose``'s
        orientation; :func:`~pfield.node._joint_states.rotate_twist`)."""
        values = [finite(f"{field}.twist.{part}.{axis}", getattr(getattr(user.twist, part), axis))
                  for part in ("linear", "angular") for axis in "xyz"]
        command = Twist(values[:3], values[3:])
        frame = user.header.frame_id
        if frame and frame == self.robot.end_effector and frame != state.params.fixed_frame:
            if q is None and pose is None:
                q = self.measured_joint_angles([], "joint_angles", state)
            if q is not None:
                return rotate_twist(command, self.robot.forward_kinematics(q).orientation)
            assert pose is not None
            orientation = pose.orientation
            return rotate_twist(command, orientation)
        transform = state.params.frames().lookup(f"{field}.header.frame_id", frame, "twists", self.robot.end_effector)
        return command if transform is None else rotate_twist(command, transform.orientation)


def _xyz(values: Any) -> dict[str, float]:
    return {"x": float(values[0]), "y": float(values[1]), "z": float(values[2])}
