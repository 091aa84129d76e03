"""2D costmaps and FindValidPose: map_server maps, nav2 cost values and inflation, footprints.

* :mod:`~pfield.costmap.map_io` — load/save map_server YAML + PGM/PNG, OccupancyGrid conversion;
* :mod:`~pfield.costmap.costmap` — :class:`Costmap2D`, nav2 inflation, :class:`CostmapParams`;
* :mod:`~pfield.costmap.footprint` — :class:`Footprint` (polygon or radius, padding, exact rasterisation);
* :mod:`~pfield.costmap.find_valid_pose` — :func:`find_valid_pose` (Move Base Flex's service, contract kept);
* :func:`example_map_path` — the built-in example map (the demo's and the CLI's default), drawn on first use.
"""

from pfield.costmap._example import example_map_path
from pfield.costmap.costmap import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
    CostmapParams,
    build_costmap,
    costs_from_occupancy,
    inflate,
    local_window,
)
from pfield.costmap.find_valid_pose import (
    PoseState,
    SearchTrace,
    ValidPoseResult,
    find_valid_pose,
    pose_state,
)
from pfield.costmap.footprint import Footprint
from pfield.costmap.map_io import MapMetadata, OccupancyMap, load_map, load_map_yaml, save_map

__all__ = [
    "FREE_SPACE",
    "INSCRIBED_INFLATED_OBSTACLE",
    "LETHAL_OBSTACLE",
    "NO_INFORMATION",
    "Costmap2D",
    "CostmapParams",
    "Footprint",
    "MapMetadata",
    "OccupancyMap",
    "PoseState",
    "SearchTrace",
    "ValidPoseResult",
    "build_costmap",
    "costs_from_occupancy",
    "example_map_path",
    "find_valid_pose",
    "inflate",
    "load_map",
    "load_map_yaml",
    "local_window",
    "pose_state",
    "save_map",
]
