"""RViz-style markers of the manager's state: goal, obstacles, influence zones and the last path.

Namespaces: ``goal`` (an arrow along the goal's x axis), ``obstacles`` (one marker per obstacle, coloured
by group), ``influence`` (each primitive grown by the influence distance Q, a mesh's bounding sphere grown
by Q; translucent: where repulsion acts), ``path`` (a line strip, thinned to :data:`MAX_PATH_POINTS`).
The array starts with a DELETEALL marker so a display drops stale ones.
RViz marker conventions: SPHERE/CUBE/CYLINDER ``scale`` are full extents (m); CYLINDER is along local z.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.interfaces.convert import pose_to_msg
from pfield.interfaces.geometry_msgs import Point, Vector3
from pfield.interfaces.std_msgs import ColorRGBA, Header
from pfield.interfaces.visualization_msgs import Marker, MarkerArray
from pfield.spatial import Pose

__all__ = ["state_markers"]

MAX_PATH_POINTS = 1000
"""The path strip shows at most this many points (every k-th waypoint and the last one)."""
_GROUP_COLOURS = {"Static": (0.55, 0.55, 0.6), "Dynamic": (1.0, 0.55, 0.1), "Robot": (0.2, 0.45, 0.9)}


def _colour(rgb: Sequence[float], alpha: float) -> ColorRGBA:
    return ColorRGBA(r=rgb[0], g=rgb[1], b=rgb[2], a=alpha)


def _shape_marker(shape: Any, grow: float) -> tuple[int, tuple[float, float, float]] | None:
    """(marker type, full-extent scale) of a primitive grown by ``grow`` m on every side; None for meshes."""
    kind = type(shape).__name__
    if kind == "Sphere":
        d = 2.0 * (shape.radius + grow)
        return Marker.SPHERE, (d, d, d)
    if kind == "Box":
        return Marker.CUBE, (shape.length + 2 * grow, shape.width + 2 * grow, shape.height + 2 * grow)
    if kind == "Cylinder":
        d = 2.0 * (shape.radius + grow)
        return Marker.CYLINDER, (d, d, shape.height + 2 * grow)
    if kind == "Ellipsoid":
        return Marker.SPHERE, (2 * (shape.semi_x + grow), 2 * (shape.semi_y + grow), 2 * (shape.semi_z + grow))
    if kind == "Capsule":  # drawn as its bounding cylinder (shaft plus both caps)
        d = 2.0 * (shape.radius + grow)
        return Marker.CYLINDER, (d, d, shape.height + d)
    if kind == "Mesh":
        return None
    raise TypeError(f"no RViz marker for obstacle shape {kind}")


def _obstacle_markers(obstacles: Sequence[Any], header: Header, influence_distance: float) -> list[Marker]:
    markers = []
    for index, obstacle in enumerate(obstacles):
        rgb = _GROUP_COLOURS.get(obstacle.group, (0.5, 0.5, 0.5))
        pose = pose_to_msg(obstacle.pose)
        primitive = _shape_marker(obstacle.shape, 0.0)
        if primitive is None:  # a mesh: drawn as itself, its influence zone as its bounding sphere grown by Q
            shape = obstacle.shape
            markers.append(Marker(header=header, ns="obstacles", id=index, type=Marker.MESH_RESOURCE, pose=pose,
                                  scale=Vector3(x=shape.scale_x, y=shape.scale_y, z=shape.scale_z),
                                  color=_colour(rgb, 0.9), mesh_resource=str(shape.mesh_resource), text=obstacle.id))
            d = 2.0 * (obstacle.bounding_radius() + influence_distance)
            markers.append(Marker(header=header, ns="influence", id=index, type=Marker.SPHERE, pose=pose,
                                  scale=Vector3(x=d, y=d, z=d), color=_colour(rgb, 0.15)))
            continue
        kind, scale = primitive
        markers.append(Marker(header=header, ns="obstacles", id=index, type=kind, pose=pose,
                              scale=Vector3(x=scale[0], y=scale[1], z=scale[2]), color=_colour(rgb, 0.9),
                              text=obstacle.id))
        kind, scale = _shape_marker(obstacle.shape, influence_distance) or (kind, scale)
        markers.append(Marker(header=header, ns="influence", id=index, type=kind, pose=pose,
                              scale=Vector3(x=scale[0], y=scale[1], z=scale[2]), color=_colour(rgb, 0.15)))
    return markers


def state_markers(frame_id: str, goal: Pose | None, obstacles: Sequence[Any], influence_distance: float,
                  path_positions: NDArray[np.float64] | None = None) -> MarkerArray:
    """The marker array of the node's state (see the module docstring)."""
    header = Header(frame_id=frame_id)
    markers = [Marker(header=header, action=Marker.DELETEALL)]
    if goal is not None:
        markers.append(Marker(header=header, ns="goal", type=Marker.ARROW, pose=pose_to_msg(goal),
                              scale=Vector3(x=0.1, y=0.01, z=0.01), color=ColorRGBA(r=0.1, g=0.8, b=0.2, a=1.0)))
    markers += _obstacle_markers(obstacles, header, influence_distance)
    if path_positions is not None and len(path_positions) > 1:
        stride = max(1, math.ceil(len(path_positions) / MAX_PATH_POINTS))
        shown = np.vstack([path_positions[:-1:stride], path_positions[-1:]])
        points = [Point(x=p[0], y=p[1], z=p[2]) for p in shown.tolist()]
        markers.append(Marker(header=header, ns="path", type=Marker.LINE_STRIP, points=points,
                              scale=Vector3(x=0.005), color=ColorRGBA(r=0.9, g=0.2, b=0.6, a=1.0)))
    return MarkerArray(markers=markers)
