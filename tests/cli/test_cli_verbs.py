"""The ros2-like verbs against the running server: listings, parameters, echo, interface show, errors."""

from __future__ import annotations

import os
import subprocess

import pytest
import yaml
from pfield_node_server import PFIELD, NodeServer, free_port


def test_listings(node_server: NodeServer) -> None:
    services = node_server.cli("service", "list", "-t")
    assert services.returncode == 0
    assert "/pfield/plan_path [potential_fields_interfaces/srv/PlanPath]" in services.stdout.splitlines()
    assert "/pfield/compute_autonomy_vector" in node_server.cli("service", "list").stdout.split()
    topics = node_server.cli("topic", "list", "-t").stdout.splitlines()
    assert "/pfield/obstacles [potential_fields_interfaces/msg/ObstacleArray]" in topics
    assert "/pfield/markers [visualization_msgs/msg/MarkerArray]" in topics


def test_parameters_get_set_dump(node_server: NodeServer) -> None:
    assert node_server.cli("param", "get", "/pfield_manager", "repulsive_gain").stdout.strip() == "0.3"
    done = node_server.cli("param", "set", "/pfield_manager", "repulsive_gain", "0.5")
    assert done.returncode == 0 and "successful" in done.stdout
    dumped = yaml.safe_load(node_server.cli("param", "dump", "/pfield_manager").stdout)
    assert dumped["/pfield_manager"]["ros__parameters"]["repulsive_gain"] == 0.5
    assert node_server.cli("param", "set", "/pfield_manager", "repulsive_gain", "0.3").returncode == 0
    missing = node_server.cli("param", "get", "/pfield_manager", "nope")
    assert missing.returncode == 2 and "nope" in missing.stderr  # a wrong command: exit 2 (docs/node.md)
    assert node_server.cli("param", "get", "/nobody", "x").returncode == 2


def test_publish_goal_and_echo_it(node_server: NodeServer) -> None:
    goal = "{header: {frame_id: 'world'}, pose: {position: {x: 0.5, y: 0.2, z: 0.4}}}"
    published = node_server.cli("topic", "pub", "--times", "2", "--rate", "50", "/pfield/planning_goal_pose",
                                "geometry_msgs/msg/PoseStamped", goal)
    assert published.returncode == 0 and "publishing #2" in published.stderr
    echoed = node_server.cli("topic", "echo", "--once", "/pfield/planning_goal_pose")
    assert echoed.returncode == 0
    message = yaml.safe_load(echoed.stdout.split("---")[0])
    assert message["pose"]["position"] == {"x": 0.5, "y": 0.2, "z": 0.4}
    markers = yaml.safe_load(node_server.cli("topic", "echo", "--once", "/pfield/markers").stdout.split("---")[0])
    assert any(m["ns"] == "goal" for m in markers["markers"])


def test_interface_show_prints_the_definition(node_server: NodeServer) -> None:
    shown = node_server.cli("interface", "show", "potential_fields_interfaces/srv/PlanPath")
    assert shown.returncode == 0
    assert 'string PLANNING_METHOD_TASK_SPACE="task_space"' in shown.stdout and "\n---\n" in shown.stdout
    pose = node_server.cli("interface", "show", "geometry_msgs/msg/Pose").stdout.splitlines()
    assert "Point position" in pose and "Quaternion orientation" in pose
    assert node_server.cli("interface", "show", "nope/msg/Nope").returncode == 2


@pytest.mark.parametrize("command", [["service", "list"], ["topic", "echo", "--once", "/pfield/planned_path"],
                                     ["topic", "hz", "/pfield/planned_path"]], ids=" ".join)
def test_unreachable_server_is_a_clear_error(command: list[str]) -> None:
    """Every verb that finds no node says so in the same words, with what to do."""
    url = f"http://127.0.0.1:{free_port()}"
    done = subprocess.run([str(PFIELD), *command], capture_output=True, text=True, env=os.environ | {"PFIELD_URL": url},
                          check=False)
    assert done.returncode == 1
    assert done.stderr.startswith(f"error: cannot reach the pfield node at {url} (")
    assert done.stderr.rstrip().endswith("start it with `pfield serve`")


def test_serve_refuses_other_hosts_without_a_token() -> None:
    env = {k: v for k, v in os.environ.items() if k != "PFIELD_TOKEN"}
    done = subprocess.run([str(PFIELD), "serve", "--host", "0.0.0.0", "--port", str(free_port())],
                          capture_output=True, text=True, env=env, check=False, timeout=120)
    assert done.returncode == 2 and "--token" in done.stderr


def test_echo_into_a_closed_pipe_stops_quietly(node_server: NodeServer) -> None:
    goal = "{header: {frame_id: 'world'}, pose: {position: {x: 0.5, y: 0.2, z: 0.4}}}"
    assert node_server.cli("topic", "pub", "--once", "/pfield/planning_goal_pose",
                           "geometry_msgs/msg/PoseStamped", goal).returncode == 0
    echo = subprocess.Popen([str(PFIELD), "topic", "echo", "/pfield/planning_goal_pose", "--url", node_server.url],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert echo.stdout is not None and echo.stderr is not None
    echo.stdout.readline()  # the latest message arrives first
    echo.stdout.close()  # what `| head -1` does
    node_server.cli("topic", "pub", "--times", "3", "--rate", "20", "/pfield/planning_goal_pose",
                    "geometry_msgs/msg/PoseStamped", goal)
    assert echo.wait(timeout=60) == 0
    assert "Broken pipe" not in echo.stderr.read().decode()
