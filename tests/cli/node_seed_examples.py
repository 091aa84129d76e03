# ruff: noqa: E501 - the seed's command lines are kept verbatim
"""The CLI examples of the seed document (potential_fields_interfaces README), verbatim.

Only ``ros2`` is replaced by ``pfield`` when they run; the mesh example's package is given to the server
with ``--package-path my_robot_description=tests/data/my_robot_description``.
"""

OBSTACLE_EXAMPLES = {
    "ball": '''ros2 topic pub --once /pfield/obstacles potential_fields_interfaces/msg/ObstacleArray "{
header: {frame_id: 'world'},
obstacles: [{
frame_id: 'ball', type: 'Sphere', group: 'Static',
pose: {position: {x: 0.4, y: 0.0, z: 0.1}, orientation: {w: 1.0}},
radius: 0.1
}]
}"''',
    "table": '''ros2 topic pub --once /pfield/obstacles potential_fields_interfaces/msg/ObstacleArray "{
header: {frame_id: 'world'},
obstacles: [{
frame_id: 'table', type: 'Box', group: 'Static',
pose: {position: {x: 0.66, y: 0.0, z: 0.3}, orientation: {w: 1.0}},
length: 0.15, width: 0.7, height: 0.6
}]
}"''',
    "pitcher": '''ros2 topic pub --once /pfield/obstacles potential_fields_interfaces/msg/ObstacleArray "{
header: {frame_id: 'world'},
obstacles: [{
frame_id: 'pitcher', type: 'Cylinder', group: 'Static',
pose: {position: {x: 0.51, y: 0.0, z: 0.15}, orientation: {w: 1.0}},
radius: 0.09, height: 0.3
}]
}"''',
    "ellipsoid_obs": '''ros2 topic pub --once /pfield/obstacles potential_fields_interfaces/msg/ObstacleArray "{
header: {frame_id: 'world'},
obstacles: [{
frame_id: 'ellipsoid_obs', type: 'Ellipsoid', group: 'Static',
pose: {position: {x: 0.5, y: 0.1, z: 0.2}, orientation: {w: 1.0}},
semi_x: 0.08, semi_y: 0.05, semi_z: 0.12
}]
}"''',
    "capsule_obs": '''ros2 topic pub --once /pfield/obstacles potential_fields_interfaces/msg/ObstacleArray "{
header: {frame_id: 'world'},
obstacles: [{
frame_id: 'capsule_obs', type: 'Capsule', group: 'Static',
pose: {position: {x: 0.45, y: 0.0, z: 0.2}, orientation: {w: 1.0}},
radius: 0.05, height: 0.2
}]
}"''',
    "mesh_obs": '''ros2 topic pub --once /pfield/obstacles potential_fields_interfaces/msg/ObstacleArray "{
header: {frame_id: 'world'},
obstacles: [{
frame_id: 'mesh_obs', type: 'Mesh', group: 'Static',
pose: {position: {x: 0.5, y: 0.0, z: 0.1}, orientation: {w: 1.0}},
mesh_resource: 'package://my_robot_description/meshes/obstacle.dae',
scale_x: 1.0, scale_y: 1.0, scale_z: 1.0
}]
}"''',
}

PLAN_TASK_SPACE = '''ros2 service call /pfield/plan_path potential_fields_interfaces/srv/PlanPath "{
start: {
position: {x: 0.227, y: 0.0, z: 0.294},
orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}
},
goal: {
position: {x: 0.5, y: 0.2, z: 0.4},
orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}
},
delta_time: 0.02,
goal_tolerance: 0.01,
max_iterations: 25000,
planning_method: 'task_space'
}"'''

PLAN_WHOLE_BODY = '''ros2 service call /pfield/plan_path potential_fields_interfaces/srv/PlanPath "{
goal: {
position: {x: 0.5, y: 0.2, z: 0.4},
orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}
},
starting_joint_angles: [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0],
delta_time: 0.02,
goal_tolerance: 0.01,
max_iterations: 25000,
planning_method: 'whole_body'
}"'''

AUTONOMY_TASK_SPACE = '''ros2 service call /pfield/compute_autonomy_vector potential_fields_interfaces/srv/ComputeAutonomyVector "{
query_pose: {
header: {frame_id: 'world'},
pose: {
position: {x: 0.3, y: 0.1, z: 0.35},
orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}
}
},
delta_time: 0.02,
planning_method: 'task_space'
}"'''

AUTONOMY_WHOLE_BODY = '''ros2 service call /pfield/compute_autonomy_vector potential_fields_interfaces/srv/ComputeAutonomyVector "{
query_pose: {
header: {frame_id: 'world'},
pose: {
position: {x: 0.3, y: 0.1, z: 0.35},
orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}
}
},
joint_angles: [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0],
prev_joint_velocities: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
delta_time: 0.02,
planning_method: 'whole_body'
}"'''

GOAL = (0.5, 0.2, 0.4)
GOAL_TOLERANCE = 0.01
QUERY = (0.3, 0.1, 0.35)
SEED_JOINTS_END_EFFECTOR = (0.227, 0.0, 0.294)
"""FK of the seed's joint angles (xArm7), the seed's task-space start: whole-body vectors are evaluated there."""
