"""The 3D viewer without a browser: shape meshes, field slice, plan CSV and scene YAML readers, the node's
markers turned back into obstacles, the offline viewer, the HTML export and ``pfield view``'s bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from _ur5 import BASE_HEIGHT, START, UR5, joint_plan, load_ur5, look_at_camera, project, skeleton_box, table_scene
from typer.testing import CliRunner

from pfield import Box, Capsule, Cylinder, Ellipsoid, FieldConfig, Mesh, Obstacle, Pose, PotentialField, Sphere
from pfield.errors import InvalidInput
from pfield.geometry import ResourceResolver
from pfield.planning.result import PlannedPath
from pfield.viz._viewer_shapes import influence_mesh, shape_mesh
from pfield.viz._viewer_state import ObstacleTracker
from pfield.viz.viewer import Viewer, export_html, field_slice, read_plan_csv


def _extents(shape: object, grow: float | None = None) -> np.ndarray:
    vertices, _ = shape_mesh(shape) if grow is None else influence_mesh(shape, grow)
    return vertices.max(axis=0) - vertices.min(axis=0)


def test_shape_meshes_have_the_shapes_sizes() -> None:
    assert _extents(Box(0.1, 0.2, 0.3)) == pytest.approx([0.1, 0.2, 0.3])
    assert _extents(Box(0.1, 0.2, 0.3), 0.05) == pytest.approx([0.2, 0.3, 0.4])
    assert _extents(Sphere(0.1)) == pytest.approx([0.2, 0.2, 0.2], abs=1e-3)
    assert _extents(Ellipsoid(0.1, 0.05, 0.2)) == pytest.approx([0.2, 0.1, 0.4], abs=1e-3)
    assert _extents(Ellipsoid(0.1, 0.05, 0.2), 0.1) == pytest.approx([0.4, 0.3, 0.6], abs=1e-3)
    assert _extents(Cylinder(0.05, 0.3))[2] == pytest.approx(0.3)
    assert _extents(Capsule(0.05, 0.2))[2] == pytest.approx(0.3)  # shaft plus both caps
    assert _extents(Capsule(0.05, 0.2), 0.1)[2] == pytest.approx(0.5)


def test_a_mesh_is_drawn_scaled_and_its_zone_is_its_bounding_sphere_grown(tmp_path: Path) -> None:
    import trimesh

    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(tmp_path / "cube.stl")
    mesh = Mesh(str(tmp_path / "cube.stl"), 2.0, 1.0, 0.5, resolver=ResourceResolver(allowed_roots=[tmp_path]))
    assert _extents(mesh) == pytest.approx([0.2, 0.1, 0.05])
    radius = float(np.linalg.norm([0.1, 0.05, 0.025]))
    assert _extents(mesh, 0.1) == pytest.approx([2 * (radius + 0.1)] * 3, abs=2e-3)


def test_field_slice_arrows_follow_the_fields_twists() -> None:
    obstacle = Obstacle("ball", Sphere(0.05), Pose((0.4, 0.1, 0.2)))
    field = PotentialField(FieldConfig(), Pose((0.5, 0.2, 0.3)), [obstacle])
    starts, vectors = field_slice(field, (0.0, 0.8, -0.4, 0.4), 0.25, 9)
    assert starts.shape == (81, 3) and np.all(starts[:, 2] == 0.25)
    assert starts[0] == pytest.approx([0.0, -0.4, 0.25]) and starts[-1] == pytest.approx([0.8, 0.4, 0.25])
    linear = field.twists(starts)[:, :3]
    cosine = np.sum(linear * vectors, axis=1) / (np.linalg.norm(linear, axis=1) * np.linalg.norm(vectors, axis=1))
    assert cosine == pytest.approx(np.ones(81))
    assert np.max(np.linalg.norm(vectors, axis=1)) == pytest.approx(0.8 * 0.1)  # 0.8 of a 0.1 m cell


@pytest.mark.parametrize(("bounds", "height", "density", "field"), [
    ((0.0, 1.0, 0.0, 1.0), 0.2, 1, "density"),
    ((0.0, 1.0, 0.0, 1.0), 0.2, 2.5, "density"),
    ((0.0, 1.0, 0.0, 1.0), float("nan"), 5, "height"),
    ((1.0, 0.0, 0.0, 1.0), 0.2, 5, "bounds"),
    ((0.0, float("inf"), 0.0, 1.0), 0.2, 5, "bounds[1]"),
])
def test_field_slice_refuses_bad_input(bounds: tuple[float, float, float, float], height: float, density: int,
                                       field: str) -> None:
    plain = PotentialField(FieldConfig(), Pose((0.5, 0.2, 0.3)))
    with pytest.raises(InvalidInput) as error:
        field_slice(plain, bounds, height, density)
    assert error.value.field == field


def _whole_body_plan() -> PlannedPath:
    times = np.array([0.0, 0.02, 0.04])
    return PlannedPath(success=True, failure_reason="", times=times,
                       positions=[[0.3, 0.0, 0.5], [0.31, 0.0, 0.5], [0.32, 0.01, 0.49]],
                       orientations=[[0, 0, 0, 1.0], [0, 0, 0.1, 0.99498743710662], [1.0, 0, 0, 0]],
                       twists=np.full((3, 6), 0.125), clearances=[np.inf, 0.1, 1 / 3], iterations=2,
                       joint_names=("a", "b"), joint_positions=[[0.0, 1.0], [0.1, 0.9], [0.2, 0.8]],
                       joint_velocities=[[5.0, -5.0], [5.0, -5.0], [0.0, 0.0]])


def test_plan_csv_round_trip_is_exact(tmp_path: Path) -> None:
    plan = _whole_body_plan()
    back = read_plan_csv(plan.to_csv(tmp_path / "plan.csv"))
    for name in ("times", "positions", "orientations", "twists", "clearances", "joint_positions",
                 "joint_velocities"):
        assert np.array_equal(getattr(back, name), getattr(plan, name)), name
    assert back.joint_names == ("a", "b") and back.success and back.iterations == 2


@pytest.mark.parametrize(("text", "reason"), [
    ("", "header row"),
    ("time,x,y\n0,1,2\n", "first columns"),
    ("time,x,y,z,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz,clearance\n0,0,0,0,0,0,0,1,0,0,0,0,0,0,abc\n", "not a number"),
    ("time,x,y,z,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz,clearance\n0,0,0\n", "15 values"),
])
def test_a_bad_plan_csv_is_refused_naming_the_file(tmp_path: Path, text: str, reason: str) -> None:
    source = tmp_path / "bad.csv"
    source.write_text(text)
    with pytest.raises(InvalidInput, match=reason) as error:
        read_plan_csv(source)
    assert error.value.field == "plan"
    with pytest.raises(InvalidInput, match="cannot read"):
        read_plan_csv(tmp_path / "missing.csv")


def test_markers_and_obstacle_messages_give_the_nodes_obstacles() -> None:
    from pfield.interfaces.convert import obstacle_to_msg
    from pfield.node._markers import state_markers

    pill = Obstacle("pill", Capsule(0.05, 0.2), Pose((0.4, 0.1, 0.2)), group="Dynamic")
    egg = Obstacle("egg", Ellipsoid(0.1, 0.05, 0.2), Pose((0.2, 0.0, 0.3), (0, 0, 1.0, 0)))
    markers = state_markers("world", Pose((0.5, 0.2, 0.4)), [pill, egg], 0.1).model_dump()
    tracker = ObstacleTracker(ResourceResolver.default())
    shown, goal = tracker.from_markers(markers)
    assert goal == Pose((0.5, 0.2, 0.4))
    # Known only from its marker, a capsule is its bounding cylinder; the ellipsoid is exact.
    assert [o.id for o in shown] == ["pill", "egg"] and isinstance(shown[0].shape, Cylinder)
    assert (shown[0].shape.radius, shown[0].shape.height) == pytest.approx((0.05, 0.3))
    assert isinstance(shown[1].shape, Ellipsoid) and shown[1].pose == egg.pose
    assert (shown[1].shape.semi_x, shown[1].shape.semi_y, shown[1].shape.semi_z) == pytest.approx((0.1, 0.05, 0.2))
    tracker.add_message({"obstacles": [obstacle_to_msg(pill).model_dump()]})
    shown, _ = tracker.from_markers(markers)
    assert shown[0] == pill


@pytest.fixture(scope="module")
def offline_viewer() -> Viewer:
    from pfield.robot import RobotModel

    viewer = Viewer(RobotModel.builtin("xarm7"), port=0)
    yield viewer
    viewer.close()


def test_offline_viewer_plays_a_whole_body_plan(offline_viewer: Viewer) -> None:
    robot = offline_viewer.robot
    q0 = np.array([0.0, -0.6, 0.0, 0.7, 0.0, 1.3, 0.0])
    obstacles = [Obstacle("ball", Sphere(0.05), Pose((0.5, 0.3, 0.1)))]
    field = PotentialField(FieldConfig(), Pose((0.3, -0.25, 0.35), (1.0, 0, 0, 0)), obstacles)
    plan = field.plan_whole_body(robot, q0, 0.02, 0.01, 3000)
    offline_viewer.show_plan(plan, obstacles, field.goal)
    assert [o.id for o in offline_viewer.scene.obstacles] == ["ball"]
    assert offline_viewer.scene.duration == pytest.approx(plan.duration)
    assert offline_viewer.time_slider.max == pytest.approx(plan.duration)
    k = len(plan) // 2
    offline_viewer.set_time(float(plan.times[k]))
    assert offline_viewer.scene.configuration == pytest.approx(plan.joint_positions[k])
    offline_viewer.set_time(1e9)  # clamped to the end
    assert offline_viewer.scene.configuration == pytest.approx(plan.joint_positions[-1])
    offline_viewer.refresh_field()
    # "Plan from current pose" offline plans locally from the shown configuration (the plan's end).
    replanned = offline_viewer.plan_from_current_pose()
    assert replanned is not None and replanned.joint_positions is not None
    assert replanned.joint_positions[0] == pytest.approx(plan.joint_positions[-1])
    offline_viewer.clear_obstacles()
    assert offline_viewer.scene.obstacles == []


def test_export_html_is_self_contained(tmp_path: Path) -> None:
    obstacles = [Obstacle("ball", Sphere(0.05), Pose((0.5, 0.3, 0.1)))]
    plan = PotentialField(FieldConfig(), Pose((0.5, 0.0, 0.3)), obstacles).plan(
        start=Pose((0.3, 0.0, 0.5)), dt=0.02, goal_tolerance=0.01, max_iterations=2000)
    target = export_html(tmp_path / "page.html", plan, obstacles)
    text = target.read_text()
    assert text.startswith("<!") and "window.__VISER_EMBED_DATA__=" in text
    assert "<script src=\"http" not in text and "<link href=\"http" not in text


SCENE = Path(__file__).resolve().parents[2] / "examples" / "manipulator" / "scene.yaml"


def _view(*args: str) -> object:
    from pfield.cli import app

    return CliRunner().invoke(app, ["view", *args])


def test_pfield_view_exports_an_offline_plan(tmp_path: Path) -> None:
    plan_file = _whole_body_plan().to_csv(tmp_path / "plan.csv")
    out = tmp_path / "out.html"
    result = _view("--plan", str(plan_file), "--scene", str(SCENE), "--robot", "none", "--export", str(out))
    assert result.exit_code == 0, result.output
    assert out.exists() and "__VISER_EMBED_DATA__" in out.read_text()
    assert result.stdout == f"wrote {out}\n"  # not the banner of the throwaway server the page was drawn on


def test_pfield_view_refuses_a_bad_scene(tmp_path: Path) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump({"obstacles": [{"frame_id": "x", "type": "Blob"}]}))
    out = tmp_path / "out.html"
    result = _view("--scene", str(scene), "--robot", "none", "--export", str(out))
    assert result.exit_code == 2 and "obstacles[0].type" in result.output and not out.exists()


@pytest.mark.parametrize(("args", "field"), [
    (["--host", "0.0.0.0"], "--page-token"),
    (["--plan", "/nonexistent/plan.csv"], "plan"),
    (["--robot", "/nonexistent/robot.urdf"], "--end-effector"),
])
def test_pfield_view_refuses_bad_options(args: list[str], field: str) -> None:
    result = _view(*args, "--robot", "none", "--export", "/tmp/never.html") if "--robot" not in args else \
        _view(*args, "--export", "/tmp/never.html")
    assert result.exit_code == 2
    assert "error:" in result.output and field in result.output
    assert not Path("/tmp/never.html").exists()


def test_live_costmap_and_find_valid_pose(tmp_path: Path) -> None:
    """The viewer follows ``pfield serve --map``: the costmap is drawn on the ground, and FindValidPose's
    answer, asked through the viewer, is the node's own answer, drawn where it says."""
    import time

    import httpx

    from serve_process import pfield_serve

    map_file = Path(__file__).resolve().parents[2] / "src" / "pfield" / "data" / "maps" / "example.yaml"
    with pfield_serve("--map", str(map_file), "--footprint", "[[0.2, 0.2], [0.2, -0.2], [-0.2, -0.2], [-0.2, 0.2]]",
                      "--log-level", "warning", log=tmp_path / "serve.log") as (url, _), Viewer(None, port=0) as viewer:
        viewer.connect(url)
        deadline = time.monotonic() + 60
        while viewer.server.scene.get_handle_by_name("/costmap") is None and time.monotonic() < deadline:
            time.sleep(0.1)
        assert viewer.server.scene.get_handle_by_name("/costmap") is not None, "no costmap drawn"
        response = viewer.find_valid_pose(0.0, 0.0, 0.3)
        direct = httpx.post(f"{url}/srv/pfield/find_valid_pose", trust_env=False, json={
            "pose": {"pose": {"position": {"x": 0.0, "y": 0.0},
                              "orientation": {"z": float(np.sin(0.15)), "w": float(np.cos(0.15))}}},
            "dist_tolerance": 1.0, "angle_tolerance": float(np.pi), "costmap": 2}).json()
        assert response == direct
        answer = direct["pose"]["pose"]["position"]
        frame = viewer.server.scene.get_handle_by_name("/valid_pose")
        assert frame is not None and frame.position[:2] == pytest.approx([answer["x"], answer["y"]])


def test_find_valid_pose_needs_a_node(offline_viewer: Viewer) -> None:
    with pytest.raises(InvalidInput, match="needs a node"):
        offline_viewer.find_valid_pose(0.0, 0.0, 0.0)


def test_costmap_image_rows_follow_the_occupancy_grid(offline_viewer: Viewer) -> None:
    from pfield.costmap.map_io import OccupancyMap

    data = np.zeros((4, 6), dtype=np.int8)
    data[0, 0] = 100  # bottom-left cell (row 0 at the bottom) occupied
    data[3, 5] = -1   # top-right cell unknown
    offline_viewer.show_costmap(OccupancyMap(data, 0.5, (-1.0, -2.0, 0.0)), (0.2, 0.3, 0.5))
    image = offline_viewer.server.scene.get_handle_by_name("/costmap")
    assert image is not None
    assert tuple(image.position) == pytest.approx((-1.0 + 1.5, -2.0 + 1.0, -0.001))  # centre of 3 m x 2 m
    assert (image.render_width, image.render_height) == pytest.approx((3.0, 2.0))


def test_a_page_served_with_a_token_admits_only_requests_that_carry_it() -> None:
    import httpx

    with Viewer(None, port=0, token="s3cret") as viewer:
        base = viewer.url.split("?")[0]
        assert viewer.url == base + "?token=s3cret"
        with httpx.Client(trust_env=False, timeout=30) as client:
            refused = client.get(base)
            assert refused.status_code == 401
            assert client.get(base + "?token=wrong").status_code == 401
            admitted = client.get(viewer.url)
            assert admitted.status_code == 200 and "<html" in admitted.text.lower()
            assert "pfield_token=s3cret" in admitted.headers.get("set-cookie", "")
        with httpx.Client(trust_env=False, timeout=30) as client:  # the cookie alone, or the bearer header
            for _ in range(5):  # one client, one request per connection: none is sent down a closing one
                by_cookie = client.get(base, headers={"Cookie": "pfield_token=s3cret"})
                assert by_cookie.status_code == 200 and by_cookie.headers["connection"] == "close"
                assert client.get(base, headers={"Authorization": "Bearer s3cret"}).status_code == 200


def test_a_page_beyond_loopback_needs_a_token() -> None:
    with pytest.raises(InvalidInput, match="needs a token") as error:
        Viewer(None, host="0.0.0.0", port=0)
    assert error.value.field == "host"


def test_the_demo_section_writes_the_html_page(tmp_path: Path) -> None:
    from rich.console import Console

    from pfield.demo import viewer as demo_viewer

    console = Console(record=True, width=200)
    demo_viewer.run(tmp_path, console)
    page = tmp_path / "viewer.html"
    assert page.exists() and "window.__VISER_EMBED_DATA__=" in page.read_text()
    assert str(page) in console.export_text().replace("\n", "")


def test_show_plan_serves_the_plan() -> None:
    import httpx

    from pfield.viz.viewer import show_plan

    plan = _whole_body_plan()
    viewer = show_plan(plan, [Obstacle("ball", Sphere(0.05), Pose((0.5, 0.3, 0.1)))], port=0, block=False)
    try:
        assert [o.id for o in viewer.scene.obstacles] == ["ball"]
        assert viewer.goal == plan.final_pose
        assert httpx.get(viewer.url, trust_env=False, timeout=30).status_code == 200
    finally:
        viewer.close()


# ---- a URDF robot of the user's own: the UR5 with its Robotiq gripper (issue 33, item 4) ------------------------

needs_ur5 = pytest.mark.skipif(not UR5.exists(), reason="the UR5 files are not in ../shared")


@needs_ur5
def test_a_ur5_exports_with_its_package_paths_from_another_directory(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """Loaded with relative package paths in its own folder, the robot draws from anywhere: its package paths
    (made absolute) travel with the model; the viewer guesses none."""
    monkeypatch.chdir(UR5)
    robot = load_ur5({"meshes": "meshes"}, Path("ur5.urdf"))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    target = export_html(tmp_path / "ur5.html", joint_plan(robot), table_scene(), robot)
    assert "window.__VISER_EMBED_DATA__=" in target.read_text()
    assert robot.resolver.package_paths == {"meshes": (UR5 / "meshes").resolve()}
    assert robot.resolve_mesh("meshes/robotiq/outer_knuckle_fine.STL") == \
        (UR5 / "meshes" / "robotiq" / "outer_knuckle_fine.STL").resolve()  # relative: from the URDF's folder
    with Viewer(robot, port=0) as viewer:  # the same robot drawn: every link's visual mesh is in the scene
        assert viewer.scene.has_robot
        meshes = viewer.scene._visual.scene.geometry
        assert len(meshes) >= 7 and all(len(mesh.vertices) > 0 for mesh in meshes.values())


def _ur5_copy(tmp_path: Path) -> Path:
    """A copy of the UR5's folder (the URDF, the SRDF and the meshes) that a test may break."""
    import shutil

    folder = tmp_path / "ur5"
    shutil.copytree(UR5 / "meshes", folder / "meshes")
    for name in ("ur5.urdf", "ur5.srdf"):
        shutil.copy(UR5 / name, folder / name)
    return folder


@needs_ur5
def test_a_zero_byte_robot_mesh_names_the_file_and_the_link(tmp_path: Path) -> None:
    """The visual mesh of the UR5's last wrist link is empty: the viewer says which file of which link and what
    to do (it was pycollada's raw traceback naming no file)."""
    folder = _ur5_copy(tmp_path)
    broken = folder / "meshes" / "ur5" / "visual" / "wrist3.dae"
    broken.chmod(0o644)
    broken.write_bytes(b"")
    robot = load_ur5({"meshes": folder / "meshes"}, folder / "ur5.urdf")  # pinocchio reads collision meshes only
    with pytest.raises(InvalidInput) as error:
        export_html(tmp_path / "ur5.html", joint_plan(robot), [], robot)
    message = str(error.value)
    assert "'wrist_3_link'" in message and str(broken.resolve()) in message
    assert "package://meshes/ur5/visual/wrist3.dae" in message
    assert "empty (0 bytes)" in message and "replace the file with a valid mesh" in message
    # no collada traceback behind it
    assert error.value.__cause__ is None and (error.value.__context__ is None or error.value.__suppress_context__)
    assert not (tmp_path / "ur5.html").exists()


def _one_link_robot(folder: Path, mesh: str) -> Path:
    """A two-link URDF whose moving link ``hand`` has the visual mesh ``mesh`` (a path relative to the URDF)."""
    urdf = folder / "arm.urdf"
    urdf.write_text(f"""<robot name="arm">
  <link name="base"/>
  <link name="hand">
    <visual><geometry><mesh filename="{mesh}"/></geometry></visual>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="hand"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>""")
    return urdf


@pytest.mark.parametrize(("content", "error_type", "reason"), [
    (None, "ResourceNotFound", "no such file"),
    (b"", "InvalidInput", "the file is empty (0 bytes)"),
    (b"solid nothing here\nendsolid\n", "InvalidInput", "holds no triangles"),
    (b"this is not a mesh at all", "InvalidInput", "holds no triangles"),
])
def test_an_unreadable_robot_mesh_names_the_file_and_the_link(tmp_path: Path, content: bytes | None,
                                                              error_type: str, reason: str) -> None:
    """Missing (removed after the model was loaded), empty, or not a mesh: a pfield error naming the link and the
    file, raised before any page is served."""
    import trimesh

    from pfield import errors
    from pfield.robot import RobotModel

    part = tmp_path / "meshes" / "part.stl"
    part.parent.mkdir()
    trimesh.creation.box(extents=(0.05, 0.05, 0.05)).export(part)
    robot = RobotModel.from_urdf(_one_link_robot(tmp_path, "meshes/part.stl"), "hand")
    if content is None:
        part.unlink()
    else:
        part.write_bytes(content)
    with pytest.raises(errors.PfieldError) as error:
        Viewer(robot, port=0)
    assert type(error.value).__name__ == error_type
    message = str(error.value)
    assert "link 'hand'" in message and str(part) in message and reason in message


def test_a_missing_robot_mesh_names_its_link_when_the_model_loads(tmp_path: Path) -> None:
    from pfield import errors
    from pfield.robot import RobotModel

    with pytest.raises(errors.ResourceNotFound) as error:
        RobotModel.from_urdf(_one_link_robot(tmp_path, "meshes/gone.stl"), "hand")
    assert "link 'hand'" in str(error.value) and "gone.stl" in str(error.value)
    with pytest.raises(errors.ResourceNotFound, match=r"link 'hand' of .*package 'parts' is unknown"):
        RobotModel.from_urdf(_one_link_robot(tmp_path, "package://parts/gone.stl"), "hand")


def _in_view(viewer: Viewer, points: np.ndarray, width: int = 1280, height: int = 720) -> list[bool]:
    camera = viewer.server.initial_camera
    rotation = look_at_camera(camera.position, camera.look_at)
    inside = []
    for point in points:
        pixel = project(camera.position, rotation, camera.fov, point, width, height)
        inside.append(pixel is not None and 0 <= pixel[0] < width and 0 <= pixel[1] < height)
    return inside


@needs_ur5
def test_the_view_frames_a_raised_ur5_and_its_scene() -> None:
    """The UR5 on its 0.91 m base, pointing up to 1.92 m, over a table scene: the initial camera (where the page
    and the HTML export open) sees the whole arm and every obstacle; the slice-height slider spans the scene."""
    robot = load_ur5()
    obstacles = table_scene()
    with Viewer(robot, port=0) as viewer:
        arm = skeleton_box(robot, np.zeros(6))  # as first drawn: every joint at 0 (the arm stretched out)
        assert all(_in_view(viewer, arm)), "the UR5 on its pedestal is not in the initial view"
        viewer.show_plan(joint_plan(robot), obstacles)
        arm = skeleton_box(robot, START)
        assert arm[:, 2].max() > 1.9 and arm[:, 2].min() == 0.0
        assert all(_in_view(viewer, arm)), "the raised UR5 is not in the initial view"
        corners = np.vstack([viewer.scene._obstacle_boxes[o.id] for o in obstacles])
        assert all(_in_view(viewer, corners)), "an obstacle is not in the initial view"
        low, high = viewer.slice_height.min, viewer.slice_height.max
        assert low <= 0.0 and high >= arm[:, 2].max() and high <= arm[:, 2].max() + 0.2
        # The slice follows the goal (the plan's end, over the table) until the user moves it.
        assert viewer.slice_height.value == pytest.approx(viewer.goal.position[2], abs=0.006)
        viewer.refresh_field()
        arrows = viewer.scene._field_handle
        assert arrows is not None
        starts = np.asarray(arrows.points)[:, 0]
        table = next(o for o in obstacles if o.id == "table_top")
        lower, upper = viewer.scene._obstacle_boxes[table.id]
        assert starts[:, 0].min() <= lower[0] and starts[:, 0].max() >= upper[0]  # the field covers the table
        assert starts[:, 1].min() <= lower[1] and starts[:, 1].max() >= upper[1]
        assert BASE_HEIGHT < high


def test_the_view_frames_a_table_top_arm_close_up(offline_viewer: Viewer) -> None:
    """A small scene is not lost in a large view: the xArm7's box fills a good part of the picture."""
    robot = offline_viewer.robot
    box = skeleton_box(robot, np.zeros(robot.n_joints), pedestal=None)
    camera = offline_viewer.server.initial_camera
    assert np.linalg.norm(np.asarray(camera.position) - np.asarray(camera.look_at)) < 2.0
    assert all(_in_view(offline_viewer, box))


def test_a_slice_height_the_user_chose_stays(offline_viewer: Viewer) -> None:
    offline_viewer.slice_height.value = 0.12  # type: ignore[misc]
    offline_viewer.set_goal(Pose((0.4, 0.0, 0.5)))
    assert offline_viewer.slice_height.value == pytest.approx(0.12)


def test_framing_of_a_box() -> None:
    """The camera sees every corner of a box from where its bounding sphere fills the field of view; the grid lies
    under it and the slice heights span it, from the ground (a base plate 1 cm under it does not count)."""
    from pfield.viz._viewer_frame import camera_pose, grid_placement, height_range

    box = np.array([[-1.9, -1.0, -0.01], [0.1, 1.1, 1.95]])
    position, look_at = camera_pose(box, np.radians(75))
    assert look_at == pytest.approx(box.mean(axis=0))
    corners = np.array([[x, y, z] for x in box[:, 0] for y in box[:, 1] for z in box[:, 2]])
    rotation = look_at_camera(position, look_at)
    pixels = [project(position, rotation, np.radians(75), corner, 1280, 720) for corner in corners]
    assert all(p is not None and 0 <= p[0] < 1280 and 0 <= p[1] < 720 for p in pixels)
    assert max(p[1] for p in pixels if p) - min(p[1] for p in pixels if p) > 0.5 * 720  # not lost in the distance
    centre, width, height = grid_placement(box)
    assert centre[2] == 0.0 and centre[0] - width / 2 <= -1.9 - 0.5 and centre[0] + width / 2 >= 0.1 + 0.5
    assert centre[1] - height / 2 <= -1.0 - 0.5 and centre[1] + height / 2 >= 1.1 + 0.5
    assert height_range(box) == (0.0, 2.0)
    assert height_range(np.array([[0.0, 0.0, -0.3], [1.0, 1.0, 0.42]])) == (-0.3, 0.5)
