"""``potential_fields_interfaces``: pfield's own messages and services (``ros/potential_fields_interfaces``).

Field for field as the seed document's ``.msg``/``.srv`` files (``Obstacle``, ``ObstacleArray``,
``PlanPath``, ``ComputeAutonomyVector``), ``FindValidPose`` as mbf_msgs, plus the services this package
adds (``RemoveObstacles``; shared control: ``ComputeAssistance``, ``ObstacleVelocity``,
``ObstacleVelocityArray``). ``tests/interfaces`` proves the models equal the files.
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import Field

from pfield.interfaces._base import Bool, Float32, Float64, Int32, RosMessage, String, UInt8, UInt32
from pfield.interfaces.geometry_msgs import Point, Pose, PoseStamped, TwistStamped, Vector3
from pfield.interfaces.nav_msgs import Path
from pfield.interfaces.std_msgs import Header
from pfield.interfaces.trajectory_msgs import JointTrajectory

PLANNING_METHOD_TASK_SPACE = "task_space"
PLANNING_METHOD_WHOLE_BODY = "whole_body"
_PLANNING_CONSTANTS: dict[str, tuple[str, Any]] = {
    "PLANNING_METHOD_TASK_SPACE": ("string", PLANNING_METHOD_TASK_SPACE),
    "PLANNING_METHOD_WHOLE_BODY": ("string", PLANNING_METHOD_WHOLE_BODY),
}


class Obstacle(RosMessage):
    """One obstacle: ``frame_id`` is its unique id (not a TF frame); sizes in m (seed document)."""

    ros_type = "potential_fields_interfaces/msg/Obstacle"
    frame_id: String = ""
    type: String = ""
    group: String = ""
    pose: Pose = Field(default_factory=Pose)
    radius: Float32 = 0.0
    height: Float32 = 0.0
    length: Float32 = 0.0
    width: Float32 = 0.0
    semi_x: Float32 = 0.0
    semi_y: Float32 = 0.0
    semi_z: Float32 = 0.0
    mesh_resource: String = ""
    scale_x: Float32 = 0.0
    scale_y: Float32 = 0.0
    scale_z: Float32 = 0.0


class ObstacleArray(RosMessage):
    ros_type = "potential_fields_interfaces/msg/ObstacleArray"
    header: Header = Field(default_factory=Header)
    obstacles: list[Obstacle] = Field(default_factory=list)


class PlanPath_Request(RosMessage):
    """Plan from ``start`` (task space) or ``starting_joint_angles`` (whole body, rad) to ``goal``.

    ``delta_time`` in s, ``goal_tolerance`` in m, ``max_iterations`` ≤ 0 means 30000.
    """

    ros_type = "potential_fields_interfaces/srv/PlanPath_Request"
    ros_constants: ClassVar[dict[str, tuple[str, Any]]] = _PLANNING_CONSTANTS
    PLANNING_METHOD_TASK_SPACE: ClassVar[str] = PLANNING_METHOD_TASK_SPACE
    PLANNING_METHOD_WHOLE_BODY: ClassVar[str] = PLANNING_METHOD_WHOLE_BODY
    start: Pose = Field(default_factory=Pose)
    goal: Pose = Field(default_factory=Pose)
    starting_joint_angles: list[Float32] = Field(default_factory=list)
    delta_time: Float32 = 0.0
    goal_tolerance: Float32 = 0.0
    max_iterations: Int32 = 0
    planning_method: String = ""


class PlanPath_Response(RosMessage):
    ros_type = "potential_fields_interfaces/srv/PlanPath_Response"
    success: Bool = False
    end_effector_path: Path = Field(default_factory=Path)
    joint_trajectory: JointTrajectory = Field(default_factory=JointTrajectory)
    end_effector_velocity_trajectory: list[TwistStamped] = Field(default_factory=list)
    error_message: String = ""


class ComputeAutonomyVector_Request(RosMessage):
    """The field's recommended end-effector velocity at ``query_pose`` (task space) or ``joint_angles``."""

    ros_type = "potential_fields_interfaces/srv/ComputeAutonomyVector_Request"
    ros_constants: ClassVar[dict[str, tuple[str, Any]]] = _PLANNING_CONSTANTS
    PLANNING_METHOD_TASK_SPACE: ClassVar[str] = PLANNING_METHOD_TASK_SPACE
    PLANNING_METHOD_WHOLE_BODY: ClassVar[str] = PLANNING_METHOD_WHOLE_BODY
    query_pose: PoseStamped = Field(default_factory=PoseStamped)
    joint_angles: list[Float32] = Field(default_factory=list)
    prev_joint_velocities: list[Float32] = Field(default_factory=list)
    delta_time: Float32 = 0.0
    planning_method: String = ""


class ComputeAutonomyVector_Response(RosMessage):
    ros_type = "potential_fields_interfaces/srv/ComputeAutonomyVector_Response"
    autonomy_vector: TwistStamped = Field(default_factory=TwistStamped)


class FindValidPose_Request(RosMessage):
    """mbf_msgs/FindValidPose request: tolerances in m and rad."""

    ros_type = "potential_fields_interfaces/srv/FindValidPose_Request"
    ros_constants: ClassVar[dict[str, tuple[str, Any]]] = {
        "LOCAL_COSTMAP": ("uint8", 1), "GLOBAL_COSTMAP": ("uint8", 2),
    }
    LOCAL_COSTMAP: ClassVar[int] = 1
    GLOBAL_COSTMAP: ClassVar[int] = 2
    pose: PoseStamped = Field(default_factory=PoseStamped)
    safety_dist: Float32 = 0.0
    dist_tolerance: Float32 = 0.0
    angle_tolerance: Float32 = 0.0
    costmap: UInt8 = 0
    current_pose: Bool = False
    use_padded_fp: Bool = False


class FindValidPose_Response(RosMessage):
    ros_type = "potential_fields_interfaces/srv/FindValidPose_Response"
    ros_constants: ClassVar[dict[str, tuple[str, Any]]] = {
        "FREE": ("uint8", 0), "INSCRIBED": ("uint8", 1), "LETHAL": ("uint8", 2),
        "UNKNOWN": ("uint8", 3), "OUTSIDE": ("uint8", 4),
    }
    FREE: ClassVar[int] = 0
    INSCRIBED: ClassVar[int] = 1
    LETHAL: ClassVar[int] = 2
    UNKNOWN: ClassVar[int] = 3
    OUTSIDE: ClassVar[int] = 4
    state: UInt8 = 0
    cost: UInt32 = 0
    pose: PoseStamped = Field(default_factory=PoseStamped)


class RemoveObstacles_Request(RosMessage):
    """Remove the obstacles with these ids (``Obstacle.frame_id``); all or nothing."""

    ros_type = "potential_fields_interfaces/srv/RemoveObstacles_Request"
    frame_ids: list[String] = Field(default_factory=list)


class RemoveObstacles_Response(RosMessage):
    ros_type = "potential_fields_interfaces/srv/RemoveObstacles_Response"
    success: Bool = False
    message: String = ""
    remaining: list[String] = Field(default_factory=list)


ARBITRATION_LINEAR = "linear"
ARBITRATION_LINEAR_GOAL = "linear_goal"
ARBITRATION_SAFETY_ONLY = "safety_only"
ASSISTANCE_FLAGS: dict[str, int] = {
    "FLAG_IN_COLLISION": 1, "FLAG_NEAR_OBSTACLE": 2, "FLAG_AT_GOAL": 4, "FLAG_STALLED": 8,
    "FLAG_AT_JOINT_LIMIT": 16, "FLAG_NEAR_SINGULARITY": 32, "FLAG_STALE_INPUT": 64, "FLAG_NO_GOAL": 128,
    "FLAG_VELOCITY_LIMITED": 256, "FLAG_HALTED": 512,
}


class ObstacleVelocity(RosMessage):
    """The velocity (m/s, world frame) of the obstacle whose ``Obstacle.frame_id`` is ``frame_id``."""

    ros_type = "potential_fields_interfaces/msg/ObstacleVelocity"
    frame_id: String = ""
    linear: Vector3 = Field(default_factory=Vector3)


class ObstacleVelocityArray(RosMessage):
    ros_type = "potential_fields_interfaces/msg/ObstacleVelocityArray"
    header: Header = Field(default_factory=Header)
    velocities: list[ObstacleVelocity] = Field(default_factory=list)


class ComputeAssistance_Request(RosMessage):
    """ComputeAutonomyVector's fields plus the operator's ``user_command`` and the ``arbitration`` mode."""

    ros_type = "potential_fields_interfaces/srv/ComputeAssistance_Request"
    ros_constants: ClassVar[dict[str, tuple[str, Any]]] = _PLANNING_CONSTANTS | {
        "ARBITRATION_LINEAR": ("string", ARBITRATION_LINEAR),
        "ARBITRATION_LINEAR_GOAL": ("string", ARBITRATION_LINEAR_GOAL),
        "ARBITRATION_SAFETY_ONLY": ("string", ARBITRATION_SAFETY_ONLY),
    }
    PLANNING_METHOD_TASK_SPACE: ClassVar[str] = PLANNING_METHOD_TASK_SPACE
    PLANNING_METHOD_WHOLE_BODY: ClassVar[str] = PLANNING_METHOD_WHOLE_BODY
    ARBITRATION_LINEAR: ClassVar[str] = ARBITRATION_LINEAR
    ARBITRATION_LINEAR_GOAL: ClassVar[str] = ARBITRATION_LINEAR_GOAL
    ARBITRATION_SAFETY_ONLY: ClassVar[str] = ARBITRATION_SAFETY_ONLY
    query_pose: PoseStamped = Field(default_factory=PoseStamped)
    joint_angles: list[Float32] = Field(default_factory=list)
    prev_joint_velocities: list[Float32] = Field(default_factory=list)
    delta_time: Float32 = 0.0
    planning_method: String = ""
    user_command: TwistStamped = Field(default_factory=TwistStamped)
    arbitration: String = ""


class ComputeAssistance_Response(RosMessage):
    """See ``ComputeAssistance.srv`` and ``docs/assistance.md`` for every field's unit and law."""

    ros_type = "potential_fields_interfaces/srv/ComputeAssistance_Response"
    ros_constants: ClassVar[dict[str, tuple[str, Any]]] = {k: ("uint32", v) for k, v in ASSISTANCE_FLAGS.items()}
    FLAG_IN_COLLISION: ClassVar[int] = 1
    FLAG_NEAR_OBSTACLE: ClassVar[int] = 2
    FLAG_AT_GOAL: ClassVar[int] = 4
    FLAG_STALLED: ClassVar[int] = 8
    FLAG_AT_JOINT_LIMIT: ClassVar[int] = 16
    FLAG_NEAR_SINGULARITY: ClassVar[int] = 32
    FLAG_STALE_INPUT: ClassVar[int] = 64
    FLAG_NO_GOAL: ClassVar[int] = 128
    FLAG_VELOCITY_LIMITED: ClassVar[int] = 256
    FLAG_HALTED: ClassVar[int] = 512
    autonomy_vector: TwistStamped = Field(default_factory=TwistStamped)
    joint_velocities: list[Float64] = Field(default_factory=list)
    blended_command: TwistStamped = Field(default_factory=TwistStamped)
    alpha: Float64 = 0.0
    speed_scale: Float64 = 0.0
    nearest_obstacle_id: String = ""
    nearest_distance: Float64 = 0.0
    nearest_normal: Vector3 = Field(default_factory=Vector3)
    robot_point: Point = Field(default_factory=Point)
    obstacle_point: Point = Field(default_factory=Point)
    time_to_collision: Float64 = 0.0
    flags: UInt32 = 0
    message: String = ""


class ExecuteTrajectory_Request(RosMessage):
    """A joint trajectory for a ros2_control controller's FollowJointTrajectory action (``ExecuteTrajectory.srv``):
    ``controller_action`` empty means the node's ``trajectory_controller_action`` parameter; ``goal_time_tolerance``
    in s (0: the controller's default)."""

    ros_type = "potential_fields_interfaces/srv/ExecuteTrajectory_Request"
    trajectory: JointTrajectory = Field(default_factory=JointTrajectory)
    controller_action: String = ""
    goal_time_tolerance: Float64 = 0.0


class ExecuteTrajectory_Response(RosMessage):
    """``success`` when the controller reported SUCCESSFUL; ``outcome`` the goal's end (SUCCEEDED, ABORTED,
    CANCELED, REJECTED; empty when nothing ran); ``error_code`` FollowJointTrajectory's Result code."""

    ros_type = "potential_fields_interfaces/srv/ExecuteTrajectory_Response"
    success: Bool = False
    outcome: String = ""
    error_code: Int32 = 0
    error_message: String = ""
