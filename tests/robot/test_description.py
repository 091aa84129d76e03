"""``RobotDescription``: one value names a robot (a built-in or a URDF with its files), hashable and picklable,
built once; every bad part refused naming its field; MoveIt problems read for a URDF robot by joint name."""

from __future__ import annotations

import pickle
import shutil
import tarfile
from pathlib import Path

import numpy as np
import pytest

from pfield.errors import InvalidInput
from pfield.geometry.resources import package_path_map
from pfield.robot.description import RobotDescription
from pfield.scene import Problem, read_moveit_problem, read_problems

UR5 = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "mbm" / "ur5"
ARM = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")


def ur5(**changes: object) -> RobotDescription:
    values: dict[str, object] = {"srdf": str(UR5 / "ur5.srdf"), "end_effector": "tool0",
                                 "package_paths": {"meshes": UR5 / "meshes"}} | changes
    return RobotDescription(str(UR5 / "ur5.urdf"), **values)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def ur5_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``box_ur5/`` with the archive's problems 1 and 2."""
    root = tmp_path_factory.mktemp("ur5")
    members = [f"problems/box_ur5/{kind}000{n}.yaml" for n in (1, 2) for kind in ("scene", "request")]
    with tarfile.open(UR5 / "ur5_problems.tar.bz2") as opened:
        opened.extractall(root, members=[opened.getmember(m) for m in members], filter="data")
    return root / "problems" / "box_ur5"


def test_a_urdf_description_is_a_plain_value_that_builds_the_robot(monkeypatch: pytest.MonkeyPatch) -> None:
    description = ur5()
    monkeypatch.chdir(UR5)  # relative paths are made absolute: the value means the same from any folder
    relative = RobotDescription("ur5.urdf", srdf="ur5.srdf", end_effector="tool0", package_paths=["meshes=meshes"])
    assert relative == description and hash(relative) == hash(description)
    assert pickle.loads(pickle.dumps(description)) == description
    assert description.robot == str((UR5 / "ur5.urdf").resolve())
    assert description.package_paths == (("meshes", str((UR5 / "meshes").resolve())),)
    assert (description.base_link, description.urdf_joints) == ("offset_link", ARM)
    assert description.short_names == ("ur5", "ur5_robotiq85")
    robot = description.build()
    assert (robot.joint_names, robot.end_effector) == (ARM, "tool0")
    assert set(robot.named_configurations()) == {"home"}  # the SRDF's group state
    assert robot.disabled_pairs is not None and frozenset(("base_link", "shoulder_link")) in robot.disabled_pairs
    # the Robotiq meshes are named relative to the URDF: they resolve against its folder
    files = {Path(g.meshPath) for g in robot.collision_model.geometryObjects if g.meshPath}
    assert (UR5 / "meshes" / "robotiq" / "outer_knuckle_fine.STL").resolve() in files
    assert (UR5 / "meshes" / "ur5" / "collision" / "base.stl").resolve() in files  # package://meshes/…


def test_locked_joints_and_built_in_names() -> None:
    locked = ur5(locked_joints={"wrist_3_joint": 0.5})
    assert locked.locked_joints == (("wrist_3_joint", 0.5),) and locked != ur5()
    robot = locked.build()
    assert robot.joint_names == ARM[:5]
    assert np.allclose(robot.forward_kinematics(np.zeros(5)).position,
                       ur5().build().forward_kinematics(np.array([0, 0, 0, 0, 0, 0.5])).position)
    panda = RobotDescription(" Panda ")
    assert panda.robot == "panda" and panda.is_builtin and panda.base_link == "panda_link0"
    assert panda.locked == {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}
    assert panda.with_locked({"panda_finger_joint1": 0.065}).locked["panda_finger_joint1"] == 0.065
    assert RobotDescription("xarm7").build().n_joints == 7


@pytest.mark.parametrize(("changes", "field", "says"), [
    ({"robot": "ur5"}, "robot", "neither a built-in robot (panda, xarm7) nor a URDF file"),
    ({"robot": "/nonexistent/ur5.urdf"}, "robot", "no such URDF file"),
    ({"robot": str(UR5 / "README.md")}, "robot", "not valid XML"),
    ({"srdf": "/nonexistent/ur5.srdf"}, "srdf", "no such SRDF file"),
    ({"srdf": str(UR5 / "ur5.urdf")}, "srdf", "not an SRDF: it has <link> elements (a URDF?)"),
    ({"robot": str(UR5 / "ur5.srdf")}, "robot", "not a URDF: it has no <link> elements (an SRDF?)"),
    ({"end_effector": None}, "end_effector", "needs its end-effector link"),
    ({"end_effector": "tool9"}, "end_effector", "no such link in ur5.urdf; links: offset_link, base_link,"),
    ({"package_paths": ["meshes"]}, "package_paths", "expected NAME=DIR"),
    ({"package_paths": ["=meshes"]}, "package_paths", "expected NAME=DIR"),
    ({"package_paths": {"meshes": "/nonexistent/meshes"}}, "package_paths", "/nonexistent/meshes is not a directory"),
    ({"locked_joints": {"elbow": 0.1}}, "locked_joints['elbow']", "no such movable joint in the URDF; joints: "
                                                                  "shoulder_pan_joint,"),
    ({"locked_joints": {"elbow_joint": float("nan")}}, "locked_joints['elbow_joint']", "finite"),
    ({"locked_joints": 3}, "locked_joints", "expected a mapping"),
])
def test_every_bad_part_is_refused_naming_its_field(changes: dict[str, object], field: str, says: str) -> None:
    robot = changes.pop("robot", str(UR5 / "ur5.urdf"))
    values: dict[str, object] = {"srdf": str(UR5 / "ur5.srdf"), "end_effector": "tool0"} | changes
    with pytest.raises(InvalidInput) as info:
        RobotDescription(robot, **values)  # type: ignore[arg-type]
    assert info.value.field == field and says in info.value.reason, info.value


def test_a_built_in_robot_keeps_its_own_files() -> None:
    for field, value in (("srdf", str(UR5 / "ur5.srdf")), ("end_effector", "tool0")):
        with pytest.raises(InvalidInput) as info:
            RobotDescription("panda", **{field: value})  # type: ignore[arg-type]
        assert info.value.field == field and "give its URDF file" in info.value.reason
    assert package_path_map([f"meshes={UR5 / 'meshes'}", ("meshes", UR5 / "meshes")]) == {
        "meshes": (UR5 / "meshes").resolve()}
    with pytest.raises(InvalidInput, match="given twice"):
        package_path_map([f"meshes={UR5 / 'meshes'}", f"meshes={UR5}"])


def test_moveit_problems_of_a_urdf_robot_match_joints_by_name(ur5_folder: Path) -> None:
    """The requests list six Robotiq joints (fixed in this URDF): ignored; the goal names all six arm joints."""
    problems = read_problems([ur5_folder], robot=ur5(), scenes=["box"])  # "box" names box_ur5
    assert [p.key for p in problems] == [("box_ur5", 1), ("box_ur5", 2)] and not any(p.error for p in problems)
    first = problems[0]
    assert first.robot == ur5() and first.goal_joints is not None
    assert tuple(first.start) == ARM and tuple(first.goal_joints) == ARM
    assert list(first.start.values()) == [1.57, -1.5707, 0.0, -1.5707, -1.57, 3.14]  # type: ignore[union-attr]
    assert len(first.obstacles) == 7


def test_joints_the_goal_leaves_out_are_locked_at_the_start(ur5_folder: Path, tmp_path: Path) -> None:
    request = (ur5_folder / "request0001.yaml").read_text()
    cut = request.replace("      - position: 0.1145459363691259\n        joint_name: wrist_3_joint\n", "")
    assert cut != request
    (tmp_path / "request0001.yaml").write_text(cut)
    problem = read_moveit_problem(ur5_folder / "scene0001.yaml", tmp_path / "request0001.yaml", 1, ur5())
    assert problem.robot == ur5(locked_joints={"wrist_3_joint": 3.14})
    assert tuple(problem.start) == ARM[:5] and tuple(problem.goal_joints or ()) == ARM[:5]
    assert problem.robot is not None and problem.robot.build().joint_names == ARM[:5]
    # a joint left free by the goal, with no start value to lock it at: the problem says so
    no_start = cut.replace("wrist_3_joint, robotiq", "robotiq").replace(", 3.14, 0, 0", ", 0, 0")
    assert no_start != cut
    (tmp_path / "request0002.yaml").write_text(no_start)
    (tmp_path / "scene0002.yaml").write_text((ur5_folder / "scene0001.yaml").read_text())
    with pytest.raises(InvalidInput) as info:
        read_moveit_problem(tmp_path / "scene0002.yaml", tmp_path / "request0002.yaml", 2, ur5())
    assert "['wrist_3_joint'] free" in info.value.reason
    bad = read_problems([tmp_path], robot=ur5())
    assert isinstance(bad[1], Problem) and "wrist_3_joint" in bad[1].error


def test_a_locked_joint_that_replaces_the_requests_values_is_warned_of(ur5_folder: Path,
                                                                     caplog: pytest.LogCaptureFixture) -> None:
    """The request starts wrist_3_joint at 3.14 and its goal asks 0.1145…: a user's lock at 0.25 replaces both (the plan
    neither starts nor ends there for that joint), said once per joint and value."""
    with caplog.at_level("WARNING", logger="pfield.scene.problems"):
        problem = read_moveit_problem(ur5_folder / "scene0001.yaml", ur5_folder / "request0001.yaml", 1,
                                      ur5(locked_joints={"wrist_3_joint": 0.25}))
        read_moveit_problem(ur5_folder / "scene0001.yaml", ur5_folder / "request0001.yaml", 1,
                            ur5(locked_joints={"wrist_3_joint": 0.25}))
    assert "wrist_3_joint" not in problem.start
    said = [r.getMessage() for r in caplog.records]
    assert said == ["the locked joint wrist_3_joint=0.25 replaces the request's start 3.14 and goal 0.114546 "
                    "(request0001.yaml; warned once per joint)"], said


def test_a_missing_file_in_another_folder_reads_the_same(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InvalidInput) as info:
        RobotDescription("ur5.urdf", end_effector="tool0")
    assert info.value.field == "robot" and info.value.value == "ur5.urdf"


def test_an_srdf_is_checked_against_its_urdf(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """Another robot's SRDF is refused (none of its links is the URDF's); links the URDF has lost since are
    logged and their pairs ignored, as MoveIt does; ``from_urdf`` takes package roots as ``NAME=DIR`` too."""
    from pfield.robot import RobotModel

    other = tmp_path / "other.srdf"
    other.write_text('<robot name="arm"><disable_collisions link1="hand" link2="link7" reason="Adjacent"/></robot>')
    with pytest.raises(InvalidInput) as info:
        ur5(srdf=str(other))
    assert info.value.field == "srdf" and "it describes another robot: none of the links it names (hand, link7) " \
        "is a link of the URDF" in info.value.reason
    with pytest.raises(InvalidInput) as info:
        RobotModel.from_urdf(UR5 / "ur5.urdf", "tool0", {"meshes": UR5 / "meshes"}, srdf=other)
    assert info.value.field == "srdf"
    edited = tmp_path / "edited.srdf"
    edited.write_text('<robot name="ur5"><disable_collisions link1="base_link" link2="shoulder_link"/>'
                      '<disable_collisions link1="base_link" link2="old_camera_link"/></robot>')
    with caplog.at_level("WARNING", logger="pfield.robot.srdf"):
        robot = RobotModel.from_urdf(UR5 / "ur5.urdf", "tool0", f"meshes={UR5 / 'meshes'}", srdf=edited)
    assert "names links the URDF does not have (their pairs are ignored): old_camera_link" in caplog.text
    caplog.clear()  # once per file: a batch makes a description per problem (with_locked)
    with caplog.at_level("WARNING", logger="pfield.robot.srdf"):
        ur5(srdf=str(edited)).with_locked({"wrist_3_joint": 0.0})
    assert "old_camera_link" not in caplog.text
    assert robot.disabled_pairs is not None and frozenset(("base_link", "shoulder_link")) in robot.disabled_pairs
    # an SRDF with no disabled pairs (groups and states only, as example-robot-data's kinova.srdf): its group states'
    # joints tell (its chain's base link "base" is a UR5 link too)
    states_only = tmp_path / "states.srdf"
    states_only.write_text('<robot name="kinova"><group name="arm"><chain base_link="base" tip_link="tip"/></group>'
                           '<group_state name="up" group="arm"><joint name="j2s6s200_joint_1" value="1.5"/>'
                           '<joint name="j2s6s200_joint_2" value="2.6"/></group_state></robot>')
    for make in (lambda: ur5(srdf=str(states_only)),
                 lambda: RobotModel.from_urdf(UR5 / "ur5.urdf", "tool0", {"meshes": UR5 / "meshes"}, srdf=states_only)):
        with pytest.raises(InvalidInput) as info:
            make()
        assert info.value.field == "srdf" and "none of the joints its group states set (j2s6s200_joint_1, " \
            "j2s6s200_joint_2) is a joint of the URDF" in info.value.reason, info.value.reason
    own = tmp_path / "own.srdf"  # this robot's states, one of them of a locked joint only: accepted
    own.write_text('<robot name="ur5"><group_state name="flat" group="wrist"><joint name="wrist_3_joint" value="0"/>'
                   '</group_state></robot>')
    assert RobotModel.from_urdf(UR5 / "ur5.urdf", "tool0", {"meshes": UR5 / "meshes"}, srdf=own,
                                locked_joints={"wrist_3_joint": 0.0}).named_configurations() == {}


def test_an_unknown_scene_names_another_robots_scenes_only_when_they_are(ur5_folder: Path, tmp_path: Path) -> None:
    """``box`` among the UR5's scenes read for the Panda: ``box_ur5`` is named, with the advice to give its robot;
    not a scene that only starts with the name (``box_top_ur5`` for ``box``, for either robot; ``bo``)."""
    with pytest.raises(InvalidInput) as info:
        read_problems(ur5_folder, scenes=["box"])
    assert "box_ur5 would match with their robot given" in info.value.reason
    longer = shutil.copytree(ur5_folder, tmp_path / "box_top_ur5")
    for robot, scene in ((ur5(), "box"), ("panda", "box"), ("panda", "bo")):
        with pytest.raises(InvalidInput) as info:
            read_problems(longer, robot=robot, scenes=[scene])
        assert "would match" not in info.value.reason, info.value.reason
