"""The shipped example map (``pfield/data/maps/example.yaml`` + ``.pgm``) and the code that draws it.

A 10 × 8 m flat at 5 cm (200 × 160 cells, origin (−5, −4)): outer walls, an inner wall at x = 1 m with a
0.9 m doorway, a 0.7 m wide corridor in the left room, a table, two pillars, and an unexplored (unknown)
corner in the right room. :func:`draw_example_map` regenerates it; a test keeps the files in sync.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np

from pfield.costmap.map_io import OccupancyMap, save_map

__all__ = ["EXAMPLE_MAP_NAME", "draw_example_map", "example_map_path"]

EXAMPLE_MAP_NAME = "example"
_RES = 0.05
_ORIGIN = (-5.0, -4.0, 0.0)


def example_map_path() -> Path:
    """Path of the shipped ``example.yaml``."""
    return Path(str(resources.files("pfield") / "data" / "maps" / f"{EXAMPLE_MAP_NAME}.yaml"))


def _centres(data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cell-centre y (column vector) and x (row vector) of the grid (m, map frame), for broadcasting."""
    rows = np.arange(data.shape[0]) * _RES + _ORIGIN[1] + 0.5 * _RES
    cols = np.arange(data.shape[1]) * _RES + _ORIGIN[0] + 0.5 * _RES
    return rows[:, None], cols[None, :]


def _box(data: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: int) -> None:
    """Set the cells whose centres lie in [x0, x1] × [y0, y1] (m, map frame)."""
    y, x = _centres(data)
    data[(y >= y0) & (y <= y1) & (x >= x0) & (x <= x1)] = value


def _disc(data: np.ndarray, cx: float, cy: float, radius: float) -> None:
    """Mark occupied the cells whose centres lie within ``radius`` (m) of (cx, cy)."""
    y, x = _centres(data)
    data[(y - cy) ** 2 + (x - cx) ** 2 <= radius**2] = 100


def draw_example_map() -> OccupancyMap:
    """The example map as an occupancy grid (0 free, 100 occupied, −1 unknown)."""
    data = np.full((160, 200), -1, dtype=np.int8)
    _box(data, -4.8, -3.8, 4.8, 3.8, 100)  # walls everywhere inside the unknown margin …
    _box(data, -4.7, -3.7, 4.7, 3.7, 0)  # … then hollowed out
    _box(data, 0.95, -3.8, 1.05, 3.8, 100)  # inner wall
    _box(data, 0.95, -0.45, 1.05, 0.45, 0)  # 0.9 m doorway
    _box(data, -3.1, 0.5, -3.0, 3.7, 100)  # corridor walls: free x ∈ (-3.0, -2.3)
    _box(data, -2.3, 0.5, -2.2, 3.0, 100)
    _box(data, -1.5, -2.0, -0.5, -1.2, 100)  # table
    _disc(data, -2.0, -0.2, 0.15)  # pillars
    _disc(data, 3.0, -1.5, 0.2)
    _box(data, 2.5, 1.8, 4.75, 3.75, -1)  # unexplored corner of the right room
    return OccupancyMap(data, _RES, _ORIGIN)


def write_example_map(folder: Path) -> Path:
    """Write ``example.yaml`` + ``example.pgm`` into ``folder`` (trinary); return the YAML path."""
    return save_map(draw_example_map(), folder / EXAMPLE_MAP_NAME)
