"""What the 3D viewer draws, on a viser server: obstacles, influence zones, goal, path, robot, field, costmap.

:class:`ViewerScene` owns the scene nodes and updates them from pfield values (``Obstacle``, ``Pose``,
``PlannedPath`` arrays, ``PotentialField``); it knows nothing of the node or the GUI. Every method may be
called from any thread (one lock). Quaternions are pfield's (x, y, z, w); viser's are (w, x, y, z).

Scene names: ``/obstacles/<id>``, ``/influence/<id>``, ``/goal`` (transform gizmo), ``/path`` (line and
``/path/triad_<k>`` frames), ``/robot`` (URDF meshes), ``/field`` (arrows), ``/query`` (frame and
``/query/autonomy`` arrow), ``/costmap`` (textured ground plane) and ``/valid_pose``.

:meth:`ViewerScene.bounds` is the box the viewer frames: the robot as drawn (and at the end of its
trajectory), the obstacles, the goal and the path.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.spatial import Pose
from pfield.viz._viewer_shapes import GROUP_COLOURS, influence_mesh, obstacle_colour, shape_mesh

__all__ = ["FIELD_COLOUR", "GOAL_COLOUR", "PATH_COLOUR", "ViewerScene", "wxyz"]

PATH_COLOUR = (230, 51, 153)
GOAL_COLOUR = (26, 204, 51)
FIELD_COLOUR = (60, 60, 200)
TRIAD_EVERY = 25
"""Orientation triads are drawn every this many waypoints (and at the last one)."""


def wxyz(pose: Pose) -> NDArray[np.float64]:
    """viser's (w, x, y, z) quaternion of a pose."""
    x, y, z, w = pose.orientation
    return np.array([w, x, y, z])


class ViewerScene:
    """The scene nodes of one viewer (see the module docstring).

    ``robot``: a :class:`~pfield.robot.RobotModel` to draw from its URDF's visual meshes, read through the
    model's own resolver (:meth:`~pfield.robot.RobotModel.resolve_mesh`); None: no robot.
    """

    def __init__(self, server: Any, robot: Any = None) -> None:
        self.server = server
        self._lock = threading.RLock()
        self._obstacles: dict[str, Any] = {}
        self._colours: dict[str, tuple[int, int, int]] = {}
        self._influence_distance = 0.0
        self._influence_visible = True
        self._goal_handle: Any = None
        self._on_goal_moved: Callable[[Pose], None] | None = None
        self._path_nodes: list[Any] = []
        self._robot = robot
        self._urdf: Any = None
        self._visual: Any = None
        """The yourdfpy URDF behind the drawn robot (its meshes and scene graph)."""
        self._obstacle_boxes: dict[str, NDArray[np.float64]] = {}
        self._goal_position: NDArray[np.float64] | None = None
        self._path_points: NDArray[np.float64] | None = None
        self._trajectory_end_box: NDArray[np.float64] | None = None
        self._joint_order: NDArray[np.int64] | None = None
        self._joint_fill: NDArray[np.float64] | None = None
        self._trajectory: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        self._field_handle: Any = None
        self._query_nodes: list[Any] = []
        self._costmap_nodes: list[Any] = []
        self.configuration: NDArray[np.float64] | None = None
        """The joint angles the robot is drawn at (None without a robot)."""
        if robot is not None:
            self._load_robot(robot)

    # ---- obstacles ------------------------------------------------------------------------------------
    @property
    def obstacles(self) -> list[Any]:
        with self._lock:
            return list(self._obstacles.values())

    def colour_of(self, obstacle_id: str) -> tuple[int, int, int]:
        """The RGB colour (0–255) obstacle ``obstacle_id`` is drawn in (fixed at its first appearance)."""
        with self._lock:
            if obstacle_id not in self._colours:
                self._colours[obstacle_id] = obstacle_colour(len(self._colours))
            return self._colours[obstacle_id]

    def set_obstacles(self, obstacles: Sequence[Any]) -> None:
        """Show exactly ``obstacles`` (pfield ``Obstacle`` values); unchanged ones are left as drawn."""
        with self._lock:
            wanted = {obstacle.id: obstacle for obstacle in obstacles}
            for key in [k for k in self._obstacles if k not in wanted]:
                self._remove_obstacle(key)
            for key, obstacle in wanted.items():
                held = self._obstacles.get(key)
                if held is not None and held.shape == obstacle.shape and held.pose == obstacle.pose \
                        and held.group == obstacle.group:
                    continue
                self._draw_obstacle(obstacle)

    def _remove_obstacle(self, key: str) -> None:
        self._obstacles.pop(key, None)
        self._obstacle_boxes.pop(key, None)
        self.server.scene.remove_by_name(f"/obstacles/{key}")
        self.server.scene.remove_by_name(f"/influence/{key}")

    def _draw_obstacle(self, obstacle: Any) -> None:
        self._obstacles[obstacle.id] = obstacle
        vertices, faces = shape_mesh(obstacle.shape)
        world = vertices @ np.asarray(obstacle.pose.rotation).T + np.asarray(obstacle.pose.position)
        self._obstacle_boxes[obstacle.id] = np.array([world.min(axis=0), world.max(axis=0)])
        placement = {"position": np.asarray(obstacle.pose.position), "wxyz": wxyz(obstacle.pose)}
        self.server.scene.add_mesh_simple(f"/obstacles/{obstacle.id}", vertices, faces,
                                          color=self.colour_of(obstacle.id), **placement)
        self._draw_influence(obstacle, placement)

    def _draw_influence(self, obstacle: Any, placement: dict[str, Any]) -> None:
        vertices, faces = influence_mesh(obstacle.shape, self._influence_distance)
        self.server.scene.add_mesh_simple(f"/influence/{obstacle.id}", vertices, faces,
                                          color=GROUP_COLOURS.get(obstacle.group, (128, 128, 128)), opacity=0.18,
                                          side="double", cast_shadow=False, receive_shadow=False,
                                          visible=self._influence_visible, **placement)

    def set_influence(self, distance: float | None = None, visible: bool | None = None) -> None:
        """Grow the influence zones to ``distance`` (m) and/or show or hide them."""
        with self._lock:
            changed = distance is not None and distance != self._influence_distance
            if distance is not None:
                self._influence_distance = float(distance)
            if visible is not None:
                self._influence_visible = bool(visible)
            for obstacle in self._obstacles.values():
                if changed:
                    self._draw_influence(obstacle, {"position": np.asarray(obstacle.pose.position),
                                                    "wxyz": wxyz(obstacle.pose)})
                else:
                    handle = self.server.scene.get_handle_by_name(f"/influence/{obstacle.id}")
                    if handle is not None:
                        handle.visible = self._influence_visible

    # ---- goal -----------------------------------------------------------------------------------------
    def enable_goal_gizmo(self, on_moved: Callable[[Pose], None] | None) -> None:
        """Draw the goal as a draggable transform gizmo; ``on_moved(pose)`` is called after each drag."""
        with self._lock:
            self._on_goal_moved = on_moved
            self._goal_handle = self.server.scene.add_transform_controls("/goal", scale=0.15, line_width=3.0,
                                                                         depth_test=False, visible=False)
            self.server.scene.add_icosphere("/goal/marker", radius=0.015, color=GOAL_COLOUR)

            @self._goal_handle.on_update
            def _(event: Any) -> None:
                handle = self._goal_handle
                w, x, y, z = (float(v) for v in handle.wxyz)
                pose = Pose(tuple(float(v) for v in handle.position), (x, y, z, w))
                if self._on_goal_moved is not None:
                    self._on_goal_moved(pose)

    def set_goal(self, pose: Pose | None) -> None:
        """Move the goal gizmo to ``pose`` (hidden while there is no goal)."""
        with self._lock:
            if self._goal_handle is None:
                self.enable_goal_gizmo(None)
            self._goal_position = None if pose is None else np.asarray(pose.position, dtype=np.float64)
            if pose is None:
                self._goal_handle.visible = False
                return
            self._goal_handle.position = np.asarray(pose.position)
            self._goal_handle.wxyz = wxyz(pose)
            self._goal_handle.visible = True

    # ---- path -----------------------------------------------------------------------------------------
    def set_path(self, positions: NDArray[np.float64] | None, orientations: NDArray[np.float64] | None) -> None:
        """The end-effector path as a line with an orientation triad every :data:`TRIAD_EVERY` waypoints."""
        with self._lock:
            for node in self._path_nodes:
                node.remove()
            self._path_nodes = []
            self._path_points = None
            if positions is None or len(positions) < 2:
                return
            points = np.asarray(positions, dtype=np.float64)
            self._path_points = points
            segments = np.stack([points[:-1], points[1:]], axis=1)
            self._path_nodes.append(self.server.scene.add_line_segments("/path/line", segments, colors=PATH_COLOUR,
                                                                        thickness=3.0, thickness_units="screen"))
            if orientations is None:
                return
            indices = sorted({*range(0, len(points), TRIAD_EVERY), len(points) - 1})
            for k in indices:
                x, y, z, w = orientations[k]
                self._path_nodes.append(self.server.scene.add_frame(
                    f"/path/triad_{k}", axes_length=0.03, axes_radius=0.002, origin_radius=0.003,
                    position=points[k], wxyz=(w, x, y, z)))

    # ---- robot ----------------------------------------------------------------------------------------
    def _load_robot(self, robot: Any) -> None:
        from viser.extras import ViserUrdf

        from pfield.viz._viewer_robot import load_visual_urdf

        self._visual = load_visual_urdf(robot)
        self._urdf = ViserUrdf(self.server, self._visual, root_node_name="/robot")
        names = list(self._urdf.get_actuated_joint_names())
        limits = self._urdf.get_actuated_joint_limits()
        own = {name: i for i, name in enumerate(robot.joint_names)}
        self._joint_order = np.array([own.get(name, -1) for name in names], dtype=np.int64)
        fill = []
        for name in names:  # joints pfield locks (a Panda's fingers): their upper limit (open)
            lower, upper = limits.get(name, (None, None))
            fill.append(float(upper) if upper is not None else 0.0 if lower is None else float(lower))
        self._joint_fill = np.array(fill)
        self.set_configuration(np.clip(np.zeros(robot.n_joints), robot.lower_limits, robot.upper_limits))

    def _full_configuration(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        assert self._joint_order is not None and self._joint_fill is not None
        values = np.asarray(q, dtype=np.float64)
        return np.where(self._joint_order >= 0, values[np.maximum(self._joint_order, 0)], self._joint_fill)

    def robot_bounds(self, q: NDArray[np.float64] | None = None) -> NDArray[np.float64] | None:
        """(2, 3) lower and upper corners (m, world) of the robot's visual meshes at joint angles ``q``
        (default: as drawn); None without a robot or meshes."""
        with self._lock:
            if self._visual is None:
                return None
            if q is None or self.configuration is None:
                bounds = self._visual.scene.bounds
            else:  # pose the mesh model at q, measure, and put it back (the drawn robot does not move)
                self._visual.update_cfg(self._full_configuration(q))
                bounds = self._visual.scene.bounds
                self._visual.update_cfg(self._full_configuration(self.configuration))
            return None if bounds is None else np.array(bounds, dtype=np.float64)

    @property
    def has_robot(self) -> bool:
        return self._urdf is not None

    def set_configuration(self, q: NDArray[np.float64]) -> None:
        """Pose the robot at joint angles ``q`` (pfield's tree order, rad or m)."""
        with self._lock:
            if self._urdf is None or self._joint_order is None or self._joint_fill is None:
                return
            values = np.asarray(q, dtype=np.float64)
            self._urdf.update_cfg(self._full_configuration(values))
            self.configuration = values.copy()

    def set_trajectory(self, times: NDArray[np.float64] | None, joint_positions: NDArray[np.float64] | None) -> None:
        """The whole-body trajectory the time slider plays (None: keep the robot where it is)."""
        with self._lock:
            if times is None or joint_positions is None or len(times) == 0:
                self._trajectory = None
                self._trajectory_end_box = None
                return
            self._trajectory = (np.asarray(times, dtype=np.float64), np.asarray(joint_positions, dtype=np.float64))
            self.set_time(0.0)
            self._trajectory_end_box = self.robot_bounds(self._trajectory[1][-1])

    @property
    def duration(self) -> float:
        """Duration of the trajectory (s); 0 without one."""
        return float(self._trajectory[0][-1]) if self._trajectory is not None else 0.0

    def set_time(self, t: float) -> None:
        """Pose the robot at time ``t`` (s) of the trajectory (joint angles linearly interpolated)."""
        with self._lock:
            if self._trajectory is None:
                return
            times, positions = self._trajectory
            q = np.array([np.interp(t, times, positions[:, j]) for j in range(positions.shape[1])])
            self.set_configuration(q)

    # ---- what the camera frames ------------------------------------------------------------------------
    def bounds(self) -> NDArray[np.float64] | None:
        """(2, 3) lower and upper corners (m, world) of what is shown: the robot as drawn and at the end of its
        trajectory, the obstacles, the goal and the path; None when nothing is."""
        with self._lock:
            boxes = [*self._obstacle_boxes.values()]
            robot = self.robot_bounds()
            for box in (robot, self._trajectory_end_box):
                if box is not None:
                    boxes.append(box)
            for points in (self._goal_position, self._path_points):
                if points is not None:
                    cloud = np.atleast_2d(points)
                    boxes.append(np.array([cloud.min(axis=0), cloud.max(axis=0)]))
        if not boxes:
            return None
        stacked = np.stack(boxes)
        return np.array([stacked[:, 0].min(axis=0), stacked[:, 1].max(axis=0)])

    # ---- field ----------------------------------------------------------------------------------------
    def set_field_arrows(self, starts: NDArray[np.float64] | None, vectors: NDArray[np.float64] | None,
                         visible: bool = True) -> None:
        """Arrows from ``starts`` (N, 3) along ``vectors`` (N, 3, m), coloured by length; None removes them."""
        with self._lock:
            if self._field_handle is not None:
                self._field_handle.remove()
                self._field_handle = None
            if starts is None or vectors is None or len(starts) == 0:
                return
            from matplotlib import colormaps

            lengths = np.linalg.norm(vectors, axis=1)
            scale = lengths / lengths.max() if lengths.max() > 0 else lengths
            colours = (np.asarray(colormaps["viridis"](scale))[:, :3] * 255).astype(np.uint8)
            points = np.stack([starts, starts + vectors], axis=1)
            shaft = float(max(lengths.max(), 1e-3)) * 0.07
            self._field_handle = self.server.scene.add_arrows("/field", points, colours, shaft_radius=shaft,
                                                              head_radius=2.5 * shaft, head_length=6 * shaft,
                                                              visible=visible)

    # ---- query pose and autonomy vector ---------------------------------------------------------------
    def set_query(self, pose: Pose | None, linear: NDArray[np.float64] | None = None) -> None:
        """The query pose as a frame and the autonomy vector's linear part (m/s, drawn 1 s long) as an arrow."""
        with self._lock:
            for node in self._query_nodes:
                node.remove()
            self._query_nodes = []
            if pose is None:
                return
            self._query_nodes.append(self.server.scene.add_frame("/query", axes_length=0.05, axes_radius=0.003,
                                                                 position=np.asarray(pose.position),
                                                                 wxyz=wxyz(pose)))
            if linear is not None and np.linalg.norm(linear) > 0:
                start = np.asarray(pose.position)
                points = np.array([[start, start + np.asarray(linear)]])
                self._query_nodes.append(self.server.scene.add_arrows("/autonomy", points, (250, 200, 0),
                                                                      shaft_radius=0.003, head_radius=0.008,
                                                                      head_length=0.02))

    # ---- costmap --------------------------------------------------------------------------------------
    def set_costmap(self, rgb: NDArray[np.uint8] | None, resolution: float = 0.05,
                    origin: tuple[float, float] = (0.0, 0.0), valid_pose: tuple[float, float, float] | None = None
                    ) -> None:
        """The costmap image (rows = y upwards, as in OccupancyGrid) as a ground plane at z = 0, with
        ``origin`` its lower-left corner (m) and an answer of FindValidPose ``(x, y, yaw)`` as a frame."""
        with self._lock:
            for node in self._costmap_nodes:
                node.remove()
            self._costmap_nodes = []
            if rgb is None:
                return
            height, width = rgb.shape[:2]
            size_x, size_y = width * resolution, height * resolution
            # viser's image plane shows row 0 at +y: flip the OccupancyGrid (row 0 at the bottom).
            self._costmap_nodes.append(self.server.scene.add_image(
                "/costmap", np.ascontiguousarray(rgb[::-1]), render_width=size_x, render_height=size_y,
                position=(origin[0] + size_x / 2, origin[1] + size_y / 2, -0.001), receive_shadow=False,
                cast_shadow=False))
            if valid_pose is not None:
                x, y, yaw = valid_pose
                self._costmap_nodes.append(self.server.scene.add_frame(
                    "/valid_pose", axes_length=0.3, axes_radius=0.015, position=(x, y, 0.02),
                    wxyz=(np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))))
