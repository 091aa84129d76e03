"""Robots and random obstacle shapes shared by the tests that hold the compiled planners to recorded digests
(tests/planning/test_core_rrt.py, test_core_whole_body.py): the same draws give the same scenes in both; and the
MotionBenchMaker UR5 problems the planning tests reproduce (:func:`ur5_problem`)."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Sphere
from pfield.robot import RobotModel

MBM = Path(__file__).resolve().parents[2] / "shared" / "benchmarks" / "mbm"
UR5 = MBM / "ur5"
PANDA_PROBLEMS = MBM / "panda_problems_dev.tar.bz2"
needs_ur5 = pytest.mark.skipif(not (UR5 / "ur5.urdf").exists(), reason="the UR5 benchmark files are not here")
needs_panda_problems = pytest.mark.skipif(not PANDA_PROBLEMS.exists(),
                                          reason="the Panda's MotionBenchMaker problems are not here")
UR5_FOREARM_WRIST_2 = np.array([-0.395, -0.366, 1.431, 1.929, -1.037, -0.057])
"""A UR5 configuration where the meshes of forearm_link and wrist_2_link intersect (a pair the SRDF keeps)."""


@functools.cache
def robot(name: str) -> RobotModel:
    """The built-in Panda, or the MotionBenchMaker UR5 with its Robotiq gripper (skipped when absent)."""
    if name == "panda":
        return RobotModel.builtin("panda")
    if not (UR5 / "ur5.urdf").exists():
        pytest.skip("the UR5 of ../shared/benchmarks/mbm is not here")
    return RobotModel.from_urdf(UR5 / "ur5.urdf", "ee_link", {"meshes": UR5 / "meshes"}, srdf=UR5 / "ur5.srdf")


@functools.cache
def ur5_at_tool0() -> RobotModel:
    """The MotionBenchMaker UR5 with ``tool0`` as its end effector, as the MBM bench builds it (:func:`robot`'s UR5
    ends at ``ee_link``)."""
    return RobotModel.from_urdf(UR5 / "ur5.urdf", end_effector="tool0", package_paths={"meshes": UR5 / "meshes"},
                                srdf=UR5 / "ur5.srdf")


@functools.cache
def meshes() -> tuple[Mesh, ...]:
    """A watertight non-convex torus and an open half sphere (built on first use, not while pytest collects)."""
    torus = trimesh.creation.torus(major_radius=0.08, minor_radius=0.03, major_sections=16, minor_sections=8)
    ball = trimesh.creation.icosphere(subdivisions=1, radius=0.06)
    return (Mesh.from_arrays(torus.vertices, torus.faces, name="torus"),
            Mesh.from_arrays(ball.vertices, ball.faces[: len(ball.faces) // 2], name="open-cap"))


def random_shape(rng: np.random.Generator, kind: int, smallest: float) -> Any:
    """A shape of kind ``kind`` (sphere, box, capsule, cylinder, ellipsoid, mesh), sizes in [smallest, 0.12] m."""
    size = rng.uniform(smallest, 0.12, 3)
    return (Sphere(size[0]), Box(*(2.0 * size)), Capsule(size[0], 2.0 * size[1]), Cylinder(size[0], 2.0 * size[1]),
            Ellipsoid(*size), meshes()[int(rng.integers(2))])[kind]


UR5_ARM = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
           "wrist_3_joint")


PANDA_ARM = tuple(f"panda_joint{k}" for k in range(1, 8))


def random_configuration(robot: RobotModel, rng: np.random.Generator) -> np.ndarray:
    """A configuration drawn uniformly within the robot's limits, each joint within [-π, π]."""
    return rng.uniform(np.maximum(robot.lower_limits, -np.pi), np.minimum(robot.upper_limits, np.pi))


def random_three_waypoints(robot: RobotModel, rng: np.random.Generator, spread: float) -> np.ndarray:
    """(3, n): a random configuration, one ``spread``·N(0, 1) rad per joint away from it (within the limits), and
    their middle in between (the middle is where the certificate tests put their obstacles)."""
    q_a = random_configuration(robot, rng)
    q_b = np.clip(q_a + rng.normal(size=robot.n_joints) * spread, robot.lower_limits, robot.upper_limits)
    return np.array([q_a, 0.5 * (q_a + q_b), q_b])


def ur5_problem(scene: str, index: int) -> tuple[list[Any], np.ndarray, np.ndarray]:
    """Obstacles, start and goal joints (:data:`UR5_ARM`) of one problem of the UR5's MotionBenchMaker archive, read
    straight from the tarball."""
    return mbm_problem(UR5 / "ur5_problems.tar.bz2", scene, index, UR5_ARM, "base_link")


def mbm_problem(path: Path, scene: str, index: int, joints: tuple[str, ...],
                base: str) -> tuple[list[Any], np.ndarray, np.ndarray]:
    """Obstacles, start and goal joints (``joints``' order) of problem ``index`` of ``scene`` in the MotionBenchMaker
    archive at ``path`` (``base``: the robot's root frame), read straight from the tarball."""
    import tarfile

    import yaml

    from pfield.scene import WORLD_FRAMES, request_from_moveit, scene_obstacles

    frames = (*WORLD_FRAMES, base)
    with tarfile.open(path) as archive:
        def read(kind: str) -> object:
            member = archive.extractfile(f"problems/{scene}/{kind}{index:04d}.yaml")
            assert member is not None
            return yaml.safe_load(member.read())

        obstacles, request = scene_obstacles(read("scene"), frames), request_from_moveit(read("request"), frames)
    assert request.goal_joints is not None
    return (obstacles, np.array([request.start[j] for j in joints]),
            np.array([request.goal_joints[j] for j in joints]))
