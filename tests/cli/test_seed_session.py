"""The seed document's CLI examples, verbatim (``ros2`` → ``pfield``), against a real ``pfield serve``."""

from __future__ import annotations

import math
import shlex
from typing import Any

import httpx
import numpy as np
import pytest
import yaml
from pfield_node_server import NodeServer

from seed_examples import (
    AUTONOMY_TASK_SPACE_COMMAND,
    AUTONOMY_WHOLE_BODY_COMMAND,
    GOAL,
    GOAL_TOLERANCE,
    OBSTACLE_COMMANDS,
    PLAN_TASK_SPACE_COMMAND,
    PLAN_WHOLE_BODY_COMMAND,
    QUERY,
    SEED_JOINTS_END_EFFECTOR,
)


def call_seed(server: NodeServer, command: str) -> dict[str, Any]:
    argv = shlex.split(command)
    assert argv[:3] == ["ros2", "service", "call"]
    return server.call(*argv[3:])


def check_plan(response: dict[str, Any], dt: float = 0.02) -> None:
    assert response["success"] is True, response["error_message"]
    assert response["error_message"] == ""
    poses = response["end_effector_path"]["poses"]
    end = poses[-1]["pose"]["position"]
    assert math.dist((end["x"], end["y"], end["z"]), GOAL) <= GOAL_TOLERANCE
    twists = response["end_effector_velocity_trajectory"]
    assert len(twists) == len(poses) > 1
    for i in (0, 1, len(poses) - 1):
        stamp = poses[i]["header"]["stamp"]
        assert stamp["sec"] + 1e-9 * stamp["nanosec"] == pytest.approx(i * dt, abs=1e-6)
        assert twists[i]["header"]["stamp"] == stamp
        assert poses[i]["header"]["frame_id"] == "world"


def test_all_six_seed_obstacles_are_accepted(seeded: NodeServer) -> None:
    assert sorted(seeded.obstacle_ids()) == sorted(OBSTACLE_COMMANDS)
    markers = seeded.cli("topic", "echo", "--once", "/pfield/markers")
    assert markers.returncode == 0
    assert "package://my_robot_description/meshes/obstacle.dae" in markers.stdout


def test_seed_task_space_plan_reaches_the_goal_among_all_obstacles(seeded: NodeServer) -> None:
    response = call_seed(seeded, PLAN_TASK_SPACE_COMMAND)
    check_plan(response)
    start = response["end_effector_path"]["poses"][0]["pose"]["position"]
    assert (start["x"], start["y"], start["z"]) == pytest.approx((0.227, 0.0, 0.294))


def test_seed_whole_body_plan_reaches_the_goal_among_all_obstacles(seeded: NodeServer) -> None:
    response = call_seed(seeded, PLAN_WHOLE_BODY_COMMAND)
    check_plan(response)
    trajectory = response["joint_trajectory"]
    assert len(trajectory["joint_names"]) == 7
    assert len(trajectory["points"]) == len(response["end_effector_path"]["poses"])
    first = trajectory["points"][0]["positions"]
    assert first == pytest.approx([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], abs=1e-6)


@pytest.mark.parametrize(("command", "where"), [(AUTONOMY_TASK_SPACE_COMMAND, QUERY),
                                               (AUTONOMY_WHOLE_BODY_COMMAND, SEED_JOINTS_END_EFFECTOR)],
                         ids=["task_space", "whole_body"])
def test_seed_autonomy_vector_points_toward_the_goal(seeded: NodeServer, command: str,
                                                     where: tuple[float, float, float]) -> None:
    goal = {"header": {"frame_id": "world"}, "pose": {"position": dict(zip("xyz", GOAL, strict=True)),
                                                      "orientation": {"x": 0.707, "z": 0.707, "w": 0.0}}}
    httpx.post(f"{seeded.url}/topic/pfield/planning_goal_pose", json=goal).raise_for_status()  # as plan_path does
    twist = call_seed(seeded, command)["autonomy_vector"]
    linear = np.array([twist["twist"]["linear"][k] for k in "xyz"])
    angular = np.array([twist["twist"]["angular"][k] for k in "xyz"])
    assert np.all(np.isfinite(linear)) and np.all(np.isfinite(angular))
    assert twist["header"]["frame_id"] == "world"
    assert float(np.dot(linear, np.subtract(GOAL, where))) > 0.0


def test_plans_are_saved_as_csv(seeded: NodeServer) -> None:
    request = yaml.safe_load(shlex.split(PLAN_TASK_SPACE_COMMAND)[-1])
    assert httpx.post(f"{seeded.url}/srv/pfield/plan_path", json=request).json()["success"]
    files = sorted(seeded.csv_dir.glob("plan_*_task_space.csv"))
    assert files
    lines = files[-1].read_text().splitlines()
    assert lines[0].startswith("time,x,y,z,qx,qy,qz,qw")
    assert len(lines) > 2
