"""The 3D viewer in a real browser: Debian's headless chromium shows a viewer that follows a real
``pfield serve`` on 127.0.0.1; screenshots are checked pixel by pixel and kept in build/test-artifacts/.

Obstacles must appear at their projected centres in their colours, a newly published obstacle must appear,
dragging the goal gizmo with the mouse must publish a goal the node receives, and the robot must be drawn
and move with the time slider. A URDF robot of the user's own (the UR5 standing on a 0.91 m pedestal) must be
in the camera's view, live and in the HTML export, with the slice-height slider spanning its scene.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from _chromium import Browser, chromium_available
from _ur5 import START, UR5, joint_plan, load_ur5, look_at_camera, project, skeleton_box, table_scene
from numpy.typing import NDArray

from serve_process import pfield_serve

ARTIFACTS = Path(__file__).resolve().parents[2] / "build" / "test-artifacts"
README_IMAGE = Path(__file__).resolve().parents[2] / "docs" / "img" / "viewer.png"
"""The README's screenshot: rewritten only when PFIELD_UPDATE_DOCS_IMAGES=1 (a test run leaves tracked files
alone); otherwise the same picture goes to the artefacts."""
WAIT = 120.0
"""s to wait for the page to show something (software WebGL on 2 shared cores is slow)."""

pytestmark = pytest.mark.slow


def _obstacle(frame_id: str, kind: str, position: tuple[float, float, float], **sizes: Any) -> dict[str, Any]:
    x, y, z = position
    return {"frame_id": frame_id, "type": kind, "group": "Static",
            "pose": {"position": {"x": x, "y": y, "z": z}, "orientation": {"w": 1.0}}, **sizes}


def _scene(mesh: Path) -> list[dict[str, Any]]:
    """One obstacle of each of the six shapes, spread out so that none hides another."""
    return [
        _obstacle("ball", "Sphere", (0.25, 0.35, 0.12), radius=0.07),
        _obstacle("crate", "Box", (0.55, 0.35, 0.1), length=0.12, width=0.12, height=0.2),
        _obstacle("pitcher", "Cylinder", (0.85, 0.35, 0.12), radius=0.06, height=0.24),
        _obstacle("egg", "Ellipsoid", (0.25, 0.75, 0.12), semi_x=0.09, semi_y=0.06, semi_z=0.05),
        _obstacle("pill", "Capsule", (0.55, 0.75, 0.12), radius=0.05, height=0.12),
        _obstacle("rock", "Mesh", (0.85, 0.75, 0.12), mesh_resource=f"file://{mesh}", scale_x=1.5, scale_y=1.0,
                  scale_z=0.8),
    ]


@pytest.fixture(scope="module")
def node(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, Path]]:
    """A real ``pfield serve`` on 127.0.0.1 (its own process) and a folder it may read meshes from."""
    import trimesh

    folder = tmp_path_factory.mktemp("meshes")
    trimesh.creation.icosphere(subdivisions=2, radius=0.06).export(folder / "rock.stl")
    with pfield_serve("--mesh-root", str(folder), "--log-level", "warning",
                      log=tmp_path_factory.mktemp("serve") / "serve.log") as (url, _):
        yield url, folder


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    assert chromium_available(), "Debian's chromium is needed (make test installs it: apt-get install chromium)"
    instance = Browser()
    yield instance
    instance.close()


@pytest.fixture(scope="module")
def live(node: tuple[str, Path], browser: Browser) -> Iterator[Any]:
    """A viewer following the node, shown in the browser, with the six obstacles and a goal published."""
    from pfield.geometry import ResourceResolver
    from pfield.robot import RobotModel
    from pfield.viz.viewer import Viewer

    url, folder = node
    post = httpx.Client(base_url=url, trust_env=False, timeout=60)
    assert post.post("/topic/pfield/obstacles", json={"obstacles": _scene(folder / "rock.stl")}).status_code == 200
    goal = {"pose": {"position": {"x": 0.35, "y": 0.0, "z": 0.45}, "orientation": {"x": 1.0, "w": 0.0}}}
    assert post.post("/topic/pfield/planning_goal_pose", json=goal).status_code == 200
    viewer = Viewer(RobotModel.builtin("xarm7"), port=0)
    viewer.arrows_toggle.value = False  # type: ignore[misc]
    viewer.connect(url, resolver=ResourceResolver(allowed_roots=[folder]))
    _until(lambda: len(viewer.scene.obstacles) == 6, "the viewer never showed the six obstacles")
    browser.open(viewer.url)
    _until(lambda: len(viewer.server.get_clients()) == 1, "the page never connected to the viewer")
    viewer.post = post  # type: ignore[attr-defined]
    yield viewer
    viewer.close()
    post.close()


def _until(condition: Callable[[], Any], message: str, timeout: float = WAIT) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.25)
    raise AssertionError(message)


def _camera(viewer: Any) -> Any:
    """A snapshot of the page's camera (position, wxyz, vertical fov), as the page last reported it."""
    from types import SimpleNamespace

    camera = next(iter(viewer.server.get_clients().values())).camera
    return SimpleNamespace(position=np.array(camera.position), wxyz=np.array(camera.wxyz), fov=float(camera.fov))


def _initial_camera(viewer: Any) -> Any:
    """The viewer's initial camera (where a page and the HTML export open) as :func:`_camera` gives one."""
    from types import SimpleNamespace

    from pfield.spatial import quaternion_from_matrix

    initial = viewer.server.initial_camera
    x, y, z, w = quaternion_from_matrix(look_at_camera(initial.position, initial.look_at))
    return SimpleNamespace(position=np.array(initial.position), wxyz=np.array([w, x, y, z]), fov=float(initial.fov))


def _project(camera: Any, point: NDArray[np.float64], width: int, height: int) -> tuple[int, int] | None:
    """Pixel (column, row) of a world point for viser's camera (OpenCV axes: x right, y down, z forward;
    ``fov`` vertical)."""
    from pfield.spatial import Pose

    w, x, y, z = camera.wxyz
    world_from_camera = Pose(camera.position, (x, y, z, w))
    local = world_from_camera.inverse() * Pose(point)
    cx, cy, cz = local.position
    if cz <= 0:
        return None
    focal = (height / 2) / math.tan(camera.fov / 2)
    return round(width / 2 + focal * cx / cz), round(height / 2 + focal * cy / cz)


def _shows_colour(image: NDArray[np.uint8], pixel: tuple[int, int], colour: tuple[int, int, int]) -> bool:
    """True when the 5×5 patch at ``pixel`` has the hue of ``colour`` (shading changes brightness only):
    the chroma vectors (colour minus its grey level) point the same way and the patch is saturated."""
    col, row = pixel
    patch = np.median(image[row - 2:row + 3, col - 2:col + 3].reshape(-1, 3).astype(float), axis=0)
    target = np.asarray(colour, dtype=float)
    chroma, want = patch - patch.mean(), target - target.mean()
    if np.ptp(patch) < 25:
        return False
    return float(chroma @ want / (np.linalg.norm(chroma) * np.linalg.norm(want))) > 0.9


def _canvas(browser: Browser) -> tuple[float, float, float, float]:
    """left, top, width, height of the page's 3D canvas (px)."""
    rect = browser.evaluate("(() => { const c = [...document.querySelectorAll('canvas')].sort((a, b) => "
                            "b.width * b.height - a.width * a.height)[0]; if (!c) return null; "
                            "const r = c.getBoundingClientRect(); return [r.left, r.top, r.width, r.height]; })()")
    return tuple(rect) if rect else (0.0, 0.0, float(browser.width), float(browser.height))


def _obstacles_visible(viewer: Any, image: NDArray[np.uint8], browser: Browser | None = None,
                       camera: Any = None) -> dict[str, bool]:
    camera = camera or _camera(viewer)
    left, top, width, height = _canvas(browser) if browser is not None else (0, 0, image.shape[1], image.shape[0])
    result = {}
    for obstacle in viewer.scene.obstacles:
        pixel = _project(camera, np.asarray(obstacle.pose.position), round(width), round(height))
        if pixel is not None:
            pixel = (pixel[0] + round(left), pixel[1] + round(top))
        result[obstacle.id] = pixel is not None and _shows_colour(image, pixel, viewer.scene.colour_of(obstacle.id))
    return result


def _screens_until(browser: Browser, viewer: Any, name: str, check: Callable[[NDArray[np.uint8]], bool]
                   ) -> NDArray[np.uint8]:
    """Screenshots until ``check(image)`` holds; the last one is saved as ``name``."""
    deadline = time.monotonic() + WAIT
    while True:
        browser.dismiss_notifications()
        image = browser.screenshot(ARTIFACTS / name)
        if check(image) or time.monotonic() > deadline:
            return image
        time.sleep(1.0)


def test_obstacles_appear_at_their_projections_in_their_colours(live: Any, browser: Browser) -> None:
    image = _screens_until(browser, live, "viewer_obstacles.png", lambda im: all(_obstacles_visible(live, im).values()))
    shown = _obstacles_visible(live, image)
    assert shown == {key: True for key in ("ball", "crate", "pitcher", "egg", "pill", "rock")}, shown
    rock = next(o for o in live.scene.obstacles if o.id == "rock")
    assert (rock.shape.scale_x, rock.shape.scale_y, rock.shape.scale_z) == pytest.approx((1.5, 1.0, 0.8))
    pill = next(o for o in live.scene.obstacles if o.id == "pill")
    assert type(pill.shape).__name__ == "Capsule"  # its exact shape, not the marker's bounding cylinder


def test_an_obstacle_published_through_the_node_appears(live: Any, browser: Browser) -> None:
    new = _obstacle("newcomer", "Sphere", (0.55, 0.05, 0.1), radius=0.06)
    assert live.post.post("/topic/pfield/obstacles", json={"obstacles": [new]}).status_code == 200
    _until(lambda: any(o.id == "newcomer" for o in live.scene.obstacles), "the viewer never got the new obstacle")
    image = _screens_until(browser, live, "viewer_new_obstacle.png",
                           lambda im: _obstacles_visible(live, im).get("newcomer", False))
    assert _obstacles_visible(live, image)["newcomer"]


def _drag(browser: Browser, start: tuple[int, int], end: tuple[int, int], steps: int = 12) -> None:
    browser.send("Input.dispatchMouseEvent", type="mouseMoved", x=start[0], y=start[1])
    browser.send("Input.dispatchMouseEvent", type="mousePressed", x=start[0], y=start[1], button="left",
                 clickCount=1, buttons=1)
    for k in range(1, steps + 1):
        x = start[0] + (end[0] - start[0]) * k / steps
        y = start[1] + (end[1] - start[1]) * k / steps
        browser.send("Input.dispatchMouseEvent", type="mouseMoved", x=x, y=y, button="left", buttons=1)
        time.sleep(0.05)
    browser.send("Input.dispatchMouseEvent", type="mouseReleased", x=end[0], y=end[1], button="left",
                 clickCount=1, buttons=0)


def test_dragging_the_goal_gizmo_publishes_a_goal_the_node_receives(live: Any, browser: Browser) -> None:
    before = live.goal
    assert before is not None and np.allclose(before.position, (0.35, 0.0, 0.45))
    camera = _camera(live)
    # Drag the gizmo's x arrow (the goal's x axis = world x: the goal is turned 180° about x) by 0.2 m.
    grab = _project(camera, np.asarray(before.position) + np.array([0.075, 0.0, 0.0]), browser.width, browser.height)
    drop = _project(camera, np.asarray(before.position) + np.array([0.275, 0.0, 0.0]), browser.width, browser.height)
    assert grab is not None and drop is not None
    _drag(browser, grab, drop, steps=20)
    browser.screenshot(ARTIFACTS / "viewer_goal_dragged.png")

    def node_goal() -> Any:
        markers = live.post.get("/topic/pfield/markers").json()["markers"]
        goal = next((m for m in markers if m.get("ns") == "goal"), None)
        return goal if goal and goal["pose"]["position"]["x"] > 0.4 else None

    goal = _until(node_goal, "the node never received a goal moved along x")
    position = goal["pose"]["position"]
    # Dragged along x only: y and z are unchanged, x moved by about the 0.2 m of the drag.
    assert position["y"] == pytest.approx(0.0, abs=1e-9) and position["z"] == pytest.approx(0.45, abs=1e-9)
    assert position["x"] == pytest.approx(0.55, abs=0.05)
    assert np.allclose(live.goal.position, (position["x"], 0.0, 0.45), atol=1e-6)  # the viewer's goal agrees


def test_the_robot_is_drawn_and_moves_with_the_time_slider(live: Any, browser: Browser) -> None:
    from pfield.interfaces.convert import pose_to_msg
    from pfield.spatial import Pose

    robot = live.robot
    goal = Pose((0.3, -0.25, 0.35), (1.0, 0.0, 0.0, 0.0))
    message = {"pose": pose_to_msg(goal).model_dump()}
    posted = [0.0]

    def goal_shown() -> bool:
        # Publish again every 5 s until the viewer shows it: on a loaded machine the page's last gizmo events
        # of the drag before may still reach the node after a single publish.
        if time.monotonic() - posted[0] > 5.0:
            assert live.post.post("/topic/pfield/planning_goal_pose", json=message).status_code == 200
            posted[0] = time.monotonic()
        return live.goal is not None and bool(np.allclose(live.goal.position, goal.position))

    _until(goal_shown, "goal not shown")
    q0 = np.array([0.0, -0.6, 0.0, 0.7, 0.0, 1.3, 0.0])
    live.scene.set_configuration(q0)
    live.method.value = "whole_body"  # type: ignore[misc]
    live.plan_from_current_pose()
    assert live.scene.duration > 0.1, live.status.content
    live.set_time(0.0)
    start_image = _screens_until(browser, live, "viewer_robot_start.png", lambda im: True)
    time.sleep(2.0)
    start_image = browser.screenshot(ARTIFACTS / "viewer_robot_start.png")

    # Drag the "Time (s)" slider to its end with the mouse.
    rect = browser.evaluate("""(() => { for (const label of document.querySelectorAll('label, p, div')) {
        if (label.textContent.trim() === 'Time (s)' && label.children.length === 0) {
          let box = label.parentElement; for (let i = 0; i < 4 && box; i++, box = box.parentElement) {
            const root = box.querySelector('.mantine-Slider-root');
            if (root) { const r = root.getBoundingClientRect(); return [r.left, r.top, r.width, r.height]; } } } }
        return null; })()""")
    assert rect is not None, "no Time (s) slider on the page"
    left, top, span, tall = rect
    _drag(browser, (int(left + 3), int(top + tall / 2)), (int(left + span + 20), int(top + tall / 2)))
    _until(lambda: live.time_slider.value >= live.scene.duration - 0.03, "the slider did not reach the end")
    assert live.scene.configuration is not None
    final = robot.forward_kinematics(live.scene.configuration).position
    assert np.linalg.norm(final - goal.position) < 0.03  # the robot is posed at the plan's end
    time.sleep(2.0)
    end_image = browser.screenshot(ARTIFACTS / "viewer_robot_end.png")

    camera = _camera(live)
    changed = np.abs(end_image.astype(int) - start_image.astype(int)).sum(axis=2) > 60
    ee_start = _project(camera, robot.forward_kinematics(q0).position, browser.width, browser.height)
    ee_end = _project(camera, final, browser.width, browser.height)
    assert ee_start is not None and ee_end is not None
    for col, row in (ee_start, ee_end):  # the arm left its start and reached the end: pixels changed there
        assert changed[row - 15:row + 16, col - 15:col + 16].mean() > 0.1
    # Drawn: where the arm stands at the end, the picture is darker than the white background.
    col, row = ee_end
    assert end_image[row - 6:row + 7, col - 6:col + 7].mean() < 235


def test_readme_screenshot_and_html_export(live: Any, browser: Browser, tmp_path: Path) -> None:
    live.arrows_toggle.value = True  # type: ignore[misc]
    live.slice_height.value = 0.12  # type: ignore[misc]
    generation = live.field_generation
    live.refresh_field()
    assert live.field_generation > generation
    time.sleep(3.0)
    target_image = README_IMAGE if os.environ.get("PFIELD_UPDATE_DOCS_IMAGES") == "1" else ARTIFACTS / "viewer.png"
    target_image.parent.mkdir(parents=True, exist_ok=True)
    image = browser.screenshot(target_image)
    assert image.shape[:2] == (browser.height, browser.width)

    live.arrows_toggle.value = False  # type: ignore[misc]  # arrows at the obstacles' height would hide centres
    live.refresh_field()
    target = live.export_html(ARTIFACTS / "viewer_export.html")
    text = target.read_text()
    assert "__VISER_EMBED_DATA__" in text and "http://" not in text.split("__VISER_EMBED_DATA__")[1][:200]
    # The page opens at the viewer's initial camera: the view of everything shown now (the live page's camera
    # stayed where that page opened, before the plan was made and the goal dragged).
    camera = _initial_camera(live)
    browser.open(target.as_uri())

    def shown(im: NDArray[np.uint8]) -> dict[str, bool]:
        return _obstacles_visible(live, im, browser, camera)

    exported = _screens_until(browser, live, "viewer_export.png", lambda im: all(shown(im).values()))
    assert all(shown(exported).values()), shown(exported)


def test_a_page_with_a_token_loads_in_the_browser(browser: Browser) -> None:
    """The token in the URL admits the page, and the cookie it sets admits the page's own WebSocket."""
    from pfield.viz.viewer import Viewer

    with Viewer(None, port=0, token="s3cret") as viewer:
        browser.open(viewer.url)
        _until(lambda: len(viewer.server.get_clients()) == 1, "the page never connected through the gate")


SLIDER_RANGE = """(() => { for (const label of document.querySelectorAll('label, p, div')) {
    if (label.textContent.trim() === 'Slice height (m)' && label.children.length === 0) {
      let box = label.parentElement; for (let i = 0; i < 4 && box; i++, box = box.parentElement) {
        const thumb = box.querySelector('[role=slider]');
        if (thumb) return ['aria-valuemin', 'aria-valuemax', 'aria-valuenow'].map(a => thumb.getAttribute(a)); } } }
    return null; })()"""
"""The page's *Slice height (m)* slider: its min, max and value as the browser shows them."""


def _drawn(image: NDArray[np.uint8], pixel: tuple[float, float]) -> bool:
    """True when the 7×7 patch at ``pixel`` is darker than the page's white background (something is drawn)."""
    col, row = round(pixel[0]), round(pixel[1])
    return bool(image[row - 3:row + 4, col - 3:col + 4].mean() < 235)


@pytest.mark.skipif(not UR5.exists(), reason="the UR5 files are not in ../shared")
def test_a_raised_ur5_is_in_view_and_the_slider_covers_its_scene(browser: Browser) -> None:
    """The UR5 stands on a 0.91 m pedestal and points up to 1.92 m over a MotionBenchMaker table: the page opens
    with the whole arm in view (every corner of its box projects inside the canvas and the arm is drawn at its
    joints), the slice-height slider spans the scene, and the HTML export opens on the same view."""
    from pfield.viz.viewer import Viewer

    robot = load_ur5()
    with Viewer(robot, port=0) as viewer:
        viewer.show_plan(joint_plan(robot), table_scene())
        viewer.refresh_field()
        browser.open(viewer.url)
        _until(lambda: len(viewer.server.get_clients()) == 1, "the page never connected to the viewer")

        initial = viewer.server.initial_camera

        def camera_at_start() -> Any:
            """The page's camera once it stands where the page opens (its first report may precede that)."""
            try:
                camera = _camera(viewer)
            except AssertionError:  # the page has not reported its camera yet
                return None
            return camera if np.allclose(camera.position, initial.position, atol=0.02) else None

        camera = _until(camera_at_start, "the page's camera never stood at the viewer's initial camera")
        left, top, width, height = _canvas(browser)
        joints_at_start = robot.joint_frames(START)[1]

        def pixels_of(points: NDArray[np.float64]) -> list[tuple[float, float] | None]:
            found = [_project(camera, point, round(width), round(height)) for point in points]
            return [None if p is None else (p[0] + left, p[1] + top) for p in found]

        def arm_drawn(image: NDArray[np.uint8]) -> bool:
            return all(p is not None and _drawn(image, p) for p in pixels_of(joints_at_start))

        image = _screens_until(browser, viewer, "viewer_ur5.png", arm_drawn)
        corners = pixels_of(skeleton_box(robot, START))
        assert all(p is not None and left <= p[0] < left + width and top <= p[1] < top + height for p in corners), \
            f"the raised UR5 leaves the picture: corners at {corners} in a {width}x{height} canvas"
        assert arm_drawn(image), "the UR5 is not drawn where its joints project"

        low, high, value = (float(v) for v in _until(lambda: browser.evaluate(SLIDER_RANGE),
                                                     "no Slice height (m) slider on the page"))
        top_of_arm = float(skeleton_box(robot, START)[:, 2].max())
        assert low <= 0.0 and high >= top_of_arm > 1.9, (low, high)
        assert low <= value <= high
        target = viewer.export_html(ARTIFACTS / "viewer_ur5_export.html")
        position, look_at, fov = initial.position, initial.look_at, initial.fov

    browser.open(target.as_uri())
    rotation = look_at_camera(position, look_at)

    # The page plays the plan: the shoulder (which barely moves) must be drawn, and the arm's box at every
    # waypoint must project inside the picture (the canvas, above the page's time bar, once it exists).
    shoulder = joints_at_start[:2]

    def exported_arm_drawn(image: NDArray[np.uint8]) -> bool:
        left, top, width, height = _canvas(browser)
        pixels = [project(position, rotation, fov, point, round(width), round(height)) for point in shoulder]
        return all(p is not None and _drawn(image, (p[0] + left, p[1] + top)) for p in pixels)

    exported = _screens_until(browser, None, "viewer_ur5_export.png", exported_arm_drawn)
    assert exported_arm_drawn(exported), "the exported page does not show the UR5 where its shoulder projects"
    left, top, width, height = _canvas(browser)
    for q in joint_plan(robot).joint_positions:
        for corner in skeleton_box(robot, q):
            pixel = project(position, rotation, fov, corner, round(width), round(height))
            assert pixel is not None and 0 <= pixel[0] < width and 0 <= pixel[1] < height
