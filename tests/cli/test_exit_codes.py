"""Exit statuses a script can trust (issue 33 items 1-3): 0 done, 1 the outcome failed, 2 the command is wrong.

Against the real ``pfield serve`` of the session (``node_server``) or a real HTTP server in a thread, through the
real CLI, as a script would run it.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
from pathlib import Path
from urllib.parse import urlsplit

import pytest
from pfield_node_server import PFIELD, NodeServer, free_port
from typer.testing import CliRunner

from pfield.cli import app
from serve_process import pfield_serve

REMOVE = "potential_fields_interfaces/srv/RemoveObstacles"
PLAN = "potential_fields_interfaces/srv/PlanPath"
FIND_VALID_POSE = "potential_fields_interfaces/srv/FindValidPose"
FOOTPRINT = "[[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25], [0.4, -0.25]]"


def test_service_call_exits_1_when_the_response_says_success_false(node_server: NodeServer) -> None:
    """``pfield service call … && send_to_robot`` went ahead after ``success: false`` (exit 0)."""
    refused = node_server.cli("service", "call", "/pfield/remove_obstacles", REMOVE, "{frame_ids: ['no_such_id']}")
    assert refused.returncode == 1, refused.stderr
    assert refused.stdout.startswith("response:\nsuccess: false")
    assert refused.stderr.strip().splitlines()[-1].startswith("success: false (message: ")
    failed_plan = node_server.cli(
        "service", "call", "--field", "success", "/pfield/plan_path", PLAN,
        "{start: {position: {x: 0.3, y: 0.0, z: 0.3}}, goal: {position: {x: 9.0, y: 0.0, z: 0.3}}, "
        "max_iterations: 3, planning_method: 'task_space'}")
    assert (failed_plan.returncode, failed_plan.stdout.strip()) == (1, "false"), failed_plan.stderr
    as_ros2 = node_server.cli("service", "call", "--exit-zero", "/pfield/remove_obstacles", REMOVE,
                              "{frame_ids: ['no_such_id']}")
    assert as_ros2.returncode == 0 and "success: false" in as_ros2.stderr
    listed = node_server.cli("service", "call", "/pfield/remove_obstacles", REMOVE, "{frame_ids: []}")
    assert listed.returncode == 0 and "success: true" in listed.stderr.strip().splitlines()[-1], listed.stderr


def test_a_wrong_command_exits_2_a_failed_outcome_1(node_server: NodeServer) -> None:
    assert node_server.cli("interface", "show", "nope/msg/Nope").returncode == 2  # checked locally
    assert node_server.cli("param", "get", "/pfield_manager", "nope").returncode == 2  # no such parameter
    assert node_server.cli("node", "info", "/nobody").returncode == 2
    refused = node_server.cli("param", "set", "/pfield_manager", "influence_distance", "--", "-0.5")
    assert refused.returncode == 2 and "influence_distance" in refused.stderr  # the node's 400
    silent = node_server.cli("topic", "echo", "--once", "--timeout", "0.5", "/pfield/nothing_published_here")
    assert silent.returncode == 1 and "no message" in silent.stderr
    assert node_server.cli("service", "call", "/pfield/plan_path", PLAN, "{goal: {position: {x: 1.0}").returncode == 2


def test_find_valid_pose_names_its_state_constant() -> None:
    """``state: 1`` (and ``--field state`` → ``1``) said nothing to a user who expects INSCRIBED."""
    from pfield.costmap._example import example_map_path
    from pfield.node._base import Bus
    from pfield.node.costmap_server import costmap_node_from_options
    from pfield.transport.http import ServerThread, create_app

    node = costmap_node_from_options(Bus(), example_map_path(), FOOTPRINT)
    request = "{pose: {header: {frame_id: map}, pose: {position: {x: -1.0, y: -1.6}}}, dist_tolerance: 1.0, costmap: 2}"
    runner = CliRunner()
    with ServerThread(create_app([node])) as server:
        whole = runner.invoke(app, ["service", "call", "--url", server.url, "/pfield/find_valid_pose",
                                    FIND_VALID_POSE, request])
        one = runner.invoke(app, ["service", "call", "--url", server.url, "--field", "state",
                                  "/pfield/find_valid_pose", FIND_VALID_POSE, request])
    assert whole.exit_code == 0 and "\nstate: 1  # INSCRIBED\n" in whole.stdout, whole.output
    assert one.exit_code == 0 and one.stdout == "1  # INSCRIBED\n", one.output


def test_find_valid_pose_exits_1_when_no_pose_is_found(tmp_path: os.PathLike[str]) -> None:
    lethal = CliRunner().invoke(app, ["find-valid-pose", "--x", "-1.0", "--y", "-2.0", "--dist-tolerance", "0.05",
                                      "--angle-tolerance", "0", "-o", str(tmp_path) + "/fvp.png"])
    assert lethal.exit_code == 1 and "state_name: LETHAL" in lethal.stdout, lethal.output


def _serve(*args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PFIELD_TOKEN"}
    return subprocess.run([str(PFIELD), "serve", *args], capture_output=True, text=True, env=env, check=False,
                          timeout=120)


def test_serve_on_a_port_in_use_exits_2_before_printing_anything(node_server: NodeServer) -> None:
    """It printed ``pfield node on http://…``, then uvicorn's ``address already in use``, while the user's next
    command talked to the old node."""
    port = urlsplit(node_server.url).port
    done = _serve("--port", str(port))
    assert done.returncode == 2 and done.stdout == "", done.stderr
    assert done.stderr == (f"error: --port={port}: 127.0.0.1:{port} is in use (a pfield node answers there): stop "
                           "the process that holds it, or serve on another port with --port N (and point clients at "
                           "it with --url or PFIELD_URL)\n")
    with socket.socket() as holder:  # any other program
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        other = holder.getsockname()[1]
        done = _serve("--port", str(other))
    assert done.returncode == 2 and done.stderr.startswith(f"error: --port={other}: 127.0.0.1:{other} is in use: ")


@pytest.mark.parametrize(("robot", "says"), [
    ("ur5", "error: --robot='ur5': neither a built-in robot (panda, xarm7) nor a URDF file: give a built-in name, "
            "or --robot FILE.urdf --end-effector LINK\n"),
    ("{urdf}", "error: --end-effector=None: a URDF robot needs its end-effector link (the link whose pose is "
               "planned); links of arm.urdf: base\n"),
])
def test_serve_names_an_unknown_robot_before_the_end_effector(robot: str, says: str, tmp_path: os.PathLike[str]
                                                              ) -> None:
    """``--robot ur5`` answered ``--end-effector=None: a URDF robot needs --end-effector LINK``."""
    urdf = f"{tmp_path}/arm.urdf"
    with open(urdf, "w") as file:
        file.write("<robot name='arm'><link name='base'/></robot>")
    done = _serve("--robot", robot.format(urdf=urdf), "--port", str(free_port()))
    assert done.returncode == 2 and done.stderr.startswith(says.format(urdf=urdf)), done.stderr


@pytest.mark.parametrize("command", [["ros2", "node"], ["ros2", "execute", "trajectory.yaml"]])
@pytest.mark.parametrize("extra", [["--pramas", "servo.yaml"], ["panda"]])
def test_ros2_commands_refuse_what_is_neither_their_option_nor_after_ros_args(command: list[str],
                                                                              extra: list[str]) -> None:
    """A misspelled option was handed to rclpy, which ignored it: the node started without its parameters."""
    result = CliRunner().invoke(app, [*command, *extra])
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith(f"error: argument={extra[0]!r}: not an option of") and "--ros-args" in \
        result.stderr


@pytest.mark.parametrize("command", [["serve"], ["ros2", "node"], ["view", "--export", "never.html"]])
def test_a_misspelled_log_level_is_a_usage_error(command: list[str]) -> None:
    result = CliRunner().invoke(app, [*command, "--log-level", "verbose"])
    assert result.exit_code == 2 and "'verbose' is not one of" in result.output and "Traceback" not in result.output


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM])
def test_serve_stopped_by_ctrl_c_or_sigterm_exits_0(stop: int, tmp_path: Path) -> None:
    """A stop asked for is a clean end, as for pfield ros2 node: uvicorn raised the signal again after its graceful
    shutdown, so the process died by it (status 130 or 143, outside the documented three)."""
    with pfield_serve(log=tmp_path / "serve.log", stop=stop) as (_, process):
        pass
    assert process.returncode == 0, (tmp_path / "serve.log").read_text()


@pytest.mark.parametrize("command", [["serve"], ["ros2", "node"]])
def test_ctrl_c_while_a_server_starts_is_a_quiet_stop(command: list[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C before the signal handlers are in place (the robot still loading) printed a KeyboardInterrupt traceback;
    it is the same asked-for stop as later: one line, status 0."""
    import pfield.cli._node
    import pfield.cli._ros2

    def interrupted(*_: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(pfield.cli._node, "robot_description", interrupted)
    monkeypatch.setattr(pfield.cli._ros2, "robot_description", interrupted)
    result = CliRunner().invoke(app, [*command, *(["--port", str(free_port())] if command == ["serve"] else [])])
    assert result.exit_code == 0 and result.stderr.strip() == "stopped", result.output


@pytest.mark.parametrize(("args", "says"), [
    (["find-valid-pose", "--x", "-1", "--y", "-1.6", "--yaw", "inf"], "--yaw=inf: must be finite"),
    (["find-valid-pose", "--x", "-1", "--y", "-1.6", "-o", "{tmp}/f.txt"], "not a picture format pfield writes"),
    (["find-valid-pose", "--x", "-1", "--y", "-1.6", "-o", "{tmp}/no/f.png"], "does not exist"),
    (["plan", "-o", "{tmp}/p.txt"], "not a picture format pfield writes"),
    (["plot2d", "-o", "{tmp}/a_file"], "is a file; give a folder"),
    (["sim2d", "grid_pass", "-o", "{tmp}/a_file"], "is a file; give a folder"),
    (["sim2d", "{tmp}/long.yaml", "-o", "{tmp}/out"], "steps, above 1e+06; simulate less time"),
])
def test_outputs_and_values_are_checked_before_the_work(args: list[str], says: str, tmp_path: Path) -> None:
    """These planned, drew or simulated first and then failed with a traceback (matplotlib's unknown format, a
    FileExistsError, a math domain error; YAML's 1e9 is text, and a billion-second run would not end)."""
    (tmp_path / "a_file").write_text("")
    (tmp_path / "long.yaml").write_text("name: long\nstart: [0, 0, 0]\ngoal: [1, 0]\nduration: 1e9\n")
    result = CliRunner().invoke(app, [a.replace("{tmp}", str(tmp_path)) for a in args])
    assert result.exit_code == 2, result.output
    assert says in " ".join(result.stderr.split()) and "Traceback" not in result.output
    assert "error" not in result.stdout  # a script's stdout gets results, not the complaint
