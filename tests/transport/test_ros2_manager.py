"""Acceptance test of the ROS 2 node: the real ``/pfield_manager`` (``pfield ros2 node``) driven by a second
rclpy process with the seed document's examples, in a private network namespace.

The node process resolves the seed's ``package://my_robot_description/meshes/obstacle.dae`` through
``--package-path`` (tests/data/my_robot_description). ``ros2_helpers/manager_scenario.py`` is the client.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import pytest
from ros2_helpers.support import HELPERS, REPO, require_netns, require_ros2_python, run_scenario

import seed_examples as seed

pytestmark = [pytest.mark.ros2, pytest.mark.slow]

XARM7_JOINTS = [f"joint{i}" for i in range(1, 8)]
SEED_IDS = sorted(seed.OBSTACLES)
PARAMS_YAML = """\
pfield_manager:
  ros__parameters:
    dynamic_obstacle_timeout: 7.5
costmap:
  ros__parameters:
    inflation_radius: 0.3
"""


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    require_ros2_python()
    require_netns()
    out = tmp_path_factory.mktemp("ros2_manager")
    package = REPO / "tests" / "data" / "my_robot_description"
    params = out / "params.yaml"
    params.write_text(PARAMS_YAML)
    node = [str(Path(sys.executable).with_name("pfield")), "ros2", "node", "--robot", "xarm7",
            "--package-path", f"my_robot_description={package}", "--params", str(params),
            "--ros-args", "-p", "dynamic_obstacle_timeout:=8.5"]
    return run_scenario(node, [sys.executable, str(HELPERS / "manager_scenario.py")], out)


def _distance(a: list[float], b: tuple[float, ...]) -> float:
    return math.dist(a, b)


def test_parameters_from_the_yaml_file_and_ros_args(session: dict[str, Any]) -> None:
    assert session["results"]["startup_parameters"] == {
        "/pfield_manager": {"dynamic_obstacle_timeout": 8.5, "influence_distance": 0.1},  # -p wins over YAML
        "/costmap": {"inflation_radius": 0.3},
    }


def test_seed_obstacles_are_all_held_and_drawn(session: dict[str, Any]) -> None:
    results = session["results"]
    assert results["held_after_seed"] == SEED_IDS  # the mesh one resolved through the package path
    assert {"obstacles", "influence"} <= set(results["marker_namespaces"])


@pytest.mark.parametrize("method", ["task_space", "whole_body"])
def test_seed_plan_path_reaches_the_goal(session: dict[str, Any], method: str) -> None:
    plan = session["results"][f"plan_{method}"]
    assert plan["success"] is True, plan["error_message"]
    assert plan["error_message"] == ""
    assert _distance(plan["final_position"], seed.GOAL) <= 0.01 + 1e-6  # the request's goal_tolerance
    assert plan["path_frame"] == "world"
    assert plan["twists"] == plan["poses"]  # one end-effector twist per step
    if method == "whole_body":
        assert plan["joint_names"] == XARM7_JOINTS
        assert plan["joint_points"] == plan["poses"] and plan["joint_point_sizes"] == [7]
    # the same path was published on /pfield/planned_path
    assert session["results"][f"planned_path_{method}"] == {"poses": plan["poses"], "frame": "world"}


def test_path_marker_published(session: dict[str, Any]) -> None:
    assert session["results"]["path_marker_points"] > 1


def test_seed_task_space_autonomy_vector_points_to_the_goal(session: dict[str, Any]) -> None:
    velocity = session["results"]["autonomy_task_space"]
    to_goal = [g - q for g, q in zip(seed.GOAL, seed.QUERY, strict=True)]
    # no obstacle within the influence distance of the query pose: straight at the goal, at the default
    # max_linear_velocity (0.05 m/s; the attraction 3.0 * 0.229 m is far above it)
    assert math.hypot(*velocity) == pytest.approx(0.05, rel=1e-6)
    assert [v / 0.05 for v in velocity] == pytest.approx([d / math.hypot(*to_goal) for d in to_goal], abs=1e-6)


def test_seed_whole_body_autonomy_vector_points_to_the_goal(session: dict[str, Any]) -> None:
    velocity = session["results"]["autonomy_whole_body"]
    assert all(math.isfinite(v) for v in velocity) and math.hypot(*velocity) > 0.0
    # evaluated at the end effector of the seed's joint angles (FK = the seed's task-space start)
    to_goal = [g - q for g, q in zip(seed.GOAL, seed.SEED_JOINTS_END_EFFECTOR, strict=True)]
    assert sum(v * d for v, d in zip(velocity, to_goal, strict=True)) > 0.0


def test_query_pose_topic_answers_on_autonomy_vector_topic(session: dict[str, Any]) -> None:
    results = session["results"]
    assert results["autonomy_topic"] == results["autonomy_task_space"]  # same pose, same answer as the service


def test_parameter_change_takes_effect_and_bad_values_are_refused(session: dict[str, Any]) -> None:
    results = session["results"]
    assert results["set_max_linear_velocity"] == [[True, ""]]
    assert math.hypot(*results["autonomy_task_space"]) > 0.01
    assert math.hypot(*results["autonomy_task_space_slow"]) <= 0.01 + 1e-9
    (ok, reason), = results["set_bad"]
    assert not ok and "max_linear_velocity" in reason and "-1.0" in reason
    (ok, reason), = results["set_bad_influence"]
    assert not ok and "influence_distance" in reason
    assert results["params_after"]["max_linear_velocity"] == 0.01
    assert results["params_after"]["influence_distance"] == 0.1


def test_bad_obstacles_leave_the_node_serving_with_its_state(session: dict[str, Any]) -> None:
    results = session["results"]
    assert results["held_after_bad"] == sorted([*SEED_IDS, "probe"])  # nothing of the bad messages was added
    assert results["remove_probe"] is True
    assert results["autonomy_unchanged_by_bad"] is True
    log = session["logs"]["node.log"]
    for fragment in ("obstacles[1].radius", "obstacles[0].type", "file:///etc/passwd", "package://nowhere"):
        assert fragment in log, fragment


def test_clean_shutdown(session: dict[str, Any]) -> None:
    # nothing left in the session's private /dev/shm (Fast DDS segments outlive an aborted process)
    assert session["session"] == {"client_returncode": 0, "node_returncode": 0, "node_died_early": False,
                                  "node_killed": False, "shm_left": []}
    assert "terminate called" not in session["logs"]["node.log"]


def test_base_controller_and_costmap_nodes_in_the_same_process(session: dict[str, Any]) -> None:
    results = session["results"]
    forward, sideways, _turn = results["cmd_vel"]  # goal 2 m straight ahead, open laser scan
    assert 0.0 < math.hypot(forward, sideways) <= results["max_spd_norm"] + 1e-9
    free_state, x, y, frame = results["find_valid_pose_free"]
    assert (free_state, x, y, frame) == (0, 0.3, 0.3, "map")  # FREE, and the requested pose itself
    assert results["find_valid_pose_blocked"] == 2  # LETHAL: inside the block, no tolerance to move
    assert results["find_valid_pose_bad_costmap"] == 2  # refused: LETHAL, never FREE
    assert "costmap=7: must be 1 (LOCAL_COSTMAP) or 2 (GLOBAL_COSTMAP)" in session["logs"]["node.log"]
