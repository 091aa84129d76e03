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
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Mapping
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

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
from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces.nav_msgs import OccupancyGrid
from pfield.interfaces.potential_fields_interfaces import FindValidPose_Request, FindValidPose_Response
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec
from pfield.spatial import Pose

__all__ = ["CostmapServer", "costmap_node_from_options", "published_costmap_values"]

_log = logging.getLogger(__name__)
LOCAL_COSTMAP, GLOBAL_COSTMAP = 1, 2
_PARAM_NAMES = tuple(f.name for f in fields(CostmapParams))


def published_costmap_values(costs: NDArray[np.uint8]) -> NDArray[np.int8]:
    """nav2's costmap → OccupancyGrid translation: 0→0, 253→99, 254→100, 255→−1, 1..252→1 + 97·(c−1)/251."""
    table = np.array([0] + [1 + (97 * (c - 1)) // 251 for c in range(1, 253)] + [99, 100, -1], dtype=np.int8)
    return table[costs]


def _pose_of(msg: gm.Pose, field: str) -> Pose:
    p, q = msg.position, msg.orientation
    if not all(math.isfinite(v) for v in (p.x, p.y, p.z, q.x, q.y, q.z, q.w)):
        raise InvalidInput(field, msg.model_dump(), "must be finite (no NaN or inf)")
    return Pose((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))


class CostmapServer(Node):
    """The ``/costmap`` node; ``frame_transforms`` maps a frame name to its pose ``(x, y, yaw)`` in
    ``global_frame`` (static 2D transforms), so requests in that frame are accepted."""

    name = "/costmap"

    def __init__(self, bus: Bus, params: CostmapParams | None = None, occupancy: OccupancyMap | None = None,
                 frame_transforms: Mapping[str, tuple[float, float, float]] | None = None) -> None:
        super().__init__(bus)
        self._lock = threading.Lock()
        self._params = params or CostmapParams()
        self._occupancy: OccupancyMap | None = None
        self._costmap: Costmap2D | None = None
        self._robot: Pose | None = None
        self._transforms = {name: Pose.planar(*xyyaw) for name, xyyaw in (frame_transforms or {}).items()}
        self.last_result: ValidPoseResult | None = None
        """The last FindValidPose search (with its candidate trace), for plots."""
        if occupancy is not None:
            self.set_map(occupancy)

    # ---- contract -----------------------------------------------------------------------------------
    def services(self) -> list[ServiceSpec]:
        return [ServiceSpec("/pfield/find_valid_pose", "potential_fields_interfaces/srv/FindValidPose",
                            FindValidPose_Request, FindValidPose_Response, self.on_find_valid_pose)]

    def subscriptions(self) -> list[SubscriptionSpec]:
        return [SubscriptionSpec("/robot_pose", "geometry_msgs/msg/PoseStamped", gm.PoseStamped, self.on_robot_pose),
                SubscriptionSpec("/map", "nav_msgs/msg/OccupancyGrid", OccupancyGrid, self.on_map)]

    def publications(self) -> list[PublicationSpec]:
        return [PublicationSpec("/costmap/costmap", "nav_msgs/msg/OccupancyGrid", OccupancyGrid)]

    def get_parameters(self) -> dict[str, Any]:
        with self._lock:
            return self._params.as_dict()

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        for key, value in values.items():
            if key not in _PARAM_NAMES:
                raise InvalidInput(key, value, f"unknown parameter of {self.name}")
        with self._lock:
            params = replace(self._params, **dict(values))  # validates every field together
            costmap = build_costmap(self._occupancy, params) if self._occupancy is not None else None
            self._params, self._costmap = params, costmap
        self._publish_costmap()
        return self.get_parameters()

    # ---- state ----------------------------------------------------------------------------------------
    @property
    def params(self) -> CostmapParams:
        return self._params

    @property
    def costmap(self) -> Costmap2D | None:
        """The inflated global costmap (None before a map is loaded)."""
        return self._costmap

    @property
    def occupancy(self) -> OccupancyMap | None:
        return self._occupancy

    @property
    def robot_pose(self) -> Pose | None:
        return self._robot

    def set_map(self, occupancy: OccupancyMap) -> None:
        """Replace the global map (its frame must be ``global_frame``) and rebuild the costmap."""
        with self._lock:
            frame = occupancy.frame_id or self._params.global_frame
            if frame != self._params.global_frame:
                raise UnknownFrame("map.header.frame_id", frame, f"expected {self._params.global_frame!r}")
            costmap = build_costmap(occupancy, self._params)
            self._occupancy, self._costmap = occupancy, costmap
        _log.info("costmap: map of %d x %d cells at %g m", occupancy.width, occupancy.height, occupancy.resolution)
        self._publish_costmap()

    def load_map(self, path: str | Path) -> None:
        """Load a map_server YAML map; on error the current map stays."""
        self.set_map(load_map(path, frame_id=self._params.global_frame))

    def _publish_costmap(self) -> None:
        costmap = self._costmap
        if costmap is None:
            return
        grid = OccupancyMap(published_costmap_values(costmap.costs), costmap.resolution,
                            (costmap.origin_x, costmap.origin_y, 0.0), costmap.frame_id)
        self.bus.publish("/costmap/costmap", OccupancyGrid.model_validate(grid.to_message_fields()))

    def _to_global(self, pose: Pose, frame: str, field: str) -> Pose:
        if frame in ("", self._params.global_frame):
            return pose
        if frame in self._transforms:
            return self._transforms[frame] * pose
        raise UnknownFrame(field, frame, f"expected {self._params.global_frame!r} (no transform is configured)")

    # ---- handlers -------------------------------------------------------------------------------------
    def on_robot_pose(self, msg: gm.PoseStamped) -> None:
        pose = self._to_global(_pose_of(msg.pose, "pose"), msg.header.frame_id, "header.frame_id")
        with self._lock:
            self._robot = pose

    def on_map(self, msg: OccupancyGrid) -> None:
        self.set_map(OccupancyMap.from_message(msg))

    def on_find_valid_pose(self, request: FindValidPose_Request) -> FindValidPose_Response:
        """Answer a FindValidPose request (see the module docstring); bad input raises ``InvalidInput``."""
        if request.costmap not in (LOCAL_COSTMAP, GLOBAL_COSTMAP):
            raise InvalidInput("costmap", request.costmap, "must be 1 (LOCAL_COSTMAP) or 2 (GLOBAL_COSTMAP)")
        with self._lock:
            params, occupancy, costmap, robot = self._params, self._occupancy, self._costmap, self._robot
        if occupancy is None or costmap is None:
            raise InvalidInput("map", None, "no map loaded: start with --map FILE.yaml or publish /map")
        if request.current_pose:
            if robot is None:
                raise InvalidInput("current_pose", True, "no robot pose received yet on /robot_pose")
            pose = robot
        else:
            pose = self._to_global(_pose_of(request.pose.pose, "pose.pose"), request.pose.header.frame_id,
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
