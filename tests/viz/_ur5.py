"""The UR5 with its Robotiq gripper (../shared/benchmarks/mbm/ur5) for the viewer's tests: the robot loaded with
its package paths, a MotionBenchMaker table scene and a joint-space plan, and a camera projection.

The URDF stands the arm's ``base_link`` on a fixed ``offset_link`` 0.9144 m above the origin (the MBM problems'
table height); the meshes are named ``package://meshes/…`` (a package called ``meshes``) and by paths relative to
the URDF's folder.
"""

from __future__ import annotations

import math
import tarfile
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

UR5 = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "mbm" / "ur5"
BASE_HEIGHT = 0.9144
"""m: the height of the UR5's base_link in its URDF."""
START = (1.57, -1.5707, 0.0, -1.5707, -1.57, 3.14)
"""table_pick_ur5 request0001's start: the arm pointing straight up (its wrist 1.92 m above the floor)."""
GOAL = (1.438775553350176, -0.6875404909857841, 1.43409606187095, -0.7445397051423589, 1.589182367635896,
        -3.14159265)
"""table_pick_ur5 request0001's joint goal: the gripper down over the table."""


def load_ur5(packages: dict[str, Any] | None = None, urdf: Path | None = None) -> Any:
    from pfield.robot import RobotModel

    return RobotModel.from_urdf(urdf or UR5 / "ur5.urdf", "ee_link",
                                packages if packages is not None else {"meshes": UR5 / "meshes"},
                                srdf=UR5 / "ur5.srdf")


def table_scene() -> list[Any]:
    """The obstacles of table_pick_ur5/scene0001 (a table top at 0.79 m with cans and boxes on it)."""
    from pfield.scene.moveit import scene_obstacles

    with tarfile.open(UR5 / "ur5_problems.tar.bz2") as archive:
        member = archive.extractfile("problems/table_pick_ur5/scene0001.yaml")
        assert member is not None
        return scene_obstacles(yaml.safe_load(member.read()))


def joint_plan(robot: Any, start: tuple[float, ...] = START, goal: tuple[float, ...] = GOAL, steps: int = 40) -> Any:
    """A whole-body PlannedPath moving the joints linearly from ``start`` to ``goal`` in 2 s."""
    from pfield.planning.result import PlannedPath

    s = np.linspace(0.0, 1.0, steps)[:, None]
    joints = (1 - s) * np.asarray(start) + s * np.asarray(goal)
    poses = [robot.forward_kinematics(q) for q in joints]
    times = 2.0 * s[:, 0]
    velocities = np.gradient(joints, times, axis=0)
    return PlannedPath(success=True, failure_reason="", times=times, positions=[p.position for p in poses],
                       orientations=[p.orientation for p in poses], twists=np.zeros((steps, 6)),
                       clearances=np.full(steps, 0.1), iterations=steps - 1, joint_names=robot.joint_names,
                       joint_positions=joints, joint_velocities=velocities)


def skeleton_box(robot: Any, q: Any, pedestal: float | None = BASE_HEIGHT) -> NDArray[np.float64]:
    """(8, 3) corners of the box around the robot's skeleton at ``q`` by pfield's own kinematics: the root's
    origin, the base on its ``pedestal`` (m; None: none), every joint and the end effector (not the viewer's
    meshes)."""
    _, origins = robot.joint_frames(q)
    base = [[0.0, 0.0, pedestal]] if pedestal is not None else []
    points = np.vstack([[[0.0, 0.0, 0.0]], *([base] if base else []), origins,
                        [robot.forward_kinematics(q).position]])
    lower, upper = points.min(axis=0), points.max(axis=0)
    return np.array([[x, y, z] for x in (lower[0], upper[0]) for y in (lower[1], upper[1])
                     for z in (lower[2], upper[2])])


def look_at_camera(position: Any, look_at: Any) -> NDArray[np.float64]:
    """World-from-camera rotation (OpenCV axes: x right, y down, z forward) of a camera at ``position``
    looking at ``look_at`` with +z up, as viser places its initial camera."""
    forward = np.asarray(look_at, dtype=float) - np.asarray(position, dtype=float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    return np.column_stack([right, down, forward])


def project(position: Any, rotation: NDArray[np.float64], fov: float, point: Any, width: int, height: int
            ) -> tuple[float, float] | None:
    """Pixel (column, row) of a world point for a pinhole camera with vertical field of view ``fov`` (rad);
    None behind the camera."""
    local = rotation.T @ (np.asarray(point, dtype=float) - np.asarray(position, dtype=float))
    if local[2] <= 0:
        return None
    focal = (height / 2) / math.tan(fov / 2)
    return width / 2 + focal * local[0] / local[2], height / 2 + focal * local[1] / local[2]
