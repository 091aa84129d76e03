"""Built-in scenes: the seed's six obstacles and task-space example, and the REFERENCE benchmark scenes.

* :func:`seed_obstacles` — the obstacles of the seed's CLI examples (table, pitcher, ball, ellipsoid,
  capsule and a mesh), and :data:`SEED_START` / :data:`SEED_GOAL` / :data:`SEED_PLAN` its task-space
  planning example (``/pfield/plan_path`` with ``planning_method: task_space``).
* :func:`evaluation_scene` — the field-evaluation scenes of the benchmark reference (REFERENCE.md §2):
  obstacles on a Fibonacci sphere of radius 0.30 m about (0.45, 0.15, 0.40).
* :func:`sphere_line_scene` — the task-space planning scenes: K spheres (r 0.02 m) spread along the
  start–goal line with a lateral offset.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, ResourceResolver, Shape, Sphere
from pfield.spatial import Pose, quaternion_exp

__all__ = [
    "BENCH_GOAL",
    "BENCH_START",
    "DEFAULT_PARAMS",
    "EVALUATION_SCENES",
    "SEED_GOAL",
    "SEED_PLAN",
    "SEED_START",
    "evaluation_query",
    "evaluation_scene",
    "seed_obstacles",
    "sphere_line_scene",
    "write_seed_mesh",
]

_TOOL_FORWARD = (0.707, 0.0, 0.707, 0.0)
SEED_START = Pose((0.227, 0.0, 0.294), _TOOL_FORWARD)
SEED_GOAL = Pose((0.5, 0.2, 0.4), _TOOL_FORWARD)
SEED_PLAN: dict[str, Any] = {"dt": 0.02, "goal_tolerance": 0.01, "max_iterations": 25000}
"""delta_time, goal_tolerance and max_iterations of the seed's task-space PlanPath example."""

BENCH_START = Pose((0.3, 0.0, 0.5))
BENCH_GOAL = Pose((0.6, 0.3, 0.3))
DEFAULT_PARAMS = FieldConfig(
    attractive_gain=1.0, rotational_attractive_gain=0.7, repulsive_gain=0.22, influence_distance=1.0,
    max_linear_velocity=5.0, max_angular_velocity=1.0, max_linear_acceleration=1.0, max_angular_acceleration=1.0,
)
"""The C++ library's defaults ("default" in REFERENCE.md §1); :class:`FieldConfig` () is "rosYaml"."""

_GOLDEN_ANGLE = 2.399963229728653
EVALUATION_SCENES = ("empty", "spheres_1", "spheres_10", "spheres_100", "boxes_10", "cylinders_10",
                     "ellipsoids_10", "capsules_10")


def write_seed_mesh(directory: Path) -> Path:
    """Write the built-in mesh obstacle (an icosphere of radius 6 cm, 80 triangles) as STL; return its path."""
    import trimesh

    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "seed_obstacle.stl"
    trimesh.creation.icosphere(subdivisions=1, radius=0.06).export(path)
    return path


def seed_obstacles(mesh_directory: Path) -> list[Obstacle]:
    """The six obstacles of the seed's examples; the mesh is written to and loaded from ``mesh_directory``.

    The seed's mesh example points at ``package://my_robot_description/meshes/obstacle.dae``, which is not
    shipped; a small icosphere written by :func:`write_seed_mesh` stands in for it (through a
    ``package://`` URI resolved to ``mesh_directory``).
    """
    path = write_seed_mesh(mesh_directory)
    resolver = ResourceResolver(package_paths={"pfield_demo": path.parent})
    mesh = Mesh(f"package://pfield_demo/{path.name}", resolver=resolver)
    return [
        Obstacle("ball", Sphere(radius=0.1), Pose((0.4, 0.0, 0.1))),
        Obstacle("table", Box(length=0.15, width=0.7, height=0.6), Pose((0.66, 0.0, 0.3))),
        Obstacle("pitcher", Cylinder(radius=0.09, height=0.3), Pose((0.51, 0.0, 0.15))),
        Obstacle("ellipsoid_obs", Ellipsoid(semi_x=0.08, semi_y=0.05, semi_z=0.12), Pose((0.5, 0.1, 0.2))),
        Obstacle("capsule_obs", Capsule(radius=0.05, height=0.2), Pose((0.45, 0.0, 0.2))),
        Obstacle("mesh_obs", mesh, Pose((0.5, 0.0, 0.1))),
    ]


def _about(axis: int, angle: float) -> Pose:
    rotvec = np.zeros(3)
    rotvec[axis] = angle
    return Pose(orientation=quaternion_exp(rotvec))


def evaluation_query() -> Pose:
    """The field-evaluation query pose: (0.3, 0, 0.5), rotated 0.3 rad about +z."""
    return Pose((0.3, 0.0, 0.5), _about(2, 0.3).orientation)


def _fibonacci_centres(count: int) -> np.ndarray:
    centre = np.array([0.45, 0.15, 0.40])
    index = np.arange(count)
    z = 1.0 - (2.0 * index + 1.0) / count
    rho = np.sqrt(1.0 - z * z)
    theta = index * _GOLDEN_ANGLE
    return centre + 0.30 * np.stack([rho * np.cos(theta), rho * np.sin(theta), z], axis=1)


def evaluation_scene(name: str) -> list[Obstacle]:
    """Obstacles of a REFERENCE §2 field-evaluation scene (``EVALUATION_SCENES``; meshes not included)."""
    if name == "empty":
        return []
    kind, _, count_text = name.partition("_")
    if kind not in ("spheres", "boxes", "cylinders", "ellipsoids", "capsules") or not count_text.isdigit():
        raise InvalidInput("scene", name, f"unknown scene; expected one of {EVALUATION_SCENES}")
    obstacles = []
    shape: Shape
    for i, centre in enumerate(_fibonacci_centres(int(count_text))):
        if kind == "spheres":
            shape, turn = Sphere(0.03), Pose()
        elif kind == "boxes":
            shape, turn = Box(0.06, 0.04, 0.08), _about(2, 0.1 * i)
        elif kind == "cylinders":
            shape, turn = Cylinder(0.03, 0.10), _about(0, 0.1 * i)
        elif kind == "ellipsoids":
            shape, turn = Ellipsoid(0.03, 0.04, 0.05), _about(1, 0.1 * i)
        else:
            shape, turn = Capsule(0.02, 0.08), _about(0, 0.1 * i)
        obstacles.append(Obstacle(f"{kind}_{i}", shape, Pose(centre, turn.orientation)))
    return obstacles


def sphere_line_scene(count: int, lateral_offset: float = 0.05, radius: float = 0.02) -> list[Obstacle]:
    """K spheres along the benchmark start–goal line (REFERENCE §2, task-space planning scenes).

    centre_k = S + ((k+1)/(K+1)) d + offset (cos(kγ) u1 + sin(kγ) u2), d = G − S,
    u1 = normalize(d × ẑ), u2 = normalize(d) × u1, γ the golden angle.
    """
    start, goal = BENCH_START.position, BENCH_GOAL.position
    d = goal - start
    u1 = np.cross(d, (0.0, 0.0, 1.0))
    u1 /= np.linalg.norm(u1)
    u2 = np.cross(d / np.linalg.norm(d), u1)
    obstacles = []
    for k in range(count):
        centre = start + ((k + 1) / (count + 1)) * d + lateral_offset * (
            math.cos(k * _GOLDEN_ANGLE) * u1 + math.sin(k * _GOLDEN_ANGLE) * u2)
        obstacles.append(Obstacle(f"sphere_{k}", Sphere(radius), Pose(centre)))
    return obstacles
