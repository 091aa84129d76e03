"""Problems in: MoveIt PlanningScene / MotionPlanRequest YAML and pfield's own scene files.

* :mod:`pfield.scene.moveit` — :func:`scene_obstacles` (PlanningScene → obstacles) and
  :func:`request_from_moveit` (MotionPlanRequest → start state and joint or pose goal);
* :mod:`pfield.scene.files` — :func:`load_scene`, pfield's scene YAML (``pfield plan --scene``);
* :mod:`pfield.scene.problems` — :class:`Problem` (one plan to make) and :func:`read_problems` (scene
  files, MotionBenchMaker folders and archives).
"""

from pfield.scene.files import load_scene
from pfield.scene.moveit import WORLD_FRAMES, MotionRequest, pose_from_moveit, request_from_moveit, scene_obstacles
from pfield.scene.problems import (
    MBM_CONFIG,
    MBM_JOINT_STEP,
    MBM_OPTIONS,
    MBM_STEP_RANGE,
    Problem,
    RobotSpec,
    mbm_options,
    read_moveit_problem,
    read_problems,
    scene_folders,
)

__all__ = ["MBM_CONFIG", "MBM_JOINT_STEP", "MBM_OPTIONS", "MBM_STEP_RANGE", "WORLD_FRAMES", "MotionRequest", "Problem",
           "RobotSpec", "load_scene", "mbm_options", "pose_from_moveit", "read_moveit_problem", "read_problems",
           "request_from_moveit", "scene_folders", "scene_obstacles"]
