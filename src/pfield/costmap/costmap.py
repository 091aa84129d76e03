"""2D costmaps with nav2's cost values and inflation rule, and their parameters.

Cost values (nav2 ``cost_values.hpp``): FREE_SPACE 0, INSCRIBED_INFLATED_OBSTACLE 253, LETHAL_OBSTACLE
254, NO_INFORMATION 255. An occupancy grid becomes costs as nav2's static layer does
(``interpretValue``): −1 → NO_INFORMATION (``track_unknown_space``), ``≥ lethal_cost_threshold`` → LETHAL,
everything else FREE (``trinary_costmap``) or ``value / lethal_cost_threshold · 254``.

Inflation (nav2 ``InflationLayer::computeCost``), with d the distance (m) from a cell centre to the
nearest lethal cell centre, r_i the inscribed radius of the padded footprint and k = cost_scaling_factor:

    cost(d) = 254                                   if d = 0
              253                                   if 0 < d ≤ r_i
              floor(252 · exp(−k · (d − r_i)))      if r_i < d and d / res ≤ ceil(inflation_radius / res)

combined as nav2 does: ``max(old, cost)``, except that an unknown cell only takes a cost ≥ 253. Distances
come from an exact Euclidean distance transform (nav2 propagates approximately, cell by cell).

Coordinates (costmap_2d ``worldToMap``/``mapToWorld``): ``mx = floor((wx − origin_x) / resolution)``,
valid when ``0 ≤ mx < size_x`` (same in y); the centre of cell ``mx`` is ``origin_x + (mx + 0.5)·res``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, fields
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield._core import costmap as _costmap
from pfield.costmap.footprint import Footprint
from pfield.costmap.map_io import OccupancyMap
from pfield.errors import InvalidInput

__all__ = [
    "FREE_SPACE",
    "INSCRIBED_INFLATED_OBSTACLE",
    "LETHAL_OBSTACLE",
    "MAX_LOCAL_WINDOW_CELLS",
    "MAX_LOCAL_WINDOW_SIZE",
    "MIN_ANGLE_INCREMENT",
    "MIN_RESOLUTION",
    "NO_INFORMATION",
    "Costmap2D",
    "CostmapParams",
    "build_costmap",
    "costs_from_occupancy",
    "inflate",
    "local_window",
]

logger = logging.getLogger(__name__)

FREE_SPACE: int = _costmap.FREE_SPACE
INSCRIBED_INFLATED_OBSTACLE: int = _costmap.INSCRIBED_INFLATED_OBSTACLE
LETHAL_OBSTACLE: int = _costmap.LETHAL_OBSTACLE
NO_INFORMATION: int = _costmap.NO_INFORMATION


MIN_ANGLE_INCREMENT = math.radians(0.1)
"""rad: the finest FindValidPose yaw step (0.1°; Move Base Flex uses 5°): finer steps multiply the yaws of a
search (3600 per turn at 0.1°) without a pose a real controller could track."""
MIN_RESOLUTION = 0.005
"""m: the finest local-window resolution (5 mm; nav2 local costmaps use 2.5–10 cm)."""
MAX_LOCAL_WINDOW_SIZE = 50.0
"""m: the largest local window side (nav2's rolling windows are 3–10 m; a 300 m one costs seconds per request)."""
MAX_LOCAL_WINDOW_CELLS = 1000
"""Cells per side of the local window at most (``local_window_size / resolution``): 10⁶ cells, ~0.1 s to build."""


@dataclass(frozen=True)
class CostmapParams:
    """Parameters of the ``/costmap`` node, named as nav2's (DESIGN §3.4); lengths in m, angles in rad.

    ``footprint`` is nav2's string ``"[[x, y], ...]"`` (a list of pairs is accepted and converted);
    ``"[]"`` means a circle of ``robot_radius``.
    ``resolution`` and ``local_window_size`` shape the local (rolling) window around the robot;
    ``angle_increment`` is FindValidPose's yaw step (Move Base Flex uses 5°).
    Bounds: ``angle_increment`` ≥ :data:`MIN_ANGLE_INCREMENT`, ``resolution`` ≥ :data:`MIN_RESOLUTION`,
    ``local_window_size`` ≤ :data:`MAX_LOCAL_WINDOW_SIZE` and ≤ :data:`MAX_LOCAL_WINDOW_CELLS` cells.
    """

    footprint: str = "[]"
    robot_radius: float = 0.1
    footprint_padding: float = 0.01
    inflation_radius: float = 0.55
    cost_scaling_factor: float = 10.0
    resolution: float = 0.05
    local_window_size: float = 3.0
    global_frame: str = "map"
    angle_increment: float = math.radians(5.0)
    lethal_cost_threshold: int = 100
    trinary_costmap: bool = True
    track_unknown_space: bool = True

    def __post_init__(self) -> None:
        for name in ("robot_radius", "footprint_padding", "inflation_radius", "cost_scaling_factor"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value < 0:
                raise InvalidInput(name, value, "must be a finite number >= 0")
        for name in ("resolution", "local_window_size", "angle_increment"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
                raise InvalidInput(name, value, "must be a finite number > 0")
        if self.angle_increment < MIN_ANGLE_INCREMENT:
            raise InvalidInput("angle_increment", self.angle_increment,
                               f"must be >= {MIN_ANGLE_INCREMENT:.6g} rad (0.1°)")
        if self.resolution < MIN_RESOLUTION:
            raise InvalidInput("resolution", self.resolution, f"must be >= {MIN_RESOLUTION:g} m")
        if self.local_window_size > MAX_LOCAL_WINDOW_SIZE:
            raise InvalidInput("local_window_size", self.local_window_size, f"must be <= {MAX_LOCAL_WINDOW_SIZE:g} m")
        if self.local_window_size / self.resolution > MAX_LOCAL_WINDOW_CELLS:
            raise InvalidInput("local_window_size", self.local_window_size,
                               f"local_window_size / resolution ({self.resolution:g} m) must be <= "
                               f"{MAX_LOCAL_WINDOW_CELLS} cells")
        if isinstance(self.footprint, list | tuple):  # a YAML-parsed "[[x, y], ...]" (pfield param set)
            object.__setattr__(self, "footprint", "[]" if not self.footprint
                               else Footprint.from_points(self.footprint).to_string())
        if not isinstance(self.footprint, str):
            raise InvalidInput("footprint", self.footprint, 'must be a string like "[[0.4, 0.25], ...]"')
        if not isinstance(self.global_frame, str) or not self.global_frame:
            raise InvalidInput("global_frame", self.global_frame, "must be a non-empty frame name")
        for name in ("trinary_costmap", "track_unknown_space"):
            if not isinstance(getattr(self, name), bool):
                raise InvalidInput(name, getattr(self, name), "must be true or false")
        threshold = self.lethal_cost_threshold
        if isinstance(threshold, bool) or not isinstance(threshold, int) or not 1 <= threshold <= 100:
            raise InvalidInput("lethal_cost_threshold", threshold, "must be an integer in [1, 100]")
        self.robot_footprint()  # validates footprint / robot_radius together

    def robot_footprint(self) -> Footprint:
        """The unpadded footprint (polygon, or the robot_radius circle)."""
        return Footprint.from_parameters(self.footprint, self.robot_radius)

    def padded_footprint(self) -> Footprint:
        return self.robot_footprint().padded(self.footprint_padding)

    def as_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True, eq=False)
class Costmap2D:
    """Costs ``costs[my, mx]`` (uint8, row 0 at the bottom) on a grid of ``resolution`` m in ``frame_id``.

    ``origin_x``, ``origin_y`` (m) locate the lower-left corner of cell (0, 0), as in costmap_2d.
    """

    costs: NDArray[np.uint8]
    resolution: float
    origin_x: float = 0.0
    origin_y: float = 0.0
    frame_id: str = "map"

    def __post_init__(self) -> None:
        costs = np.ascontiguousarray(self.costs, dtype=np.uint8)
        if costs.ndim != 2 or costs.size == 0:
            raise InvalidInput("costs", f"array{costs.shape}", "expected a non-empty (size_y, size_x) grid")
        costs.setflags(write=False)
        object.__setattr__(self, "costs", costs)
        if not (math.isfinite(self.resolution) and self.resolution > 0):
            raise InvalidInput("resolution", self.resolution, "must be > 0")

    @property
    def size_x(self) -> int:
        return int(self.costs.shape[1])

    @property
    def size_y(self) -> int:
        return int(self.costs.shape[0])

    def world_to_map(self, wx: float, wy: float) -> tuple[int, int] | None:
        """Cell ``(mx, my)`` containing the world point, or None outside the map (costmap_2d ``worldToMap``)."""
        if wx < self.origin_x or wy < self.origin_y:
            return None
        mx = math.floor((wx - self.origin_x) / self.resolution)
        my = math.floor((wy - self.origin_y) / self.resolution)
        if mx < self.size_x and my < self.size_y:
            return mx, my
        return None

    def map_to_world(self, mx: int, my: int) -> tuple[float, float]:
        """World position (m) of the centre of cell ``(mx, my)`` (costmap_2d ``mapToWorld``)."""
        return self.origin_x + (mx + 0.5) * self.resolution, self.origin_y + (my + 0.5) * self.resolution

    def cost(self, mx: int, my: int) -> int:
        return int(self.costs[my, mx])

    @cached_property
    def lethal_distance(self) -> NDArray[np.float64]:
        """Distance (cells) from each cell centre to the nearest LETHAL cell centre (inf when there is none)."""
        lethal = self.costs == LETHAL_OBSTACLE
        if not lethal.any():
            return np.full(self.costs.shape, np.inf)
        from scipy import ndimage  # here, not at import: `pfield serve` without a map never needs it (~0.3 s)

        return np.ascontiguousarray(ndimage.distance_transform_edt(~lethal), dtype=np.float64)


def costs_from_occupancy(data: NDArray[np.int8], lethal_cost_threshold: int = 100, trinary_costmap: bool = True,
                         track_unknown_space: bool = True) -> NDArray[np.uint8]:
    """Costs of occupancy values as nav2's static layer assigns them (``interpretValue``)."""
    values = np.asarray(data, dtype=np.int16)
    if trinary_costmap:
        costs = np.zeros(values.shape, dtype=np.uint8)
    else:
        costs = np.floor(values.clip(0, None) / lethal_cost_threshold * LETHAL_OBSTACLE).astype(np.uint8)
    costs[values >= lethal_cost_threshold] = LETHAL_OBSTACLE
    costs[values == -1] = NO_INFORMATION if track_unknown_space else FREE_SPACE
    return costs


def inflate(costs: NDArray[np.uint8], resolution: float, inscribed_radius: float, inflation_radius: float,
            cost_scaling_factor: float) -> NDArray[np.uint8]:
    """nav2 inflation of the LETHAL cells of ``costs`` (see the module docstring for the rule)."""
    lethal = costs == LETHAL_OBSTACLE
    out = np.array(costs, dtype=np.uint8)
    if not lethal.any():
        return out
    if inflation_radius < inscribed_radius:
        logger.warning("inflation_radius %g < inscribed radius %g: the robot may hit obstacles",
                       inflation_radius, inscribed_radius)
    cell_radius = max(0, math.ceil(inflation_radius / resolution))
    from scipy import ndimage

    distance = ndimage.distance_transform_edt(~lethal)
    metres = distance * resolution
    with np.errstate(over="ignore"):
        decay = (INSCRIBED_INFLATED_OBSTACLE - 1) * np.exp(-cost_scaling_factor * (metres - inscribed_radius))
    inflated = np.where(metres <= inscribed_radius, INSCRIBED_INFLATED_OBSTACLE, np.floor(np.minimum(decay, 252)))
    inflated = np.where(distance > cell_radius, 0, inflated).astype(np.uint8)
    inflated[lethal] = LETHAL_OBSTACLE
    unknown = out == NO_INFORMATION
    out = np.maximum(out, inflated)
    overrides = unknown & (inflated >= INSCRIBED_INFLATED_OBSTACLE)
    out[overrides] = inflated[overrides]
    return out


def build_costmap(occupancy: OccupancyMap, params: CostmapParams) -> Costmap2D:
    """The inflated costmap of an occupancy grid, inflated for the padded footprint of ``params``.

    costmap_2d has no rotated grids: a non-zero origin yaw is ignored with a warning, as nav2 does.
    """
    if occupancy.origin[2] != 0.0:
        logger.warning("map origin yaw %g ignored (costmap_2d grids are axis-aligned)", occupancy.origin[2])
    base = costs_from_occupancy(occupancy.data, params.lethal_cost_threshold, params.trinary_costmap,
                                params.track_unknown_space)
    costs = inflate(base, occupancy.resolution, params.padded_footprint().inscribed_radius,
                    params.inflation_radius, params.cost_scaling_factor)
    return Costmap2D(costs, occupancy.resolution, occupancy.origin[0], occupancy.origin[1], occupancy.frame_id)


def _snap(value: float) -> float:
    """``value`` rounded to the nearest integer when within 1e-9 of it (grid-aligned windows stay aligned)."""
    nearest = round(value)
    return float(nearest) if abs(value - nearest) < 1e-9 else value


def local_window(occupancy: OccupancyMap, center_x: float, center_y: float, params: CostmapParams) -> Costmap2D:
    """A rolling window of ``local_window_size`` m at ``resolution`` around ``(center_x, center_y)``.

    The window's origin is ``center − size/2`` snapped down to the global grid when the resolutions match
    (to the window's own resolution otherwise); each window cell takes the worst global cell it overlaps
    (occupied > unknown > free), cells beyond the global map are unknown. Then it is inflated as a whole.
    """
    size = params.local_window_size
    res = params.resolution
    cells = max(1, math.floor(size / res + 1e-9))
    ox, oy = occupancy.origin[0], occupancy.origin[1]
    step = occupancy.resolution if math.isclose(res, occupancy.resolution, rel_tol=1e-12) else res
    origin_x = ox + math.floor((center_x - 0.5 * cells * res - ox) / step) * step
    origin_y = oy + math.floor((center_y - 0.5 * cells * res - oy) / step) * step
    scale = res / occupancy.resolution
    data = _costmap.resample_occupancy(np.ascontiguousarray(occupancy.data, dtype=np.int8),
                                       _snap((origin_x - ox) / occupancy.resolution),
                                       _snap((origin_y - oy) / occupancy.resolution), scale, cells, cells)
    window = OccupancyMap(data, res, (origin_x, origin_y, 0.0), occupancy.frame_id)
    return build_costmap(window, params)
