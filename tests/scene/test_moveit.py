"""MoveIt PlanningScene / MotionPlanRequest readers: MBM scenes, a mesh collision object, bad input."""

from __future__ import annotations

import tarfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from core_scenes import UR5, ur5_at_tool0
from pfield.errors import InvalidInput
from pfield.geometry import Box, Cylinder, Mesh, Sphere
from pfield.robot import RobotModel
from pfield.scene import (
    MBM_CONFIG,
    MBM_JOINT_STEP,
    MBM_OPTIONS,
    MBM_STEP_RANGE,
    Problem,
    RobotSpec,
    mbm_options,
    read_moveit_problem,
    read_problems,
    request_from_moveit,
    scene_obstacles,
)
from pfield.spatial import Pose

ARCHIVE = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "mbm" / "panda_problems_dev.tar.bz2"
MEMBERS = ("problems/box_panda/scene0001.yaml", "problems/box_panda/request0001.yaml")


@pytest.fixture(scope="module")
def box_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not ARCHIVE.exists():
        pytest.fail(f"{ARCHIVE} is missing (the shared MBM problems)")
    root = tmp_path_factory.mktemp("mbm")
    with tarfile.open(ARCHIVE) as opened:
        opened.extractall(root, members=[opened.getmember(m) for m in MEMBERS], filter="data")
    return root / "problems" / "box_panda"


def test_an_mbm_scene_becomes_its_boxes_and_cylinders_with_the_file_values(box_folder: Path) -> None:
    scene = yaml.safe_load((box_folder / "scene0001.yaml").read_text())
    obstacles = scene_obstacles(scene)
    objects = scene["world"]["collision_objects"]
    assert [o.id for o in obstacles] == [item["id"] for item in objects]
    for obstacle, item in zip(obstacles, objects, strict=True):
        primitive, pose = item["primitives"][0], item["primitive_poses"][0]
        dims = primitive["dimensions"]
        expected = (Box(length=dims[0], width=dims[1], height=dims[2]) if primitive["type"] == "box"
                    else Cylinder(radius=dims[1], height=dims[0]))
        assert obstacle.shape == expected
        np.testing.assert_array_equal(obstacle.pose.position, pose["position"])
        quat = np.asarray(pose["orientation"], dtype=float)
        np.testing.assert_allclose(obstacle.pose.orientation, quat / np.linalg.norm(quat), rtol=0, atol=1e-15)


def test_an_mbm_request_locks_the_fingers_at_0_065_and_keeps_the_arm_joints(box_folder: Path) -> None:
    problem = read_moveit_problem(box_folder / "scene0001.yaml", box_folder / "request0001.yaml", 1)
    request = yaml.safe_load((box_folder / "request0001.yaml").read_text())
    state = request["start_state"]["joint_state"]
    assert problem.robot == RobotSpec("panda", (("panda_finger_joint1", 0.065), ("panda_finger_joint2", 0.065)))
    assert dict(problem.start) == dict(zip(state["name"][:7], state["position"][:7], strict=True))
    assert problem.goal_joints == {c["joint_name"]: c["position"]
                                   for c in request["goal_constraints"][0]["joint_constraints"]}
    # the options are chosen for the robot when it is built (mbm_options), not here
    assert (problem.scene, problem.index, problem.options) == ("box_panda", 1, None)


def _rail(tmp_path: Path, revolute_speed: float) -> RobotModel:
    """A prismatic rail (10 m/s) carrying one revolute joint (``revolute_speed`` rad/s, none when 0)."""
    arm = "" if revolute_speed == 0.0 else f"""
  <joint name='turn' type='revolute'><parent link='carriage'/><child link='arm'/><axis xyz='0 0 1'/>
    <limit lower='-2' upper='2' velocity='{revolute_speed}' effort='1'/></joint>"""
    urdf = tmp_path / f"rail_{revolute_speed}.urdf"
    links = "<link name='base'/><link name='carriage'/>" + ("<link name='arm'/>" if arm else "")
    urdf.write_text(f"""<robot name='rail'>{links}
  <joint name='rail' type='prismatic'><parent link='base'/><child link='carriage'/><axis xyz='1 0 0'/>
    <limit lower='0' upper='1' velocity='10' effort='1'/></joint>{arm}
</robot>""")
    return RobotModel.from_urdf(urdf, "arm" if arm else "carriage")


def test_mbm_options_step_the_fastest_revolute_joint_by_0_05_rad_within_20_to_50_ms(tmp_path: Path) -> None:
    """Panda: 2.61 rad/s → 0.0192 s, raised to 0.02; the MBM UR5: 0.5 rad/s → 0.1 s, cut to 0.05; between, exact;
    a prismatic joint's m/s are not counted, and without a revolute joint the set's own 0.02 s."""
    assert MBM_JOINT_STEP == 0.05 and MBM_STEP_RANGE == (0.02, 0.05)
    panda = RobotModel.builtin("panda")
    assert float(np.max(panda.velocity_limits)) == pytest.approx(2.61)
    assert mbm_options(panda).dt == 0.02
    if (UR5 / "ur5.urdf").exists():  # ../shared's UR5
        assert mbm_options(ur5_at_tool0()).dt == 0.05
    stepped = mbm_options(_rail(tmp_path, 1.25))  # the rail's 10 m/s would make it 0.005 s, raised to 0.02
    assert stepped == replace(MBM_OPTIONS, dt=0.05 / 1.25)  # everything else is the set's
    assert mbm_options(_rail(tmp_path, 0.0)) is MBM_OPTIONS


def test_a_problem_leaves_its_options_to_its_robot_only_with_a_robot() -> None:
    whole_body = Problem("s", 1, start={"j": 0.0}, goal_joints={"j": 0.1}, robot=RobotSpec("panda"), options=None)
    assert whole_body.options is None
    with pytest.raises(InvalidInput, match="options"):
        Problem("s", 1, start=Pose(), goal=Pose((0.1, 0.0, 0.0)), options=None)


MESH_SCENE = """
world:
  collision_objects:
    - id: wedge
      header: {frame_id: world}
      pose:
        position: {x: 1.0, y: 0.0, z: 0.0}
        orientation: {x: 0, y: 0, z: 0.7071067811865476, w: 0.7071067811865476}
      meshes:
        - vertices: [{x: 0, y: 0, z: 0}, {x: 0.1, y: 0, z: 0}, {x: 0, y: 0.1, z: 0}, {x: 0, y: 0, z: 0.1}]
          triangles: [{vertex_indices: [0, 2, 1]}, {vertex_indices: [0, 1, 3]}, {vertex_indices: [0, 3, 2]},
                      {vertex_indices: [1, 2, 3]}]
      mesh_poses: [{position: {x: 0.0, y: 0.5, z: 0.0}, orientation: {w: 1.0}}]
      primitives: [{type: 2, dimensions: [0.05]}]
      primitive_poses: [{position: {x: 0.2, y: 0.0, z: 0.3}}]
      subframe_names: [tip]
      subframe_poses: [{position: {x: 0, y: 0, z: 0.1}}]
"""


def test_a_mesh_collision_object_becomes_a_mesh_at_the_composed_pose() -> None:
    sphere, mesh = scene_obstacles(yaml.safe_load(MESH_SCENE))
    assert (sphere.id, mesh.id) == ("wedge_0", "wedge_1")  # primitives first, then meshes, as MoveIt lists them
    assert sphere.shape == Sphere(radius=0.05)
    # object pose: +90° about z at (1, 0, 0); the shape offsets are rotated into the world by it
    np.testing.assert_allclose(sphere.pose.position, [1.0, 0.2, 0.3], atol=1e-15)
    np.testing.assert_allclose(mesh.pose.position, [0.5, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(mesh.pose.orientation, [0, 0, 2**-0.5, 2**-0.5], atol=1e-15)
    assert isinstance(mesh.shape, Mesh) and mesh.shape.watertight
    np.testing.assert_array_equal(np.sort(mesh.shape.data.vertices, axis=0),
                                  np.sort([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], axis=0))
    # local (−0.1, 0, 0) is world (0.5, −0.1, 0): 0.1 m from the tetrahedron's corner at the local origin
    d, _ = mesh.signed_distance(np.array([[0.5, -0.1, 0.0]]))
    assert d[0] == pytest.approx(0.1, abs=1e-12)


def test_a_pose_goal_is_the_region_centre_less_the_target_offset() -> None:
    request = request_from_moveit({
        "start_state": {"joint_state": {"name": ["a"], "position": [0.5]}},
        "goal_constraints": [{
            "position_constraints": [{"link_name": "tool", "target_point_offset": {"x": 0.0, "y": 0.0, "z": 0.1},
                                      "constraint_region": {"primitive_poses": [{"position": [0.4, 0.0, 0.5]}]}}],
            "orientation_constraints": [{"link_name": "tool", "orientation": [1.0, 0.0, 0.0, 0.0]}]}]})
    # 180° about x turns the link's +z offset into −z in the world: the link origin sits 0.1 m above the point
    assert request.goal_pose is not None and request.goal_pose.isclose(Pose((0.4, 0.0, 0.6), (1, 0, 0, 0)))
    assert (request.goal_link, request.start, request.goal_joints) == ("tool", {"a": 0.5}, None)


@pytest.mark.parametrize(("scene", "field", "words"), [
    ({"world": {"collision_objects": [{"id": "c", "primitives": [{"type": "cone", "dimensions": [1, 1]}],
                                       "primitive_poses": [{}]}]}},
     "scene.world.collision_objects[0].primitives[0].type", "cone"),
    ({"world": {"collision_objects": [{"id": "b", "primitives": [{"type": "box", "dimensions": [1, 1]}],
                                       "primitive_poses": [{}]}]}},
     "scene.world.collision_objects[0].primitives[0].dimensions", "3 dimensions"),
    ({"world": {"collision_objects": [{"id": "b", "primitives": [{"type": "box", "dimensions": [1, -1, 1]}],
                                       "primitive_poses": [{}]}]}},
     "scene.world.collision_objects[0].primitives[0].width", None),
    ({"world": {"collision_objects": [{"id": "b", "primitives": [{"type": "sphere", "dimensions": [1]}],
                                       "primitive_poses": []}]}},
     "scene.world.collision_objects[0].primitive_poses", "one pose per entry"),
    ({"world": {"collision_objects": [{"id": "b", "header": {"frame_id": "camera"}}]}},
     "scene.world.collision_objects[0].header.frame_id", "world frame"),
    ({"world": {"collision_objects": [{"id": "b", "operation": 1}]}},
     "scene.world.collision_objects[0].operation", "ADD"),
    ({"world": {"collision_objects": [{"id": "b", "planes": [{"coef": [0, 0, 1, 0]}]}]}},
     "scene.world.collision_objects[0].planes", "plane"),
    ({"robot_state": {"attached_collision_objects": [{"link_name": "hand"}]}},
     "scene.robot_state.attached_collision_objects", "attached"),
    ({"world": {"collision_objects": [{"id": "m", "meshes": [{"vertices": [[0, 0, 0]],
                                                              "triangles": [{"vertex_indices": [0, 1, 2]}]}],
                                       "mesh_poses": [{}]}]}},
     "scene.world.collision_objects[0].meshes[0].triangles[0].vertex_indices", "vertex indices"),
    ({"world": {"collision_objects": [{"id": "s", "primitives": [{"type": "sphere", "dimensions": [0.1]}],
                                       "primitive_poses": [{"position": [0, 0, float("nan")]}]}]}},
     "scene.world.collision_objects[0].primitive_poses[0].position.z", None),
    ("not a scene", "scene", "mapping"),
])
def test_bad_scenes_are_refused_naming_the_part(scene: object, field: str, words: str | None) -> None:
    with pytest.raises(InvalidInput, match=words) as raised:
        scene_obstacles(scene)
    assert raised.value.field == field


@pytest.mark.parametrize(("primitive", "pose", "field"), [
    ({"type": 2, "dimensions": ["0.1"]}, {}, "primitives[0].dimensions[0]"),
    ({"type": 2, "dimensions": [True]}, {}, "primitives[0].dimensions[0]"),
    ({"type": 2, "dimensions": [0.1]}, {"position": {"x": "0.4"}}, "primitive_poses[0].position.x"),
    ({"type": 2, "dimensions": [0.1]}, {"orientation": [0, 0, 0, False]}, "primitive_poses[0].orientation.w"),
])
def test_numbers_are_numbers_as_in_the_messages(primitive: dict[str, object], pose: dict[str, object],
                                                field: str) -> None:
    """An int serves for a float (MotionBenchMaker writes 0 and 1); a string or a boolean is refused, where
    ``float()`` would read "0.4" and True."""
    scene = {"world": {"collision_objects": [{"id": "s", "primitives": [primitive], "primitive_poses": [pose]}]}}
    with pytest.raises(InvalidInput, match="must be a number, not a") as raised:
        scene_obstacles(scene)
    assert raised.value.field == f"scene.world.collision_objects[0].{field}"
    integers = {"id": "s", "primitives": [{"type": 2, "dimensions": [1]}], "primitive_poses": [{"position": [0, 1, 0]}]}
    (ball,) = scene_obstacles({"world": {"collision_objects": [integers]}})
    assert ball.shape == Sphere(radius=1.0) and ball.pose.isclose(Pose((0.0, 1.0, 0.0)))


@pytest.mark.parametrize(("request_data", "field"), [
    ({"goal_constraints": []}, "request.goal_constraints"),
    ({"start_state": {"joint_state": {"name": ["a", "b"], "position": [0.0]}}},
     "request.start_state.joint_state.position"),
    ({"goal_constraints": [{"joint_constraints": [{"joint_name": "a", "position": "x"}]}]},
     "request.goal_constraints[0].joint_constraints[0].position"),
    ({"goal_constraints": [{"joint_constraints": [{"joint_name": "a", "position": 0}]}],
      "path_constraints": {"joint_constraints": [{"joint_name": "a"}]}}, "request.path_constraints"),
    ({"goal_constraints": [{"position_constraints": [{"constraint_region": {}}]}]},
     "request.goal_constraints[0].position_constraints[0].constraint_region.primitive_poses"),
    ({"start_state": {"joint_state": {"name": ["a"], "position": ["0.5"]}}},
     "request.start_state.joint_state.position[0]"),
    ({"goal_constraints": [{"joint_constraints": [{"joint_name": "a", "position": True}]}]},
     "request.goal_constraints[0].joint_constraints[0].position"),
])
def test_bad_requests_are_refused_naming_the_part(request_data: dict[str, object], field: str) -> None:
    with pytest.raises(InvalidInput) as raised:
        request_from_moveit(request_data)
    assert raised.value.field == field


def test_read_problems_refuses_bad_arguments_and_keeps_a_bad_pair_as_an_unreadable_problem(
        box_folder: Path, tmp_path: Path) -> None:
    with pytest.raises(InvalidInput, match="no such file") as raised:
        read_problems([tmp_path / "missing"])
    assert raised.value.field == "problems"
    with pytest.raises(InvalidInput) as raised:
        read_problems([box_folder], limit=0)
    assert raised.value.field == "limit"
    with pytest.raises(InvalidInput) as raised:
        read_problems([box_folder], robot="r2d2")
    assert raised.value.field == "robot"
    with pytest.raises(InvalidInput) as raised:
        read_problems([box_folder], scenes=["kitchen"])
    assert (raised.value.field, raised.value.value) == ("scenes", ["kitchen"])
    folder = tmp_path / "set"
    folder.mkdir()
    for name in ("scene0001.yaml", "request0001.yaml"):
        (folder / name).write_text((box_folder / name).read_text())
    (folder / "scene0002.yaml").write_text((box_folder / "scene0001.yaml").read_text())
    (folder / "request0002.yaml").write_text("goal_constraints: []\n")
    good, bad = read_problems([folder])
    assert (good.key, good.error, bad.key) == (("set", 1), "", ("set", 2))
    assert bad.error.startswith("request0002.yaml: request.goal_constraints")


def test_a_problem_refuses_inconsistent_parts() -> None:
    with pytest.raises(InvalidInput) as raised:
        Problem("s", 0, start={"a": 0.0}, goal=Pose())
    assert raised.value.field == "start"
    with pytest.raises(InvalidInput) as raised:
        Problem("s", 0, start=Pose())
    assert raised.value.field == "goal"
    with pytest.raises(InvalidInput) as raised:
        Problem("s", True, start=Pose(), goal=Pose())  # type: ignore[arg-type]
    assert raised.value.field == "index"
    with pytest.raises(InvalidInput) as raised:
        Problem("s", 0, obstacles=("ball",), start=Pose(), goal=Pose())  # type: ignore[arg-type]
    assert raised.value.field == "obstacles[0]"


TABLE_PICK = tuple(f"problems/table_pick_panda/{kind}{i:04d}.yaml" for i in (1, 2, 3, 4)
                   for kind in ("scene", "request"))


def test_the_mbm_stagnation_window_keeps_the_fields_plans_and_ends_its_failures_sooner(tmp_path: Path) -> None:
    """MBM_CONFIG's 0.5 s window against the 10 s default: a plan the field completes is the same plan to the last
    waypoint; one that stagnates is reported as stagnation, in fewer steps."""

    from pfield.field import PotentialField
    from pfield.planning import PlanStatus

    with tarfile.open(ARCHIVE) as opened:
        opened.extractall(tmp_path, members=[opened.getmember(m) for m in TABLE_PICK], filter="data")
    folder = tmp_path / "problems" / "table_pick_panda"
    options = replace(MBM_OPTIONS, global_fallback=False)
    outcomes = []
    robot = None
    for i in (1, 2, 3, 4):
        problem = read_moveit_problem(folder / f"scene{i:04d}.yaml", folder / f"request{i:04d}.yaml", i)
        assert problem.config is MBM_CONFIG and MBM_CONFIG.stagnation_window == 0.5
        assert problem.robot is not None and problem.goal_joints is not None
        robot = robot or problem.robot.build()
        start = np.clip([problem.start[name] for name in robot.joint_names], robot.lower_limits, robot.upper_limits)
        goal = robot.forward_kinematics(np.clip([problem.goal_joints[name] for name in robot.joint_names],
                                                robot.lower_limits, robot.upper_limits))
        short, long = (PotentialField(config, goal, problem.obstacles).plan_whole_body(robot, start, options=options)
                       for config in (MBM_CONFIG, replace(MBM_CONFIG, stagnation_window=10.0)))
        if long.success:
            assert short.success
            np.testing.assert_array_equal(short.joint_positions, long.joint_positions)
        else:
            assert short.status == long.status == PlanStatus.STAGNATION
            assert short.iterations < long.iterations
        outcomes.append(long.success)
    assert any(outcomes) and not all(outcomes)  # both kinds of problem are among them
