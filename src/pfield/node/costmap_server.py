"""``/costmap``: the transport-free costmap node serving FindValidPose.

Service ``/pfield/find_valid_pose`` (potential_fields_interfaces/srv/FindValidPose, Move Base Flex's
contract kept; see :mod:`pfield.costmap.find_valid_pose`). Topics in: ``/robot_pose``
(geometry_msgs/PoseStamped, the robot pose used by ``current_pose`` and by the local window) and ``/map``
(nav_msgs/OccupancyGrid, replaces the global map). Topic out: ``/costmap/costmap`` (nav_msgs/OccupancyGrid,
the inflated global costmap in nav2's published scale: 0 free, 1–98 inflated, 99 inscribed, 100 lethal,
−1 unknown), published whenever the map or the parameters change.

Parameters (nav2 names, DESIGN §3.4): the :class:`~pfield.costmap.CostmapParams` fields. ``costmap`` in a
request selects ``GLOBAL_COSTMAP`` (2: the whole map) or ``LOCAL_COSTMAP`` (1: a ``local_window_size`` m
window at ``resolution`` around the robot); other values are rejected. Requests and robot poses must be in
``global_frame`` (an empty frame means it) or in a frame given in ``frame_transforms``.
Every handler validates before touching state: a bad request or map leaves the node as it was.

Ranges (refused with ``InvalidInput`` naming the field before any work): the parameters' rows of
:func:`costmap_table` (``angle_increment`` ≥ 0.1°, ``local_window_size`` ≤ 50 m …); a request's
``safety_dist`` and ``dist_tolerance`` in [0, the map's diagonal] m and ``angle_tolerance`` in [0, 2π] rad;
the search's work is capped by :data:`~pfield.costmap.find_valid_pose.MAX_KERNEL_CELLS` (footprint cells ×
yaws) and :data:`~pfield.costmap.find_valid_pose.MAX_CANDIDATES` (positions × yaws).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield._validation import in_range
from pfield.costmap import (
    Costmap2D,
    CostmapParams,
    OccupancyMap,
    PoseState,
    ValidPoseResult,
    build_costmap,
    find_valid_pose,
    load_map,
    local_window,
)
from pfield.costmap.costmap import MAX_LOCAL_WINDOW_SIZE, MIN_ANGLE_INCREMENT, MIN_RESOLUTION
from pfield.costmap.footprint import MAX_FOOTPRINT_POINTS
from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces.convert import pose_from_msg
from pfield.interfaces.nav_msgs import OccupancyGrid
from pfield.interfaces.potential_fields_interfaces import FindValidPose_Request, FindValidPose_Response
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec
from pfield.node._frames import StaticTransforms
from pfield.node._params import ParameterRow, ParameterTable
from pfield.spatial import Pose

__all__ = ["CostmapServer", "CostmapState", "costmap_node_from_options", "costmap_table", "published_costmap_values"]

_log = logging.getLogger(__name__)
LOCAL_COSTMAP, GLOBAL_COSTMAP = 1, 2


FOOTPRINT_TEXT_LENGTH = 48 * MAX_FOOTPRINT_POINTS
"""Longest ``footprint`` string: room for the most vertices a footprint may have, each written in full."""


def costmap_table(name: str) -> ParameterTable:
    """The ``/costmap`` parameter table (nav2's names; ranges a real mobile base stays well inside)."""
    d = CostmapParams()
    rows = [
        ParameterRow("footprint", "string", 'nav2 footprint polygon "[[x, y], ...]" (m, robot frame); "[]" means '
                     "a circle of robot_radius", d.footprint, max_length=FOOTPRINT_TEXT_LENGTH),
        ParameterRow("robot_radius", "double", "radius of a circular robot (m)", d.robot_radius, 0.0, 10.0, "m"),
        ParameterRow("footprint_padding", "double", "padding added around the footprint (m)", d.footprint_padding,
                     0.0, 1.0, "m"),
        ParameterRow("inflation_radius", "double", "distance from lethal cells over which costs decay (m)",
                     d.inflation_radius, 0.0, 10.0, "m"),
        ParameterRow("cost_scaling_factor", "double", "exponential decay rate of the inflated cost (1/m)",
                     d.cost_scaling_factor, 0.0, 100.0, "1/m"),
        ParameterRow("resolution", "double", "cell size of the local window (m)", d.resolution, MIN_RESOLUTION, 1.0,
                     "m"),
        ParameterRow("local_window_size", "double", "side of the local (rolling) window around the robot (m); "
                     "at most 1000 cells per side", d.local_window_size, 0.0, MAX_LOCAL_WINDOW_SIZE, "m",
                     positive=True),
        ParameterRow("global_frame", "string", "frame of the map and of every answer", d.global_frame),
        ParameterRow("angle_increment", "double", "FindValidPose's yaw step (rad; Move Base Flex uses 5°)",
                     d.angle_increment, MIN_ANGLE_INCREMENT, math.pi, "rad"),
        ParameterRow("lethal_cost_threshold", "integer", "occupancy value (0–100) from which a cell is lethal",
                     d.lethal_cost_threshold, 1, 100),
        ParameterRow("trinary_costmap", "bool", "occupancy becomes free/lethal/unknown only (nav2's static layer)",
                     d.trinary_costmap),
        ParameterRow("track_unknown_space", "bool", "unknown cells (-1) stay unknown instead of free",
                     d.track_unknown_space),
    ]
    return ParameterTable(name, rows)


def published_costmap_values(costs: NDArray[np.uint8]) -> NDArray[np.int8]:
    """nav2's costmap → OccupancyGrid translation: 0→0, 253→99, 254→100, 255→−1, 1..252→1 + 97·(c−1)/251."""
    table = np.array([0] + [1 + (97 * (c - 1)) // 251 for c in range(1, 253)] + [99, 100, -1], dtype=np.int8)
    return table[costs]


@dataclass(frozen=True, eq=False)
class CostmapState:
    """The ``/costmap`` node's state as one immutable value (swapped whole under the node's lock)."""

    params: CostmapParams
    occupancy: OccupancyMap | None = None
    costmap: Costmap2D | None = None
    robot: Pose | None = None
    version: int = 0

    def evolve(self, **changes: Any) -> CostmapState:
        return replace(self, **changes, version=self.version + 1)


class CostmapServer(Node):
    """The ``/costmap`` node; ``frame_transforms`` maps a frame name to its pose ``(x, y, yaw)`` in
    ``global_frame`` (static 2D transforms), so requests in that frame are accepted."""

    name = "/costmap"

    def __init__(self, bus: Bus, params: CostmapParams | None = None, occupancy: OccupancyMap | None = None,
                 frame_transforms: Mapping[str, tuple[float, float, float]] | None = None) -> None:
        super().__init__(bus)
        self._lock = threading.Lock()
        self._state = CostmapState(params or CostmapParams())
        self.parameter_table = costmap_table(self.name)
        self._transforms = {name: Pose.planar(*xyyaw) for name, xyyaw in (frame_transforms or {}).items()}
        self.last_result: ValidPoseResult | None = None
        """The last FindValidPose search (with its candidate trace), for plots."""
        if occupancy is not None:
            self.set_map(occupancy)

    # ---- contract -----------------------------------------------------------------------------------
    def services(self) -> list[ServiceSpec]:
        return [ServiceSpec("/pfield/find_valid_pose", "potential_fields_interfaces/srv/FindValidPose",
                            FindValidPose_Request, FindValidPose_Response, self.on_find_valid_pose,
                            long_running=True)]

    def subscriptions(self) -> list[SubscriptionSpec]:
        return [SubscriptionSpec("/robot_pose", "geometry_msgs/msg/PoseStamped", gm.PoseStamped, self.on_robot_pose),
                SubscriptionSpec("/map", "nav_msgs/msg/OccupancyGrid", OccupancyGrid, self.on_map)]

    def publications(self) -> list[PublicationSpec]:
        return [PublicationSpec("/costmap/costmap", "nav_msgs/msg/OccupancyGrid", OccupancyGrid)]

    def get_parameters(self) -> dict[str, Any]:
        return self._state.params.as_dict()

    def describe_parameters(self) -> dict[str, dict[str, Any]]:
        return self.parameter_table.describe()

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        checked = self.parameter_table.check(values)
        with self._lock:
            state = self._state
            params = replace(state.params, **checked)  # validates every field together
            costmap = build_costmap(state.occupancy, params) if state.occupancy is not None else None
            self._state = state.evolve(params=params, costmap=costmap)
        self._publish_costmap()
        return self.get_parameters()

    # ---- state ----------------------------------------------------------------------------------------
    @property
    def params(self) -> CostmapParams:
        return self._state.params

    @property
    def costmap(self) -> Costmap2D | None:
        """The inflated global costmap (None before a map is loaded)."""
        return self._state.costmap

    @property
    def occupancy(self) -> OccupancyMap | None:
        return self._state.occupancy

    @property
    def robot_pose(self) -> Pose | None:
        return self._state.robot

    def set_map(self, occupancy: OccupancyMap) -> None:
        """Replace the global map (its frame must be ``global_frame``) and rebuild the costmap."""
        with self._lock:
            state = self._state
            frame = occupancy.frame_id or state.params.global_frame
            if frame != state.params.global_frame:
                raise UnknownFrame("map.header.frame_id", frame, f"expected {state.params.global_frame!r}")
            costmap = build_costmap(occupancy, state.params)
            self._state = state.evolve(occupancy=occupancy, costmap=costmap)
        _log.info("costmap: map of %d x %d cells at %g m", occupancy.width, occupancy.height, occupancy.resolution)
        self._publish_costmap()

    def load_map(self, path: str | Path) -> None:
        """Load a map_server YAML map; on error the current map stays."""
        self.set_map(load_map(path, frame_id=self._state.params.global_frame))

    def _publish_costmap(self) -> None:
        costmap = self._state.costmap
        if costmap is None:
            return
        grid = OccupancyMap(published_costmap_values(costmap.costs), costmap.resolution,
                            (costmap.origin_x, costmap.origin_y, 0.0), costmap.frame_id)
        self.bus.publish("/costmap/costmap", OccupancyGrid.model_validate(grid.to_message_fields()))

    def frames(self) -> StaticTransforms:
        """The frames service of this node: ``global_frame`` and the static ``frame_transforms``."""
        return StaticTransforms(self._state.params.global_frame, self._transforms)

    def _to_global(self, pose: Pose, frame: str, field: str) -> Pose:
        transform = self.frames().lookup(field, frame)
        return pose if transform is None else transform * pose

    # ---- handlers -------------------------------------------------------------------------------------
    def on_robot_pose(self, msg: gm.PoseStamped) -> None:
        pose = self._to_global(pose_from_msg(msg.pose, "pose"), msg.header.frame_id, "header.frame_id")
        with self._lock:
            self._state = self._state.evolve(robot=pose)

    def on_map(self, msg: OccupancyGrid) -> None:
        self.set_map(OccupancyMap.from_message(msg))

    def on_find_valid_pose(self, request: FindValidPose_Request) -> FindValidPose_Response:
        """Answer a FindValidPose request (see the module docstring); bad input raises ``InvalidInput``."""
        if request.costmap not in (LOCAL_COSTMAP, GLOBAL_COSTMAP):
            raise InvalidInput("costmap", request.costmap, "must be 1 (LOCAL_COSTMAP) or 2 (GLOBAL_COSTMAP)")
        state = self._state
        params, occupancy, costmap, robot = state.params, state.occupancy, state.costmap, state.robot
        if occupancy is None or costmap is None:
            raise InvalidInput("map", None, "no map loaded: start with --map FILE.yaml or publish /map")
        diagonal = math.hypot(costmap.size_x, costmap.size_y) * costmap.resolution
        for name in ("safety_dist", "dist_tolerance"):
            in_range(name, getattr(request, name), 0.0, diagonal, "m (the map's diagonal)")
        in_range("angle_tolerance", request.angle_tolerance, 0.0, 2.0 * math.pi, "rad")
        if request.current_pose:
            if robot is None:
                raise InvalidInput("current_pose", True, "no robot pose received yet on /robot_pose")
            pose = robot
        else:
            pose = self._to_global(pose_from_msg(request.pose.pose, "pose.pose"), request.pose.header.frame_id,
                                   "pose.header.frame_id")
        if request.costmap == LOCAL_COSTMAP:
            if robot is None:
                raise InvalidInput("costmap", request.costmap, "the local costmap needs a robot pose on /robot_pose")
            costmap = local_window(occupancy, float(robot.position[0]), float(robot.position[1]), params)
        footprint = params.padded_footprint() if request.use_padded_fp else params.robot_footprint()
        result = find_valid_pose(costmap, footprint, pose, safety_dist=request.safety_dist,
                                 dist_tolerance=request.dist_tolerance, angle_tolerance=request.angle_tolerance,
                                 angle_increment=params.angle_increment)
        self.last_result = result
        return self._response(result, request, params.global_frame)

    @staticmethod
    def _response(result: ValidPoseResult, request: FindValidPose_Request, frame: str) -> FindValidPose_Response:
        response = FindValidPose_Response(state=int(result.state), cost=min(result.cost, 2**32 - 1))
        if result.pose is not None and result.state != PoseState.LETHAL:
            p, q = result.pose.position, result.pose.orientation
            response.pose = gm.PoseStamped.model_validate({
                "header": {"stamp": request.pose.header.stamp, "frame_id": frame},
                "pose": {"position": {"x": p[0], "y": p[1], "z": p[2]},
                         "orientation": {"x": q[0], "y": q[1], "z": q[2], "w": q[3]}}})
        return response


def costmap_node_from_options(bus: Bus, map_path: str | Path | None, footprint: str | None = None,
                              params: Mapping[str, Any] | None = None) -> CostmapServer:
    """A :class:`CostmapServer` as ``pfield serve --map FILE.yaml --footprint "[[x, y], ...]"`` builds it."""
    values = dict(params or {})
    if footprint:
        values["footprint"] = footprint
    node = CostmapServer(bus)
    if values:
        node.set_parameters(values)
    if map_path is not None:
        node.load_map(map_path)
    return node
