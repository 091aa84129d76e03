"""Framing the viewer's scene: the camera, the ground grid and the slice-height range from the scene's bounds.

The bounds are a (2, 3) box (lower and upper corners, m, world) of what is shown
(:meth:`~pfield.viz._viewer_scene.ViewerScene.bounds`). The camera looks at the box's centre along
:data:`VIEW_DIRECTION` from the distance at which the box's bounding sphere fills the vertical field of view,
so the whole box is in view in any landscape window, wherever the robot stands (a UR5 on a 0.91 m base, a
mobile manipulator) and however large the scene is.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["DEFAULT_BOUNDS", "VIEW_DIRECTION", "camera_pose", "grid_placement", "height_range"]

DEFAULT_BOUNDS = np.array([[0.0, -0.5, 0.0], [1.0, 0.5, 0.5]])
"""What an empty viewer frames: a table-top arm's workspace in front of the origin (m)."""
VIEW_DIRECTION = np.array([-0.6, 0.8, -0.6]) / np.linalg.norm([-0.6, 0.8, -0.6])
"""The camera's line of sight (unit, world): a three-quarter view of an arm facing +x, from its front right
(+x, −y) and 31° above the horizon."""
LEAST_RADIUS = 0.3
"""m: the smallest scene the camera frames (a lone point is seen from 0.5 m away at a 75° field of view)."""


def camera_pose(bounds: NDArray[np.float64], fov: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Camera position and look-at point (m, world) that show all of ``bounds`` with vertical field of view
    ``fov`` (rad): the box's bounding sphere touches the top and bottom of the picture."""
    lower, upper = np.asarray(bounds, dtype=np.float64)
    centre = (lower + upper) / 2
    radius = max(float(np.linalg.norm(upper - lower)) / 2, LEAST_RADIUS)
    distance = radius / math.sin(fov / 2)
    return centre - VIEW_DIRECTION * distance, centre


def grid_placement(bounds: NDArray[np.float64], margin: float = 0.5, cell: float = 0.5
                   ) -> tuple[tuple[float, float, float], float, float]:
    """Centre (on the ground, z = 0), width and height (m) of a ground grid under ``bounds``: the box's
    footprint grown by ``margin`` on each side, rounded out to whole ``cell`` multiples."""
    lower, upper = np.asarray(bounds, dtype=np.float64)
    lo = np.floor((lower[:2] - margin) / cell) * cell
    hi = np.ceil((upper[:2] + margin) / cell) * cell
    centre = (hi + lo) / 2
    return (float(centre[0]), float(centre[1]), 0.0), float(hi[0] - lo[0]), float(hi[1] - lo[1])


def height_range(bounds: NDArray[np.float64], step: float = 0.1, sunk: float = 0.02) -> tuple[float, float]:
    """The heights (m) a horizontal slice through the scene can take: from the ground (or the box's bottom
    when it is lower by more than ``sunk``, e.g. not a base plate's underside) to the box's top, rounded out to
    ``step``."""
    lower, upper = np.asarray(bounds, dtype=np.float64)[:, 2]
    low = math.floor((min(0.0, float(lower)) + sunk) / step + 1e-9) * step
    high = math.ceil(float(upper) / step - 1e-9) * step
    return round(low, 6), round(max(high, low + step), 6)
