"""The manager's calls into the library (field, planners, meshes), kept in one place.

Task-space plans come from :meth:`PotentialField.plan`; when the request also gives joint angles, the
joint trajectory is attached by IK along the path (:func:`pfield.planning.joint_trajectory.
attach_joint_trajectory`). Whole-body plans come from :meth:`PotentialField.plan_whole_body` with the
start pose implied by the joint angles (the request's ``start`` is ignored, as the seed says).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.planning.cancel import CancelToken
from pfield.planning.options import DEFAULT_GLOBAL_TIME_LIMIT
from pfield.planning.result import PlannedPath
from pfield.spatial import Pose, Twist

__all__ = ["PlanInputs", "make_field", "make_mesh", "make_resolver", "run_plan", "whole_body_twist"]


@dataclass(frozen=True)
class PlanInputs:
    """A validated PlanPath request (dt in s, tolerance in m)."""

    method: str
    goal: Pose
    start: Pose | None
    joint_angles: NDArray[np.float64] | None
    delta_time: float
    goal_tolerance: float
    max_iterations: int


def make_field(config: FieldConfig, goal: Pose, obstacles: Sequence[Any]) -> Any:
    from pfield.field import PotentialField

    return PotentialField(config, goal=goal, obstacles=list(obstacles))


def make_mesh(resource: str, scale: tuple[float, float, float], resolver: Any, max_bytes: int) -> Any:
    """A Mesh shape of ``resource`` resolved through ``resolver`` (a :class:`~pfield.geometry.ResourceResolver`);
    a resolved file over ``max_bytes`` is refused before it is read.

    The node's clients are not trusted: without a resolver only files under the current directory are read
    (the library's own default resolver would read any file)."""
    from pfield.geometry import Mesh, ResourceResolver

    if resolver is None:
        resolver = ResourceResolver(allowed_roots=(Path.cwd(),))
    size = resolver.resolve(resource).stat().st_size
    if size > max_bytes:
        raise InvalidInput("mesh_resource", resource, f"the file has {size} bytes, above max_mesh_file_size "
                           f"({max_bytes} bytes)")
    return Mesh(resource, *scale, resolver=resolver)


def run_plan(config: FieldConfig, obstacles: Sequence[Any], robot: Any, inputs: PlanInputs,
             cancel: CancelToken | None = None, *, global_fallback: bool = True,
             global_time_limit: float = DEFAULT_GLOBAL_TIME_LIMIT) -> PlannedPath:
    """The plan of ``inputs`` among ``obstacles``; ``cancel`` (checked here before planning, and passed to the
    planner, which checks it between iterations) ends it early with the status ``cancelled``.

    ``global_fallback`` and ``global_time_limit`` are the :class:`~pfield.planning.PlanOptions` fields of
    those names (the node's parameters). Joint trajectories are time-parameterised within the URDF velocity
    limits and the config's acceleration limits (revolute: ``max_angular_acceleration``, prismatic:
    ``max_linear_acceleration``)."""
    from pfield.planning import PlanOptions
    field = make_field(config, inputs.goal, obstacles)
    options = PlanOptions(dt=inputs.delta_time, goal_tolerance=inputs.goal_tolerance,
                          max_iterations=inputs.max_iterations, cancel=cancel, global_fallback=global_fallback,
                          global_time_limit=global_time_limit)
    if inputs.method == "whole_body":
        assert inputs.joint_angles is not None
        return field.plan_whole_body(robot, inputs.joint_angles, options=options)
    assert inputs.start is not None
    path: PlannedPath = field.plan(start=inputs.start, options=options)
    if inputs.joint_angles is not None:
        from pfield.planning.joint_trajectory import attach_joint_trajectory

        path = attach_joint_trajectory(path, robot, inputs.joint_angles)  # the robot's acceleration limits
    return path


def whole_body_twist(field: Any, robot: Any, q: NDArray[np.float64], qd: NDArray[np.float64] | None,
                     dt: float, query_pose: Pose | None = None) -> Twist:
    """End-effector twist of the whole-body autonomy vector at joint angles ``q`` (world frame).

    A ``query_pose`` that disagrees with FK(q) is logged; the joint angles stay the truth."""
    from pfield.shared_control.autonomy import whole_body_autonomy_vector

    return whole_body_autonomy_vector(field, robot, q, prev_joint_velocities=qd, dt=dt, query_pose=query_pose)


def make_resolver(package_paths: Mapping[str, Path], mesh_roots: Sequence[Path]) -> Any:
    """The node's :class:`~pfield.geometry.ResourceResolver`: ``package://`` through ``package_paths``;
    files only inside ``mesh_roots`` or a package directory."""
    from pfield.geometry import ResourceResolver

    allowed = [*mesh_roots, *package_paths.values()]
    return ResourceResolver(package_paths=dict(package_paths), allowed_roots=allowed)
