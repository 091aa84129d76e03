"""What a live viewer makes of the node's messages (the streams of :data:`pfield.viz.viewer.LIVE_TOPICS`).

:class:`LiveState` is called from the link's stream threads, one message at a time, and updates the
viewer: obstacles and goal from the markers combined with the obstacle messages (see
:class:`~pfield.viz._viewer_state.ObstacleTracker`), the field parameters, the path, the query pose and
its autonomy vector, and the costmap.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.field.config import FieldConfig
from pfield.spatial import Pose
from pfield.viz._viewer_state import ObstacleTracker, path_arrays, pose_of

__all__ = ["GOAL_HOLD", "LiveState"]

_log = logging.getLogger(__name__)
GOAL_HOLD = 1.0
"""s after a drag during which goals echoed back by the node do not move the gizmo."""


class LiveState:
    """The node's state as last streamed, applied to ``viewer``."""

    def __init__(self, viewer: Any, tracker: ObstacleTracker) -> None:
        self.viewer = viewer
        self.tracker = tracker
        self.markers: Mapping[str, Any] | None = None
        self.query: Pose | None = None
        self.autonomy: NDArray[np.float64] | None = None
        self.grid: Any = None
        self._lock = threading.Lock()

    def load_parameters(self) -> None:
        try:
            values = self.viewer.link.get("/param/pfield_manager")
        except Exception as exc:
            _log.warning("cannot read the field parameters: %s", exc)
            return
        known = set(FieldConfig().as_dict())
        self.viewer.config = self.viewer.config.replace(**{k: v for k, v in values.items() if k in known})
        self.viewer.scene.set_influence(distance=self.viewer.config.influence_distance)

    def on_message(self, topic: str, data: dict[str, Any]) -> None:
        with self._lock:  # one stream at a time: markers and obstacle messages combine
            self._show_message(topic, data)

    def _show_message(self, topic: str, data: dict[str, Any]) -> None:
        if topic == "/pfield/obstacles":
            self.tracker.add_message(data)
            if self.markers is not None:
                self._on_markers(self.markers, reload=False)
        elif topic == "/pfield/markers":
            self._on_markers(data, reload=True)
        elif topic == "/pfield/planned_path":
            positions, orientations = path_arrays(data)
            self.viewer.show_path_arrays(positions, orientations)
        elif topic == "/pfield/query_pose":
            self.query = pose_of(data.get("pose", {}))
            self.viewer.scene.set_query(self.query, self.autonomy)
        elif topic == "/pfield/autonomy_vector":
            linear = data.get("twist", {}).get("linear", {})
            self.autonomy = np.array([linear.get("x", 0.0), linear.get("y", 0.0), linear.get("z", 0.0)])
            self.viewer.scene.set_query(self.query, self.autonomy)
        elif topic == "/costmap/costmap":
            self._on_costmap(data)

    def _on_markers(self, data: Mapping[str, Any], reload: bool) -> None:
        self.markers = data
        if reload:
            self.load_parameters()
        obstacles, goal = self.tracker.from_markers(data)
        self.viewer.set_obstacles(obstacles)
        if time.monotonic() - self.viewer.moved_at > GOAL_HOLD:
            self.viewer.set_goal(goal)

    def _on_costmap(self, data: Mapping[str, Any]) -> None:
        from pfield.costmap.map_io import OccupancyMap
        from pfield.interfaces.nav_msgs import OccupancyGrid

        self.grid = OccupancyMap.from_message(OccupancyGrid.model_validate(data))
        self.viewer.show_costmap(self.grid, self.viewer.valid_pose)
