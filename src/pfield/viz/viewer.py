"""The 3D web viewer (viser): obstacles, influence zones, goal, plans, the robot and the field, in a browser.

``Viewer`` serves a page (default http://127.0.0.1:8080) that shows

* every obstacle in its shape and pose (a palette colour each), its influence zone (the shape grown by
  the influence distance Q, translucent; toggle),
* the goal as a draggable transform gizmo (live: dragging publishes ``/pfield/planning_goal_pose``),
* the last planned end-effector path with an orientation triad every few waypoints,
* the robot from its URDF meshes (read through the robot model's own package paths), posed along a
  whole-body plan by a time slider (and "Play"),
* the field's limited linear twist as arrows on a horizontal slice (toggle; slice height and arrows per
  side in the GUI), computed in the viewer with :meth:`PotentialField.twists` (batched, compiled),
* the query pose and its autonomy vector, and a costmap as a textured ground plane with the
  FindValidPose answer.

The camera frames the scene's bounds (the robot as drawn, the obstacles, the goal and the path), and the
ground grid, the field arrows' extent and the slice-height slider follow them (:meth:`Viewer.frame_scene`).

Live (:meth:`Viewer.connect`): the viewer is a client of a running node's HTTP/WebSocket API in its own
threads, so the node never waits for it. Offline (:meth:`Viewer.show_plan`, :func:`show_plan`): a plan
(e.g. read back with :func:`read_plan_csv`) and its obstacles. :func:`export_html` writes a
self-contained HTML page (viser's scene recording with its client inlined) that plays the robot along
the plan without a server.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield._validation import is_loopback_host
from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.planning.result import PlannedPath
from pfield.spatial import Pose
from pfield.viz._viewer_field import field_slice, scene_bounds
from pfield.viz._viewer_frame import DEFAULT_BOUNDS, camera_pose, grid_placement, height_range
from pfield.viz._viewer_scene import ViewerScene
from pfield.viz._viewer_state import ObstacleTracker, path_arrays, pose_of, read_plan_csv

__all__ = ["LIVE_TOPICS", "Viewer", "export_html", "field_slice", "read_plan_csv", "show_plan"]


_log = logging.getLogger(__name__)
LIVE_TOPICS = ("/pfield/markers", "/pfield/obstacles", "/pfield/planned_path", "/pfield/query_pose",
               "/pfield/autonomy_vector", "/costmap/costmap")
"""The node topics a live viewer streams."""
SLICE_HEIGHT = 0.3
"""m: the field slice's height before a goal is shown (then it follows the goal until it is moved)."""


class Viewer:
    """A viser page of the pfield scene (see the module docstring).

    ``robot``: :class:`~pfield.robot.RobotModel` drawn from its URDF's visual meshes, read through the paths
    the model was loaded with (:attr:`~pfield.robot.RobotModel.resolver`; None: no robot); ``package_paths``
    is ignored (kept so that older calls still work: the model carries its own); ``host``/``port``: where the
    page is served (port 0: a free one); ``config``: field parameters until a node gives its own.
    """

    def __init__(self, robot: Any = None, package_paths: Mapping[str, Path] | None = None, *,
                 host: str = "127.0.0.1", port: int = 8080, config: FieldConfig | None = None,
                 token: str | None = None) -> None:
        import viser

        if not is_loopback_host(host) and not token:
            raise InvalidInput("host", host, "serving the page beyond this machine needs a token")
        self._gate: Any = None
        self.token = token
        if token:  # viser on loopback behind a token gate on the asked address
            from pfield.viz._viewer_gate import TokenGate

            self.server = viser.ViserServer(host="127.0.0.1", port=0, label="pfield", verbose=False)
            self._gate = TokenGate(host, port, self.server.get_port(), token).start()
        else:
            self.server = viser.ViserServer(host=host, port=port, label="pfield", verbose=False)
        self.server.scene.set_up_direction("+z")
        self.robot = robot
        try:
            self.scene = ViewerScene(self.server, robot)
        except BaseException:
            self._stop_server()
            raise
        self.config = config or FieldConfig()
        self.goal: Pose | None = None
        self.link: Any = None
        """The :class:`~pfield.viz._viewer_link.NodeLink` to the node (None offline)."""
        self.live: Any = None
        """What the node's messages said (:class:`~pfield.viz._viewer_live.LiveState`; None offline)."""
        self.moved_at = -np.inf
        """time.monotonic() of the last goal drag."""
        self.path_arrays: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        """Positions and orientations of the path shown."""
        self.valid_pose: tuple[float, float, float] | None = None
        self._field_dirty = threading.Event()
        self._closed = threading.Event()
        self._workers: list[threading.Thread] = []
        self.field_generation = 0
        """Incremented each time the field arrows are redrawn."""
        self.bounds = DEFAULT_BOUNDS.copy()
        """(2, 3) corners (m) of the box the camera frames (see :meth:`frame_scene`)."""
        self._frame_lock = threading.RLock()
        self._framed: dict[str, Any] = {}
        self._build_gui()
        self.frame_scene()
        self.scene.enable_goal_gizmo(self._on_goal_dragged)
        self._start(self._field_worker, "pfield-view-field")
        self._start(self._play_worker, "pfield-view-play")

    @property
    def url(self) -> str:
        """The page's address (with ``?token=`` when it has one)."""
        if self._gate is not None:
            return f"http://{self._gate.host}:{self._gate.port}/?token={self.token}"
        return f"http://{self.server.get_host()}:{self.server.get_port()}"

    def _start(self, target: Any, name: str) -> None:
        thread = threading.Thread(target=target, name=name, daemon=True)
        thread.start()
        self._workers.append(thread)

    # ---- GUI ------------------------------------------------------------------------------------------
    def _build_gui(self) -> None:
        gui = self.server.gui
        with gui.add_folder("Scene"):
            self.influence_toggle = gui.add_checkbox("Influence zones", True)
            self.arrows_toggle = gui.add_checkbox("Field arrows", True)
            self.slice_height = gui.add_slider("Slice height (m)", min=0.0, max=1.2, step=0.01,
                                               initial_value=SLICE_HEIGHT)
            self._auto_slice: float | None = SLICE_HEIGHT  # the height the viewer chose (None: the user chose)
            self.arrow_density = gui.add_slider("Arrows per side", min=4, max=40, step=1, initial_value=14)
        with gui.add_folder("Plan"):
            self.method = gui.add_dropdown("Method", ("whole_body", "task_space"), initial_value="whole_body")
            self.plan_button = gui.add_button("Plan from current pose")
            self.clear_button = gui.add_button("Clear obstacles")
            self.time_slider = gui.add_slider("Time (s)", min=0.0, max=1.0, step=0.02, initial_value=0.0)
            self.play_toggle = gui.add_checkbox("Play", False)
            self.status = gui.add_markdown("")
        with gui.add_folder("Costmap", expand_by_default=False):
            self.valid_x = gui.add_number("x (m)", initial_value=0.0, step=0.05)
            self.valid_y = gui.add_number("y (m)", initial_value=0.0, step=0.05)
            self.valid_yaw = gui.add_number("yaw (rad)", initial_value=0.0, step=0.05)
            self.valid_button = gui.add_button("Find valid pose")
            self.valid_status = gui.add_markdown("")
        self.influence_toggle.on_update(lambda _: self.scene.set_influence(visible=self.influence_toggle.value))
        for control in (self.arrows_toggle, self.slice_height, self.arrow_density):
            control.on_update(lambda _: self._field_dirty.set())
        self.time_slider.on_update(lambda _: self.scene.set_time(float(self.time_slider.value)))
        self.plan_button.on_click(lambda _: self._start(self.plan_from_current_pose, "pfield-view-plan"))
        self.clear_button.on_click(lambda _: self._start(self.clear_obstacles, "pfield-view-clear"))
        self.valid_button.on_click(lambda _: self._start(self._find_valid_pose_clicked, "pfield-view-valid"))

    def _say(self, text: str) -> None:
        self.status.content = text

    # ---- framing --------------------------------------------------------------------------------------
    def frame_scene(self) -> NDArray[np.float64]:
        """Fit the view to what is shown and return its bounds (see :attr:`bounds`).

        The initial camera (where a page opens, where "Reset view" returns, and the HTML export's view) frames
        the box of the robot as drawn (and at the end of its trajectory), the obstacles, the goal, the path
        and the origin (the robot's root, on the ground); the ground grid lies under it, the field arrows
        cover its footprint and the *Slice height* slider spans its heights. An open page's camera is left
        where its user put it. Called whenever the shown content changes (not as the robot plays).
        """
        with self._frame_lock:
            bounds = self.scene.bounds()
            if bounds is None:
                bounds = DEFAULT_BOUNDS.copy()
            else:  # and the origin: the robot's root, where it stands (a pedestal has no mesh of its own)
                bounds = np.array([np.minimum(bounds[0], 0.0), np.maximum(bounds[1], 0.0)])
            self.bounds = bounds
            camera = self.server.initial_camera
            position, look_at = camera_pose(bounds, camera.fov)
            if self._changed("camera", np.concatenate([position, look_at])):
                camera.position = position
                camera.look_at = look_at
            centre, width, height = grid_placement(bounds)
            if self._changed("grid", np.array([*centre, width, height])):
                self.server.scene.add_grid("/ground", width=width, height=height, cell_size=0.1, position=centre,
                                           plane="xy")
            self._fit_slice_slider(bounds)
            return bounds

    def _changed(self, key: str, value: NDArray[np.float64]) -> bool:
        old = self._framed.get(key)
        if old is not None and np.allclose(old, value, atol=1e-3):
            return False
        self._framed[key] = value
        return True

    def _fit_slice_slider(self, bounds: NDArray[np.float64]) -> None:
        low, high = height_range(bounds)
        slider = self.slice_height
        value = float(slider.value)
        if self._auto_slice is not None and abs(value - self._auto_slice) > 1e-9:
            self._auto_slice = None  # moved by the user: keep it there
        if self._auto_slice is not None and self.goal is not None:
            value = float(self.goal.position[2])
        value = round(float(np.clip(value, low, high)), 2)
        if (slider.min, slider.max) != (low, high):
            slider.min, slider.max = low, high  # type: ignore[misc]
        if value != float(slider.value):
            slider.value = value  # type: ignore[misc]
            self._field_dirty.set()
        if self._auto_slice is not None:
            self._auto_slice = value

    # ---- scene content --------------------------------------------------------------------------------
    def set_obstacles(self, obstacles: Sequence[Any]) -> None:
        self.scene.set_obstacles(obstacles)
        self.frame_scene()
        self._field_dirty.set()

    def set_goal(self, pose: Pose | None) -> None:
        self.goal = pose
        self.scene.set_goal(pose)
        self.frame_scene()
        self._field_dirty.set()

    def set_path(self, path: PlannedPath) -> None:
        """Show ``path``: its end-effector line and triads and, for a whole-body plan, the robot along it."""
        self.path_arrays = (path.positions, path.orientations)
        self.scene.set_path(path.positions, path.orientations)
        if path.joint_positions is not None and self.scene.has_robot:
            self._set_trajectory(path.times, path.joint_positions)
        self.frame_scene()
        self._field_dirty.set()

    def show_path_arrays(self, positions: NDArray[np.float64], orientations: NDArray[np.float64]) -> None:
        """Show an end-effector path given as arrays (a node's ``nav_msgs/Path``), without a trajectory."""
        self.path_arrays = (positions, orientations)
        self.scene.set_path(positions, orientations)
        self.frame_scene()
        self._field_dirty.set()

    def _set_trajectory(self, times: NDArray[np.float64], joints: NDArray[np.float64]) -> None:
        self.scene.set_trajectory(times, joints)
        self.time_slider.max = max(float(times[-1]), 0.02)
        self.time_slider.value = 0.0  # type: ignore[misc]

    def show_plan(self, path: PlannedPath, obstacles: Sequence[Any] = (), goal: Pose | None = None) -> Viewer:
        """Offline: show ``path``, ``obstacles`` and ``goal`` (default: the plan's last pose)."""
        self.set_obstacles(obstacles)
        self.scene.set_influence(distance=self.config.influence_distance)
        self.set_goal(goal or path.final_pose)
        self.set_path(path)
        return self

    def set_time(self, t: float) -> None:
        """Move the time slider (and the robot) to ``t`` s of the whole-body plan."""
        self.time_slider.value = float(np.clip(t, 0.0, self.time_slider.max))  # type: ignore[misc]
        self.scene.set_time(float(self.time_slider.value))

    # ---- field arrows ---------------------------------------------------------------------------------
    def current_field(self) -> Any:
        """The :class:`PotentialField` of the shown goal, obstacles and parameters (None without a goal)."""
        from pfield.field import PotentialField

        return None if self.goal is None else PotentialField(self.config, self.goal, self.scene.obstacles)

    def refresh_field(self) -> None:
        """Recompute and redraw the field arrows now (the GUI controls do this in the background)."""
        field = self.current_field() if self.arrows_toggle.value else None
        if field is None:
            self.scene.set_field_arrows(None, None)
        else:
            bounds = scene_bounds([self.bounds])  # the framed scene's footprint (and a margin)
            starts, vectors = field_slice(field, bounds, float(self.slice_height.value),
                                          int(self.arrow_density.value))
            self.scene.set_field_arrows(starts, vectors)
        self.field_generation += 1

    def _field_worker(self) -> None:
        while not self._closed.is_set():
            if not self._field_dirty.wait(0.2):
                continue
            time.sleep(0.05)  # let a burst of changes (a drag) settle into one redraw
            self._field_dirty.clear()
            try:
                self.refresh_field()
            except Exception:
                _log.exception("drawing the field arrows failed")

    def _play_worker(self) -> None:
        step = 0.05
        while not self._closed.wait(step):
            if self.play_toggle.value and self.scene.duration > 0:
                t = float(self.time_slider.value) + step
                self.set_time(0.0 if t > self.scene.duration else t)

    # ---- live link ------------------------------------------------------------------------------------
    def connect(self, url: str, token: str | None = None, resolver: Any = None) -> Viewer:
        """Follow the node at ``url`` (see the module docstring); ``resolver`` reads mesh URIs."""
        from pfield.geometry import ResourceResolver
        from pfield.viz._viewer_link import NodeLink
        from pfield.viz._viewer_live import LiveState

        self.live = LiveState(self, ObstacleTracker(resolver or ResourceResolver.default()))
        self.link = NodeLink(url, LIVE_TOPICS, self.live.on_message, token=token)
        self.live.load_parameters()
        self.link.start()
        return self

    def find_valid_pose(self, x: float, y: float, yaw: float, dist_tolerance: float = 1.0,
                        angle_tolerance: float = math.pi) -> dict[str, Any]:
        """Ask the node's ``/pfield/find_valid_pose`` (global costmap) for the closest valid pose to
        ``(x, y, yaw)`` (m, rad, map frame), draw the answer on the costmap and return the response."""
        if self.link is None:
            raise InvalidInput("url", None, "FindValidPose needs a node: connect the viewer first")
        from pfield.interfaces.convert import pose_to_msg

        request = {"pose": {"pose": pose_to_msg(Pose.planar(x, y, yaw)).model_dump()},
                   "dist_tolerance": dist_tolerance, "angle_tolerance": angle_tolerance, "costmap": 2}
        response = self.link.call("/pfield/find_valid_pose", request)
        answer = pose_of(response.get("pose", {}).get("pose", {}))
        self.valid_pose = (float(answer.position[0]), float(answer.position[1]), answer.yaw)
        if self.live is not None and self.live.grid is not None:
            self.show_costmap(self.live.grid, self.valid_pose)
        return response

    def _find_valid_pose_clicked(self) -> None:
        try:
            response = self.find_valid_pose(float(self.valid_x.value), float(self.valid_y.value),
                                            float(self.valid_yaw.value))
        except Exception as exc:
            self.valid_status.content = f"failed: {exc}"
            return
        x, y, yaw = self.valid_pose or (0.0, 0.0, 0.0)
        self.valid_status.content = f"state {response.get('state')}, cost {response.get('cost')}: " \
                                    f"({x:.2f}, {y:.2f}, {yaw:.2f})"

    def show_costmap(self, grid: Any, valid_pose: tuple[float, float, float] | None = None) -> None:
        """Draw an :class:`~pfield.costmap.map_io.OccupancyMap` on the ground (free white, occupied black,
        unknown blue) and a FindValidPose answer ``(x, y, yaw)``."""
        values = np.asarray(grid.data, dtype=np.float64)
        grey = (255 - np.clip(values, 0, 100) * 2.55).astype(np.uint8)
        rgb = np.stack([grey, grey, grey], axis=-1)
        rgb[values < 0] = (120, 150, 220)
        self.scene.set_costmap(rgb, grid.resolution, grid.origin[:2], valid_pose)

    def _on_goal_dragged(self, pose: Pose) -> None:
        self.moved_at = time.monotonic()
        self.goal = pose
        self._field_dirty.set()
        if self.link is not None:
            from pfield.interfaces.convert import pose_to_msg

            self.link.publish_latest("/pfield/planning_goal_pose",
                                     {"header": {"frame_id": ""}, "pose": pose_to_msg(pose).model_dump()})

    # ---- buttons --------------------------------------------------------------------------------------
    def plan_from_current_pose(self) -> PlannedPath | None:
        """Plan from the robot's shown configuration (or the path's start) to the goal: through the node's
        ``/pfield/plan_path`` when live, else locally. Returns the local plan (None when live or failed)."""
        if self.goal is None:
            self._say("no goal: drag the goal gizmo or publish /pfield/planning_goal_pose")
            return None
        method = str(self.method.value) if self.scene.has_robot else "task_space"
        q = self.scene.configuration
        if q is not None:
            start = self.robot.forward_kinematics(q)
        else:
            start = Pose(self.path_arrays[0][0]) if self.path_arrays is not None else Pose()
        self._say(f"planning ({method}) ...")
        try:
            if self.link is not None:
                self._plan_on_node(method, start, q)
                return None
            field = self.current_field()
            if method == "whole_body":
                path = field.plan_whole_body(self.robot, q, 0.02, 0.01, 30000)
            else:
                path = field.plan(start=start, dt=0.02, goal_tolerance=0.01, max_iterations=30000)
        except Exception as exc:
            self._say(f"planning failed: {exc}")
            return None
        self.set_path(path)
        self._say(f"{method}: {'reached' if path.success else path.failure_reason} ({path.duration:.2f} s)")
        return path

    def _plan_on_node(self, method: str, start: Pose, q: NDArray[np.float64] | None) -> None:
        from pfield.interfaces.convert import pose_to_msg

        assert self.goal is not None
        request = {"start": pose_to_msg(start).model_dump(), "goal": pose_to_msg(self.goal).model_dump(),
                   "starting_joint_angles": [] if q is None else [float(v) for v in q],
                   "delta_time": 0.02, "goal_tolerance": 0.01, "max_iterations": 0, "planning_method": method}
        response = self.link.call("/pfield/plan_path", request)
        trajectory = response.get("joint_trajectory", {})
        points = trajectory.get("points", [])
        if points and self.robot is not None:
            order = [list(trajectory["joint_names"]).index(name) for name in self.robot.joint_names]
            joints = np.array([[p["positions"][i] for i in order] for p in points])
            times = np.array([p["time_from_start"]["sec"] + 1e-9 * p["time_from_start"]["nanosec"] for p in points])
            self._set_trajectory(times, joints)
        positions, orientations = path_arrays(response.get("end_effector_path", {}))
        self.show_path_arrays(positions, orientations)
        self._say(f"{method}: {'reached' if response.get('success') else response.get('error_message')}")

    def clear_obstacles(self) -> None:
        """Clear the node's obstacles (live) or the shown ones (offline)."""
        if self.link is None:
            self.set_obstacles([])
            return
        try:
            self._say(self.link.call("/pfield/clear_obstacles", {}).get("message", ""))
        except Exception as exc:
            self._say(f"clear failed: {exc}")

    # ---- export and shutdown --------------------------------------------------------------------------
    def export_html(self, target: str | Path, frames: int = 120) -> Path:
        """Write the scene as a self-contained HTML page; a whole-body plan plays in ``frames`` steps."""
        serializer = self.server.get_scene_serializer()
        duration = self.scene.duration
        if duration > 0:
            for t in np.linspace(0.0, duration, frames):
                self.scene.set_time(float(t))
                serializer.insert_sleep(duration / max(frames - 1, 1))
        path = Path(target)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(serializer.as_html(), encoding="utf-8")
        return path

    def close(self) -> None:
        self._closed.set()
        if self.link is not None:
            self.link.close()
        for thread in self._workers:
            thread.join(timeout=3.0)
        self._stop_server()

    def _stop_server(self) -> None:
        if self._gate is not None:
            self._gate.stop()
        self.server.stop()

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def show_plan(path: PlannedPath, obstacles: Sequence[Any] = (), robot: Any = None, *, goal: Pose | None = None,
              host: str = "127.0.0.1", port: int = 8080, block: bool = True) -> Viewer:
    """Serve a page of ``path`` (and ``obstacles``, ``robot``); with ``block`` wait until Ctrl-C."""
    viewer = Viewer(robot, host=host, port=port).show_plan(path, obstacles, goal)
    if block:
        _log.info("viewer on %s (Ctrl-C to stop)", viewer.url)
        try:
            while True:
                time.sleep(1.0)
        except KeyboardInterrupt:
            viewer.close()
    return viewer


def export_html(target: str | Path, path: PlannedPath, obstacles: Sequence[Any] = (), robot: Any = None, *,
                goal: Pose | None = None, config: FieldConfig | None = None) -> Path:
    """Write a self-contained HTML page of ``path`` with ``obstacles`` and ``robot`` to ``target``.

    The page needs no server (open it from disk); a whole-body plan plays the robot along it."""
    with Viewer(robot, port=0, config=config) as viewer:
        viewer.show_plan(path, obstacles, goal)
        viewer.refresh_field()
        return viewer.export_html(target)
