"""pfield values of what the viewer shows: a node's messages and plan CSV files.

Obstacles of a live node: the ``/pfield/markers`` array says which obstacles exist and where (one marker
per obstacle in namespace ``obstacles``, its ``text`` the id, its pose already in the fixed frame); the
``/pfield/obstacles`` messages seen give each one's exact shape (a capsule's marker is its bounding
cylinder). An obstacle known only from its marker is drawn from the marker (sphere, ellipsoid, box,
cylinder or mesh) in group ``Static``.
"""

from __future__ import annotations

import csv
import logging
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.errors import InvalidInput, PfieldError
from pfield.planning.result import PlannedPath
from pfield.spatial import Pose

__all__ = ["ObstacleTracker", "path_arrays", "pose_of", "read_plan_csv"]

_log = logging.getLogger(__name__)
_SPHERE, _CUBE, _CYLINDER, _MESH = 2, 1, 3, 10  # visualization_msgs/Marker types


def pose_of(data: Mapping[str, Any]) -> Pose:
    """A Pose of a geometry_msgs/Pose as decoded JSON."""
    p, q = data.get("position", {}), data.get("orientation", {})
    return Pose((p.get("x", 0.0), p.get("y", 0.0), p.get("z", 0.0)),
                (q.get("x", 0.0), q.get("y", 0.0), q.get("z", 0.0), q.get("w", 1.0)))


def path_arrays(path: Mapping[str, Any]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions (N, 3) and orientations (N, 4) of a nav_msgs/Path as decoded JSON."""
    poses = [pose_of(item.get("pose", {})) for item in path.get("poses", [])]
    if not poses:
        return np.zeros((0, 3)), np.zeros((0, 4))
    return np.array([p.position for p in poses]), np.array([p.orientation for p in poses])


class ObstacleTracker:
    """The obstacles a node holds, from its obstacle messages and markers (see the module docstring).

    ``resolver``: the :class:`~pfield.geometry.ResourceResolver` mesh URIs are read through.
    """

    def __init__(self, resolver: Any) -> None:
        self.resolver = resolver
        self._shapes: dict[str, tuple[Any, str]] = {}
        """id → (shape, group) of every obstacle message seen."""
        self._failed: set[str] = set()

    def _mesh(self, resource: str, sx: float, sy: float, sz: float) -> Any:
        from pfield.geometry import Mesh

        return Mesh(resource, sx, sy, sz, resolver=self.resolver)

    def add_message(self, data: Mapping[str, Any]) -> None:
        """Remember the shapes of an ObstacleArray message (decoded JSON); bad entries are skipped."""
        from pfield.interfaces import potential_fields_interfaces as pfi
        from pfield.interfaces.convert import obstacle_from_msg

        for item in data.get("obstacles", []):
            try:
                message = pfi.Obstacle.model_validate(item)
                obstacle = obstacle_from_msg(message, self._mesh)
                self._shapes[message.frame_id] = (obstacle.shape, obstacle.group)
            except (PfieldError, ValueError, OSError) as exc:
                _log.warning("obstacle %s not shown: %s", item.get("frame_id"), exc)

    def _shape_of_marker(self, marker: Mapping[str, Any]) -> Any:
        from pfield.geometry import Box, Cylinder, Ellipsoid, Sphere

        s = marker.get("scale", {})
        sx, sy, sz = s.get("x", 0.0), s.get("y", 0.0), s.get("z", 0.0)
        kind = marker.get("type")
        if kind == _SPHERE:
            return Sphere(sx / 2) if sx == sy == sz else Ellipsoid(sx / 2, sy / 2, sz / 2)
        if kind == _CUBE:
            return Box(sx, sy, sz)
        if kind == _CYLINDER:
            return Cylinder(sx / 2, sz)
        if kind == _MESH:
            return self._mesh(marker.get("mesh_resource", ""), sx, sy, sz)
        raise InvalidInput("marker.type", kind, "not an obstacle marker")

    def from_markers(self, markers: Mapping[str, Any]) -> tuple[list[Any], Pose | None]:
        """The obstacles (in marker order) and the goal of a MarkerArray (decoded JSON)."""
        from pfield.geometry import Obstacle

        obstacles, goal = [], None
        for marker in markers.get("markers", []):
            ns = marker.get("ns")
            if ns == "goal":
                goal = pose_of(marker.get("pose", {}))
            if ns != "obstacles":
                continue
            key = str(marker.get("text", ""))
            try:
                shape, group = self._shapes.get(key) or (self._shape_of_marker(marker), "Static")
                obstacles.append(Obstacle(key, shape, pose_of(marker.get("pose", {})), group=group))
            except (PfieldError, ValueError, OSError) as exc:
                if key not in self._failed:
                    _log.warning("obstacle %s not shown: %s", key, exc)
                    self._failed.add(key)
        return obstacles, goal


def read_plan_csv(path: str | Path) -> PlannedPath:
    """A :class:`PlannedPath` of a CSV file written by :meth:`PlannedPath.to_csv` (any planner).

    The file carries no status: the plan is read as successful. Raises :class:`InvalidInput` naming the
    file and the column or row that is wrong.
    """
    source = Path(path)
    try:
        with source.open(newline="") as handle:
            rows = list(csv.reader(handle))
    except OSError as exc:
        raise InvalidInput("plan", str(source), f"cannot read: {exc}") from None
    if len(rows) < 2:
        raise InvalidInput("plan", str(source), "expected a header row and at least one waypoint")
    header = rows[0]
    base = ["time", "x", "y", "z", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "wx", "wy", "wz", "clearance"]
    if header[:len(base)] != base:
        raise InvalidInput("plan", str(source), f"the first columns must be {', '.join(base)}")
    try:
        table = np.array([[float(v) for v in row] for row in rows[1:]], dtype=np.float64)
    except ValueError as exc:
        raise InvalidInput("plan", str(source), f"not a number: {exc}") from None
    if table.ndim != 2 or table.shape[1] != len(header):
        raise InvalidInput("plan", str(source), f"every row must have {len(header)} values")
    names = tuple(h[len("position_"):] for h in header if h.startswith("position_"))
    n = len(names)
    joints = table[:, 15:15 + n] if n else None
    velocities = table[:, 15 + n:15 + 2 * n] if n and table.shape[1] >= 15 + 2 * n else None
    return PlannedPath(success=True, failure_reason="", times=table[:, 0], positions=table[:, 1:4],
                       orientations=table[:, 4:8], twists=table[:, 8:14], clearances=table[:, 14],
                       iterations=len(table) - 1, joint_names=names, joint_positions=joints,
                       joint_velocities=velocities)
