"""The CLI examples of the seed document (potential_fields_interfaces README), verbatim: the one source of
the seed's obstacle messages and requests for every test (CLI and ROS 2).

``OBSTACLES`` and the request constants are the YAML flow arguments as the seed writes them; the ``*_COMMAND``
forms are the seed's whole ``ros2 ...`` command lines around them. The CLI tests run those with ``ros2``
replaced by ``pfield``; the mesh example's package is given to the node with ``--package-path
my_robot_description=tests/data/my_robot_description``. The ROS 2 helper scripts import this module as a
plain file (``tests/`` on ``sys.path``), so it needs nothing but PyYAML.
"""

from __future__ import annotations

from typing import Any

import yaml


def _obstacle_array(obstacle: str) -> str:
    """The seed's one-obstacle ``ObstacleArray`` message (frame ``world``) around ``obstacle``'s lines."""
    return "{\nheader: {frame_id: 'world'},\nobstacles: [{\n" + obstacle + "\n}]\n}"


OBSTACLES = {
    "ball": _obstacle_array("""frame_id: 'ball', type: 'Sphere', group: 'Static',
pose: {position: {x: 0.4, y: 0.0, z: 0.1}, orientation: {w: 1.0}},
radius: 0.1"""),
    "table": _obstacle_array("""frame_id: 'table', type: 'Box', group: 'Static',
pose: {position: {x: 0.66, y: 0.0, z: 0.3}, orientation: {w: 1.0}},
length: 0.15, width: 0.7, height: 0.6"""),
    "pitcher": _obstacle_array("""frame_id: 'pitcher', type: 'Cylinder', group: 'Static',
pose: {position: {x: 0.51, y: 0.0, z: 0.15}, orientation: {w: 1.0}},
radius: 0.09, height: 0.3"""),
    "ellipsoid_obs": _obstacle_array("""frame_id: 'ellipsoid_obs', type: 'Ellipsoid', group: 'Static',
pose: {position: {x: 0.5, y: 0.1, z: 0.2}, orientation: {w: 1.0}},
semi_x: 0.08, semi_y: 0.05, semi_z: 0.12"""),
    "capsule_obs": _obstacle_array("""frame_id: 'capsule_obs', type: 'Capsule', group: 'Static',
pose: {position: {x: 0.45, y: 0.0, z: 0.2}, orientation: {w: 1.0}},
radius: 0.05, height: 0.2"""),
    "mesh_obs": _obstacle_array("""frame_id: 'mesh_obs', type: 'Mesh', group: 'Static',
pose: {position: {x: 0.5, y: 0.0, z: 0.1}, orientation: {w: 1.0}},
mesh_resource: 'package://my_robot_description/meshes/obstacle.dae',
scale_x: 1.0, scale_y: 1.0, scale_z: 1.0"""),
}

_ORIENTATION = "orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}"
"""The seed's end-effector orientation (tool pointing down), the same in every request."""
_GOAL = f"""goal: {{
position: {{x: 0.5, y: 0.2, z: 0.4}},
{_ORIENTATION}
}},"""
_PLAN_SETTINGS = """delta_time: 0.02,
goal_tolerance: 0.01,
max_iterations: 25000,"""
_QUERY_POSE = f"""query_pose: {{
header: {{frame_id: 'world'}},
pose: {{
position: {{x: 0.3, y: 0.1, z: 0.35}},
{_ORIENTATION}
}}
}},"""

PLAN_TASK_SPACE = f"""{{
start: {{
position: {{x: 0.227, y: 0.0, z: 0.294}},
{_ORIENTATION}
}},
{_GOAL}
{_PLAN_SETTINGS}
planning_method: 'task_space'
}}"""

PLAN_WHOLE_BODY = f"""{{
{_GOAL}
starting_joint_angles: [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0],
{_PLAN_SETTINGS}
planning_method: 'whole_body'
}}"""

AUTONOMY_TASK_SPACE = f"""{{
{_QUERY_POSE}
delta_time: 0.02,
planning_method: 'task_space'
}}"""

AUTONOMY_WHOLE_BODY = f"""{{
{_QUERY_POSE}
joint_angles: [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0],
prev_joint_velocities: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
delta_time: 0.02,
planning_method: 'whole_body'
}}"""

_PUBLISH_OBSTACLES = "ros2 topic pub --once /pfield/obstacles potential_fields_interfaces/msg/ObstacleArray"
_CALL_PLAN = "ros2 service call /pfield/plan_path potential_fields_interfaces/srv/PlanPath"
_CALL_AUTONOMY = ("ros2 service call /pfield/compute_autonomy_vector "
                  "potential_fields_interfaces/srv/ComputeAutonomyVector")

OBSTACLE_COMMANDS = {name: f'{_PUBLISH_OBSTACLES} "{text}"' for name, text in OBSTACLES.items()}
"""The seed's six ``ros2 topic pub --once /pfield/obstacles ...`` command lines, by obstacle id."""
PLAN_TASK_SPACE_COMMAND = f'{_CALL_PLAN} "{PLAN_TASK_SPACE}"'
PLAN_WHOLE_BODY_COMMAND = f'{_CALL_PLAN} "{PLAN_WHOLE_BODY}"'
AUTONOMY_TASK_SPACE_COMMAND = f'{_CALL_AUTONOMY} "{AUTONOMY_TASK_SPACE}"'
AUTONOMY_WHOLE_BODY_COMMAND = f'{_CALL_AUTONOMY} "{AUTONOMY_WHOLE_BODY}"'

GOAL = (0.5, 0.2, 0.4)
"""m, world frame: the goal position of the seed's plan requests."""
GOAL_TOLERANCE = 0.01
"""m: the seed's plan ``goal_tolerance``."""
QUERY = (0.3, 0.1, 0.35)
"""m, world frame: the query position of the seed's autonomy requests."""
SEED_JOINTS_END_EFFECTOR = (0.227, 0.0, 0.294)
"""m, world frame: FK of the seed's joint angles on the xArm7, the seed's task-space start (whole-body
vectors are evaluated there)."""


def parse(text: str) -> dict[str, Any]:
    """A YAML flow argument as ``ros2`` reads it (``yaml.safe_load``)."""
    data = yaml.safe_load(text)
    assert isinstance(data, dict)
    return data
