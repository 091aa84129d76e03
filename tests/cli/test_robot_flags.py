"""The robot flags (``--robot PATH.urdf --srdf --end-effector --package-path --locked-joint``) on every command that
takes a robot, with the UR5 of ../shared/benchmarks/mbm/ur5 (not built in): ``batch`` plans its MoveIt problems,
a real ``serve`` and a real ``ros2 node`` plan for it, ``view`` draws it, ``plan`` plans its whole body; a bad
value of each flag is refused by each command with exit status 2, naming the flag."""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import re
import subprocess
import sys
import tarfile
from pathlib import Path
from typing import Any

import pytest
from pfield_node_server import NodeServer

from pfield.robot.catalog import example_robot_data_root
from serve_process import PFIELD, REPO, SRC, free_port, pfield_serve

UR5 = REPO.parent / "shared" / "benchmarks" / "mbm" / "ur5"
ARM = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
FLAGS = ["--robot", str(UR5 / "ur5.urdf"), "--srdf", str(UR5 / "ur5.srdf"), "--end-effector", "tool0",
         "--package-path", f"meshes={UR5 / 'meshes'}"]
SCENE = REPO / "tests" / "data" / "ur5" / "scene.yaml"
PANDA_SRDF = example_robot_data_root() / "robots" / "panda_description" / "srdf" / "panda.srdf"
"""Another robot's SRDF (example-robot-data's Panda): no link it names is the UR5's."""
START = [0.0, -1.2, 1.6, -1.97, -1.57, 0.0]
"""rad: the UR5's start in SCENE (the issue's example), its tool 1.165 m high, pointing down."""


def pfield(*args: str, cwd: Path = REPO, timeout: float = 600) -> subprocess.CompletedProcess[str]:
    env = os.environ | {"PYTHONPATH": os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH")]))}
    return subprocess.run([str(PFIELD), *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=timeout,
                          check=False)


def test_batch_plans_ur5_moveit_problems_by_joint_name(tmp_path: Path) -> None:
    out = tmp_path / "ur5.jsonl"
    # two worker processes: each gets the description (pickled) and builds the UR5 from it
    done = pfield("batch", str(UR5 / "ur5_problems.tar.bz2"), *FLAGS, "--limit", "2", "--scene", "box",
                  "--workers", "2", "-o", str(out))
    assert done.returncode == 0, done.stderr
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert [(r["scene"], r["index"]) for r in records] == [("box_ur5", 1), ("box_ur5", 2)]
    with tarfile.open(UR5 / "ur5_problems.tar.bz2") as archive:
        request = archive.extractfile("problems/box_ur5/request0001.yaml")
        assert request is not None
        import yaml

        state = yaml.safe_load(request)["start_state"]["joint_state"]
    assert len(state["name"]) == 12  # six arm joints and six Robotiq joints (fixed in this URDF): ignored
    for record in records:
        assert record["status"] != "error", record["error"]
        assert record["joint_names"] == ARM
        assert {len(q) for q in record["positions"]} == {6}
        assert record["positions"][0] == pytest.approx(state["position"][:6])
        # the UR5's step (mbm_options: its joints' 0.5 rad/s limits), not the Panda's 0.02 s
        steps = [b - a for a, b in itertools.pairwise(record["times"])]
        assert len(steps) > 1 and steps == pytest.approx([0.05] * len(steps))


@pytest.fixture(scope="module")
def ur5_server(tmp_path_factory: pytest.TempPathFactory) -> Any:
    work = tmp_path_factory.mktemp("ur5_serve")
    with pfield_serve(*FLAGS, "--csv-dir", str(work / "csv"), log=work / "serve.log") as (url, process):
        yield NodeServer(url, process, work / "csv", work / "serve.log")


def test_serve_plans_for_the_ur5(ur5_server: NodeServer) -> None:
    request = ("{goal: {position: {x: 0.35, y: 0.55, z: 1.165}, orientation: {x: 1.0, w: 0.0}}, "
               f"starting_joint_angles: {START}, delta_time: 0.02, goal_tolerance: 0.01, max_iterations: 5000, "
               "planning_method: 'whole_body'}")
    answer = ur5_server.call("/pfield/plan_path", "potential_fields_interfaces/srv/PlanPath", request)
    assert answer["success"] is True, answer["error_message"]
    trajectory = answer["joint_trajectory"]
    assert trajectory["joint_names"] == ARM
    assert trajectory["points"][0]["positions"] == pytest.approx(START, abs=1e-9)
    end = answer["end_effector_path"]["poses"][-1]["pose"]["position"]
    assert math.dist((end["x"], end["y"], end["z"]), (0.35, 0.55, 1.165)) <= 0.01


def test_plan_plans_the_ur5_whole_body(tmp_path: Path) -> None:
    out, table = tmp_path / "ur5.png", tmp_path / "ur5.csv"
    done = pfield("plan", "--scene", str(SCENE), *FLAGS, "--start-joints", ",".join(map(str, START)),
                  "-o", str(out), "--csv", str(table))
    assert done.returncode == 0, done.stderr + done.stdout
    assert "ur5_robotiq85" in done.stdout and "reached the goal" in done.stdout and out.stat().st_size > 0
    rows = list(csv.reader(table.open()))
    header, first, last = rows[0], [float(v) for v in rows[1]], [float(v) for v in rows[-1]]
    joints = [header.index(f"position_{name}") for name in ARM]  # the columns name the UR5's joints
    assert [first[i] for i in joints] == pytest.approx(START)
    x, y, z = (last[header.index(name)] for name in ("x", "y", "z"))
    assert math.dist((x, y, z), (0.35, 0.55, 1.165)) <= 0.01
    # what a controller would execute, beside the planner's step time; the scene's start pose is said to be unused
    printed = " ".join(done.stdout.split())
    length, duration = (float(re.search(pattern, printed).group(1)) for pattern in
                        (r"joint path ([0-9.]+) rad", r"trajectory ([0-9.]+) s within the joint limits"))
    path = [[float(row[i]) for i in joints] for row in rows[1:]]
    assert length == pytest.approx(sum(math.dist(a, b) for a, b in itertools.pairwise(path)), abs=0.005)
    assert 0.5 < duration < last[header.index("time")]  # retimed: faster than the field's own steps
    assert "the scene file's start pose is not used" in printed


def test_plan_draws_the_arm(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``plan --robot`` draws ``save_arm_plot``'s picture (the arm at key moments), titled with the robot."""
    from typer.testing import CliRunner

    import pfield.viz.arm
    from pfield.cli import app

    drawn: list[tuple[str, str, int, tuple[float, ...]]] = []
    monkeypatch.setattr(pfield.viz.arm, "save_arm_plot", lambda path, robot, obstacles, file, title, goal: drawn.append(
        (robot.name, title, len(obstacles), tuple(goal.position))))
    result = CliRunner().invoke(app, ["plan", "--scene", str(SCENE), *FLAGS, "--start-joints", "home", "-o",
                                      str(tmp_path / "ur5.png")])
    assert result.exit_code == 0, result.stderr
    assert drawn == [("ur5_robotiq85", "ur5_robotiq85 whole-body plan: reached the goal", 1, (0.35, 0.55, 1.165))]


def test_view_draws_the_ur5(tmp_path: Path) -> None:
    with_robot, without = tmp_path / "ur5.html", tmp_path / "none.html"
    done = pfield("view", "--scene", str(SCENE), *FLAGS, "--export", str(with_robot))
    assert done.returncode == 0, done.stderr
    bare = pfield("view", "--scene", str(SCENE), "--robot", "none", "--export", str(without))
    assert bare.returncode == 0, bare.stderr
    # the robot's visual meshes (the UR5's .dae files and the gripper's STLs, megabytes) are in the page
    assert with_robot.stat().st_size > without.stat().st_size + 500_000


@pytest.mark.ros2
@pytest.mark.slow
def test_ros2_node_plans_for_the_ur5(tmp_path: Path) -> None:
    sys.path.insert(0, str(REPO / "tests" / "transport"))
    from ros2_helpers.support import require_netns, require_ros2_python, run_session

    require_ros2_python()
    require_netns()
    node = [str(PFIELD), "ros2", "node", *FLAGS]
    client = [sys.executable, str(Path(__file__).with_name("ur5_ros2_client.py"))]
    process = run_session(node, client, tmp_path, timeout=600)
    assert process.returncode == 0, process.stderr
    results = json.loads((tmp_path / "results.json").read_text())
    assert "error" not in results, results["error"] + (tmp_path / "node.log").read_text()
    plan = results["plan"]
    assert plan["success"] is True, plan["error_message"]
    # the request's joint angles cross ROS as float32 (PlanPath.srv): the start comes back to 6e-8 rad
    assert plan["joint_names"] == ARM and plan["first"] == pytest.approx(START, abs=1e-7)


BAD = [
    (["--robot", "/nonexistent/ur5.urdf"], "error: --robot='/nonexistent/ur5.urdf': no such URDF file: give a "
                                           "built-in name, or --robot FILE.urdf --end-effector LINK"),
    (["--robot", "ur5"], "error: --robot='ur5': neither a built-in robot (panda, xarm7) nor a URDF file"),
    (["--srdf", "/nonexistent/ur5.srdf"], "error: --srdf='/nonexistent/ur5.srdf': no such SRDF file"),
    (["--end-effector", "tool9"], "error: --end-effector='tool9': no such link in ur5.urdf; links: offset_link, "
                                  "base_link,"),
    (["--package-path", "meshes"], "error: --package-path='meshes': expected NAME=DIR"),
    (["--package-path", "meshes=/nonexistent/meshes"], "error: --package-path='meshes=/nonexistent/meshes': "
                                                       "/nonexistent/meshes is not a directory"),
    (["--locked-joint", "wrist_3_joint"], "error: --locked-joint='wrist_3_joint': expected NAME=VALUE"),
    (["--locked-joint", "wrist_3_joint=up"], "error: --locked-joint='wrist_3_joint=up': 'up' is not a number"),
    (["--locked-joint", "wrist_3_joint=nan"], "error: --locked-joint=nan: must be finite"),
    (["--locked-joint", "wrist_9_joint=0"], "error: --locked-joint wrist_9_joint=0.0: no such movable joint in "
                                            "the URDF; joints: shoulder_pan_joint,"),
    # files swapped, or another robot's: refused before a model is built
    (["--srdf", str(UR5 / "ur5.urdf")], f"error: --srdf='{UR5 / 'ur5.urdf'}': not an SRDF: it has <link> elements"),
    (["--robot", str(UR5 / "ur5.srdf")], f"error: --robot='{UR5 / 'ur5.srdf'}': not a URDF: it has no <link> "
                                         "elements (an SRDF?)"),
    (["--srdf", str(PANDA_SRDF)], "error: --srdf="),
    # a package root that is a folder, but not the package's: the first mesh it cannot find is named, with the flag
    (["--package-path", f"meshes={UR5}"], f"error: link 'base_link' of {(UR5 / 'ur5.urdf').resolve()}: "
                                          "'package://meshes/ur5/"),  # the file read
]
COMMANDS = {
    "serve": ["serve", "--port", str(free_port())],
    "ros2 node": ["ros2", "node"],
    "view": ["view", "--export", "{tmp}/never.html"],
    "plan": ["plan", "--start-joints", "0,0,0,0,0,0", "-o", "{tmp}/never.png"],
    "batch": ["batch", str(UR5 / "ur5_problems.tar.bz2"), "-o", "{tmp}/never.jsonl"],
}


def _with(flags: list[str], bad: list[str]) -> list[str]:
    """FLAGS with the bad value in place of its flag's (a new flag appended)."""
    args = list(flags)
    if bad[0] in args:
        args[args.index(bad[0]) + 1] = bad[1]
        return args
    return [*args, *bad]


@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_command_refuses_each_bad_flag_naming_it(command: str, tmp_path: Path) -> None:
    """Each bad value: exit status 2, one ``error: --flag=…`` line, nothing written. The first command of the
    list runs as its own process; the others through typer in-process (the same code after argument parsing)."""
    from typer.testing import CliRunner

    from pfield.cli import app

    base = [part.format(tmp=tmp_path) for part in COMMANDS[command]]
    if command == "ros2 node":
        pytest.importorskip("rclpy")
    runner = CliRunner()
    for i, (bad, says) in enumerate(BAD):
        args = [*base, *_with(FLAGS, bad)]
        if i == 0:
            done = pfield(*args)
            code, stderr = done.returncode, done.stderr
        else:
            result = runner.invoke(app, args)
            code, stderr = result.exit_code, result.stderr
        assert code == 2, (bad, stderr)
        assert stderr.startswith(says), (bad, stderr)
        assert bad[0] != "--srdf" or bad[1] != str(PANDA_SRDF) or "it describes another robot: none of the links " \
            "it names (panda_hand, panda_leftfinger, panda_link0, panda_link1, …) is a link of the URDF" in stderr
        assert bad[1] != f"meshes={UR5}" or "on the command line --package-path meshes=DIR" in stderr, stderr
        assert stderr.count("\n") == 1, stderr
    assert list(tmp_path.iterdir()) == []


def test_plan_refuses_robot_flags_without_a_robot_and_a_bad_start(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from pfield.cli import app

    runner = CliRunner()
    out = str(tmp_path / "never.png")
    result = runner.invoke(app, ["plan", "--srdf", str(UR5 / "ur5.srdf"), "-o", out])
    assert result.exit_code == 2 and result.stderr.startswith("error: --robot=None: --start-joints, --srdf"), \
        result.stderr
    for start, says in ((None, "a whole-body plan (--robot) starts from joint positions: give 6 comma-separated "
                               "values (rad or m) for shoulder_pan_joint,"),
                        ("0,0,0", "expected 6"),
                        ("0,0,0,0,0,9", "outside the limits of wrist_3_joint"),
                        ("up", "expected 6 comma-separated numbers or a named state; named states: home")):
        args = ["plan", *FLAGS, "-o", out] + ([] if start is None else ["--start-joints", start])
        result = runner.invoke(app, args)
        assert result.exit_code == 2 and result.stderr.startswith("error: --start-joints") and \
            says in result.stderr, result.stderr
    # a locked joint leaves the robot five: six values are one too many
    result = runner.invoke(app, ["plan", *FLAGS, "--locked-joint", "wrist_3_joint=0", "--start-joints",
                                 ",".join(map(str, START)), "-o", out])
    assert result.exit_code == 2 and "expected 5 numbers, for shoulder_pan_joint, shoulder_lift_joint, elbow_joint, " \
        "wrist_1_joint, wrist_2_joint (locked joints excluded), got 6" in result.stderr, result.stderr
    assert list(tmp_path.iterdir()) == []


def test_view_without_a_robot_refuses_robot_flags(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from pfield.cli import app

    out = tmp_path / "never.html"
    result = CliRunner().invoke(app, ["view", "--robot", "none", "--end-effector", "tool0", "--export", str(out)])
    assert result.exit_code == 2 and result.stderr.startswith("error: --robot='none': --srdf, --end-effector and "
                                                              "--locked-joint describe a robot"), result.stderr
    assert not out.exists()


def test_an_error_found_while_building_the_model_names_its_flag(tmp_path: Path) -> None:
    """What only pinocchio finds (here a joint whose child link does not exist) is named by flag, as the checks
    made before it are: ``--robot``, not the library's ``urdf``."""
    from typer.testing import CliRunner

    from pfield.cli import app

    urdf = tmp_path / "arm.urdf"
    urdf.write_text('<robot name="arm"><link name="base"/><link name="tip"/><joint name="j" type="revolute">'
                    '<parent link="base"/><child link="nowhere"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
                    '</joint></robot>')
    for command in (["plan", "--scene", str(SCENE), "--start-joints", "0", "-o", str(tmp_path / "never.png")],
                    ["view", "--export", str(tmp_path / "never.html")]):
        result = CliRunner().invoke(app, [*command, "--robot", str(urdf), "--end-effector", "tip"])
        assert result.exit_code == 2, result.stderr
        # (a long path is quoted cut in its middle: its end names the file)
        assert result.stderr.startswith("error: --robot='") and "arm.urdf': pinocchio could not parse it" in \
            result.stderr, result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm.urdf"]


def test_relative_paths_from_another_folder_name_the_robot_first_and_where_they_were_looked_for(
        tmp_path: Path) -> None:
    """The docs' ``R=../shared/…`` flags typed in another folder: the URDF is named first (not its package root),
    with the absolute path it was looked for at; then, the URDF given absolutely, the SRDF and the package root."""
    relative = "../shared/benchmarks/mbm/ur5"
    tmp_path = tmp_path / "elsewhere" / "here"  # where ../shared is not (tmp_path's own parent may be /tmp)
    tmp_path.mkdir(parents=True)
    flags = ["--robot", f"{relative}/ur5.urdf", "--srdf", f"{relative}/ur5.srdf", "--end-effector", "tool0",
             "--package-path", f"meshes={relative}/meshes"]
    command = ["plan", "--scene", str(SCENE), "--start-joints", "home", "-o", "never.png"]
    done = pfield(*command, *flags, cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.startswith(
        f"error: --robot='{relative}/ur5.urdf': no such URDF file (looked for {tmp_path}/{relative}/ur5.urdf: "
        "relative paths are read from the current folder)"), done.stderr
    done = pfield(*command, *flags[2:], "--robot", str(UR5 / "ur5.urdf"), cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.startswith(f"error: --srdf='{relative}/ur5.srdf': no such SRDF file "
                                                           f"(looked for {tmp_path}/{relative}/ur5.srdf"), done.stderr
    done = pfield(*command, *flags[4:], "--robot", str(UR5 / "ur5.urdf"), cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.startswith(
        f"error: --package-path='meshes={relative}/meshes': {relative}/meshes is not a directory (looked for "
        f"{tmp_path}/{relative}/meshes"), done.stderr
    assert list(tmp_path.iterdir()) == []
