"""pfield's FollowJointTrajectory client (:mod:`pfield.transport.trajectory_client`).

Goal building and every refusal run in process (no ROS traffic). The behaviour against a real rclpy action
server (``ros2_helpers/trajectory_server.py``: joints joint1–joint3, a kinematic arm and a rate-limited one)
runs in a private network namespace: success with feedback, INVALID_JOINTS, cancel mid-way, a path tolerance
violated, no server (a clear timeout error), and ``pfield ros2 execute``'s exit codes.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from ros2_helpers.support import HELPERS, missing, require_netns, require_ros2_python, run_scenario

from pfield.errors import InvalidInput
from pfield.interfaces.trajectory_msgs import JointTrajectory
from pfield.planning.retime import retime_joint_path
from pfield.transport.trajectory_client import (
    ExecutionOptions,
    TrajectoryClient,
    TrajectoryErrorCode,
    TrajectoryOutcome,
    TrajectoryResult,
    as_timed_trajectory,
    build_goal,
)

pytestmark = pytest.mark.ros2
JOINTS = ["joint1", "joint2", "joint3"]


def require_control_msgs() -> None:
    if importlib.util.find_spec("control_msgs") is None:
        missing("control_msgs (ros/control_msgs) is not built: run `make ros2-interfaces`")


@pytest.fixture(autouse=True)
def _ros2() -> None:
    require_ros2_python()
    require_control_msgs()


def _timed() -> Any:
    return retime_joint_path(JOINTS, np.linspace([0, 0, 0], [0.6, -0.4, 0.3], 25), np.full(3, 1.0),
                             np.full(3, 2.0), 0.05)


# ---- the goal (in process) ----------------------------------------------------------------------------------
def test_goal_carries_every_sample_with_its_time() -> None:
    timed = _timed()
    options = ExecutionOptions(path_tolerance={"joint1": 0.05}, goal_tolerance={"joint3": (0.01, 0.1, -1.0)},
                               goal_time_tolerance=0.25)
    goal = build_goal(timed, options)
    assert list(goal.trajectory.joint_names) == JOINTS
    assert len(goal.trajectory.points) == len(timed.times)
    for point, t, q, qd, qdd in zip(goal.trajectory.points, timed.times, timed.positions, timed.velocities,
                                    timed.accelerations, strict=True):
        assert point.time_from_start.sec + 1e-9 * point.time_from_start.nanosec == pytest.approx(t, abs=1e-9)
        assert list(point.positions) == q.tolist()
        assert list(point.velocities) == qd.tolist()
        assert list(point.accelerations) == qdd.tolist()
        assert 0 <= point.time_from_start.nanosec < 1_000_000_000
    assert [(r.name, r.position, r.velocity, r.acceleration) for r in goal.path_tolerance] == [("joint1", 0.05, 0, 0)]
    assert [(r.name, r.position, r.velocity, r.acceleration) for r in goal.goal_tolerance] == [
        ("joint3", 0.01, 0.1, -1.0)]
    assert (goal.goal_time_tolerance.sec, goal.goal_time_tolerance.nanosec) == (0, 250_000_000)
    assert (goal.trajectory.header.stamp.sec, goal.trajectory.header.stamp.nanosec) == (0, 0)  # start now


def test_goal_from_a_message_keeps_empty_derivatives_empty() -> None:
    message = JointTrajectory.model_validate({"joint_names": ["a", "b"], "points": [
        {"positions": [0.0, 1.0], "time_from_start": {"sec": 0, "nanosec": 500_000_000}},
        {"positions": [0.5, 1.5], "time_from_start": {"sec": 2, "nanosec": 0}}]})
    goal = build_goal(message)
    assert [list(p.positions) for p in goal.trajectory.points] == [[0.0, 1.0], [0.5, 1.5]]
    assert [list(p.velocities) for p in goal.trajectory.points] == [[], []]
    assert as_timed_trajectory(message).duration == 2.0


def test_plan_without_a_trajectory_is_refused() -> None:
    from pfield.field import FieldConfig, PotentialField
    from pfield.spatial import Pose

    path = PotentialField(FieldConfig(), Pose([0.3, 0.0, 0.3]), []).plan(Pose([0.25, 0.0, 0.3]), dt=0.02)
    assert path.success and path.trajectory is None  # task space without a robot: no joint trajectory
    with pytest.raises(InvalidInput) as error:
        build_goal(path)
    assert error.value.field == "path.trajectory"


def _message(**changes: Any) -> Any:
    points = [{"positions": [0.0, 0.0], "time_from_start": {"sec": 0}},
              {"positions": [0.1, 0.2], "time_from_start": {"sec": 1}}]
    return JointTrajectory.model_validate({"joint_names": ["a", "b"], "points": points} | changes)


@pytest.mark.parametrize(("trajectory", "field"), [
    (_message(joint_names=["a", "a"]), "trajectory.joint_names"),
    (_message(joint_names=["a", ""]), "trajectory.joint_names[1]"),
    (_message(points=[]), "trajectory.points"),
    (_message(points=[{"positions": [0.0, 0.0], "time_from_start": {"sec": 1}},
                      {"positions": [0.1, 0.2], "time_from_start": {"sec": 1}}]),
     "trajectory.points[1].time_from_start"),
    (_message(points=[{"positions": [0.0], "time_from_start": {"sec": 1}}]), "trajectory.points[0].positions"),
    (_message(points=[{"positions": [0.0, float("nan")], "time_from_start": {"sec": 1}}]),
     "trajectory.points[0].positions"),
    (_message(points=[{"positions": [0.0, 0.0], "velocities": [0.0, 0.0], "time_from_start": {"sec": 0}},
                      {"positions": [0.1, 0.2], "time_from_start": {"sec": 1}}]), "trajectory.points[1].velocities"),
    ("not a trajectory", "trajectory"),
])
def test_bad_trajectories_are_refused_naming_the_field(trajectory: Any, field: str) -> None:
    with pytest.raises(InvalidInput) as error:
        build_goal(trajectory)
    assert error.value.field == field


def test_bad_timed_trajectory_is_refused() -> None:
    timed = _timed()
    backwards = replace(timed, times=timed.times[::-1].copy())
    with pytest.raises(InvalidInput, match="time_from_start"):
        build_goal(backwards)


@pytest.mark.parametrize(("options", "field"), [
    ({"path_tolerance": {"joint1": -0.5}}, "path_tolerance['joint1']"),
    ({"goal_tolerance": {"joint1": (0.1, 0.2)}}, "goal_tolerance['joint1']"),
    ({"goal_tolerance": {"joint1": float("inf")}}, "goal_tolerance['joint1']"),
    ({"path_tolerance": [0.1]}, "path_tolerance"),
    ({"goal_time_tolerance": -1.0}, "goal_time_tolerance"),
    ({"server_timeout": float("nan")}, "server_timeout"),
    ({"accept_timeout": True}, "accept_timeout"),
])
def test_bad_options_are_refused_naming_the_field(options: dict[str, Any], field: str) -> None:
    with pytest.raises(InvalidInput) as error:
        ExecutionOptions(**options)
    assert error.value.field == field


def test_tolerance_for_a_joint_not_in_the_trajectory_is_refused() -> None:
    with pytest.raises(InvalidInput) as error:
        build_goal(_timed(), ExecutionOptions(path_tolerance={"elbow": 0.1}))
    assert error.value.field == "path_tolerance['elbow']"


@pytest.mark.parametrize("name", ["", "/", "bad name/follow", "/ctrl/1follow", 7])
def test_bad_action_name_is_refused_before_ros_starts(name: Any) -> None:
    with pytest.raises(InvalidInput) as error:
        TrajectoryClient(name)
    assert error.value.field == "controller_action"


def test_result_success_needs_succeeded_and_successful() -> None:
    ok = TrajectoryResult(TrajectoryOutcome.SUCCEEDED, TrajectoryErrorCode.SUCCESSFUL, "", 0.0, 1.0, 3)
    assert ok.success and ok.describe() == "SUCCEEDED (SUCCESSFUL)"
    aborted = replace(ok, outcome=TrajectoryOutcome.ABORTED, error_code=TrajectoryErrorCode.PATH_TOLERANCE_VIOLATED,
                      error_string="joint1 off")
    assert not aborted.success and aborted.describe() == "ABORTED (PATH_TOLERANCE_VIOLATED): joint1 off"
    assert not replace(ok, outcome=TrajectoryOutcome.REJECTED, error_code=None).success


# ---- against a real action server (private network namespace) ---------------------------------------------
@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    require_ros2_python()
    require_netns()
    out = tmp_path_factory.mktemp("trajectory_client")
    server = [sys.executable, str(HELPERS / "trajectory_server.py"), "--sim", "xarm7", *JOINTS]
    return run_scenario(server, [sys.executable, str(HELPERS / "trajectory_scenario.py")], out)


def test_success_streams_feedback_and_reaches_the_last_point(session: dict[str, Any]) -> None:
    success = session["results"]["success"]
    assert (success["outcome"], success["error_code_name"], success["success"]) == ("SUCCEEDED", "SUCCESSFUL", True)
    times = success["feedback_times"]
    assert success["feedback_count"] == len(times) > 10
    assert times == sorted(times) and times[-1] == pytest.approx(success["duration"], abs=0.02)
    assert success["final_actual"] == pytest.approx(success["target"], abs=1e-9)  # the kinematic arm
    assert success["feedback_joints"] == JOINTS


def test_wrong_joint_names_end_invalid_joints(session: dict[str, Any]) -> None:
    result = session["results"]["invalid_joints"]
    assert (result["outcome"], result["error_code"], result["error_code_name"]) == ("ABORTED", -2, "INVALID_JOINTS")
    assert "elbow" in result["error_string"]


def test_cancel_mid_way_stops_before_the_end(session: dict[str, Any]) -> None:
    cancel = session["results"]["cancel"]
    assert cancel["outcome"] == "CANCELED" and not cancel["success"]
    assert 0.3 * cancel["duration"] < cancel["last_feedback"] < cancel["duration"]
    assert session["results"]["after_cancel"]["outcome"] == "SUCCEEDED"


def test_lagging_arm_violates_the_path_tolerance(session: dict[str, Any]) -> None:
    result = session["results"]["path_tolerance"]
    assert (result["outcome"], result["error_code_name"]) == ("ABORTED", "PATH_TOLERANCE_VIOLATED")
    assert result["error_string"].startswith("joint1:")


def test_lagging_arm_misses_the_goal_in_time(session: dict[str, Any]) -> None:
    result = session["results"]["goal_tolerance"]
    assert (result["outcome"], result["error_code_name"]) == ("ABORTED", "GOAL_TOLERANCE_VIOLATED")
    assert "goal tolerance" in result["error_string"]


def test_physical_arm_follows_the_retimed_trajectory(session: dict[str, Any]) -> None:
    """The same server driving the xArm7 in MuJoCo (position servos, Menagerie's gains): the goal succeeds (within
    the server's 0.01 rad goal tolerance) and the servos track the reference closely all the way."""
    result = session["results"]["simulated"]
    assert (result["outcome"], result["error_code_name"]) == ("SUCCEEDED", "SUCCESSFUL")
    assert 0 < result["max_tracking_error"] < 0.1


def test_absent_server_is_a_clear_timeout_error(session: dict[str, Any]) -> None:
    absent = session["results"]["absent"]
    assert absent["raised"] == "ServerUnavailable"
    assert "/absent_controller/follow_joint_trajectory" in absent["message"]
    assert "server_timeout=1 s" in absent["message"]


def test_cli_exit_codes(session: dict[str, Any]) -> None:
    results = session["results"]
    assert results["cli_success"]["returncode"] == 0, results["cli_success"]["stderr"]
    assert "SUCCEEDED (SUCCESSFUL)" in results["cli_success"]["stderr"]
    assert results["cli_invalid_joints"]["returncode"] == 1
    assert "INVALID_JOINTS" in results["cli_invalid_joints"]["stderr"]
    assert results["cli_bad_file"]["returncode"] == 2
    assert "time_from_start" in results["cli_bad_file"]["stderr"]
    assert results["cli_absent"]["returncode"] == 1
    assert "no FollowJointTrajectory action server" in results["cli_absent"]["stderr"]


def test_session_ends_cleanly(session: dict[str, Any]) -> None:
    state = session["session"]
    assert state["client_returncode"] == 0 and not state["node_killed"] and state["node_returncode"] == 0
    assert "goals: [" in session["logs"]["node.log"]


# ---- pfield ros2 execute: refusals before ROS starts (exit 2) ---------------------------------------------
def test_cli_reads_stdin_and_refuses_a_bad_trajectory_there() -> None:
    from typer.testing import CliRunner

    from pfield.cli import app

    backwards = {"joint_names": JOINTS, "points": [{"positions": [0, 0, 0], "time_from_start": {"sec": 2}},
                                                    {"positions": [0, 0, 0], "time_from_start": {"sec": 1}}]}
    result = CliRunner().invoke(app, ["ros2", "execute", "-"], input=json.dumps(backwards))
    assert result.exit_code == 2, result.output
    assert "trajectory.points[1].time_from_start=1.0" in result.output


@pytest.mark.parametrize(("args", "says"), [
    (["missing.yaml"], "TRAJECTORY"),
    (["plan.json", "--path-tolerance", "joint1"], "--path-tolerance"),
    (["plan.json", "--goal-tolerance", "joint1=0.1,0.2"], "--goal-tolerance"),
    (["plan.json", "--goal-tolerance", "elbow=0.1"], "goal_tolerance['elbow']"),
    (["plan.json", "--server-timeout", "-1"], "server_timeout"),
    (["plan.json", "--action", "not a name"], "controller_action"),
])
def test_cli_refuses_bad_input_with_exit_2(args: list[str], says: str, tmp_path: Any,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    from typer.testing import CliRunner

    from pfield.cli import app

    timed = _timed()
    points = [{"positions": q.tolist(), "time_from_start": {"sec": int(t), "nanosec": 0}}
              for q, t in zip(timed.positions[::6], range(0, 25, 6), strict=True)]
    (tmp_path / "plan.json").write_text(json.dumps({"joint_trajectory": {"joint_names": JOINTS, "points": points}}))
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["ros2", "execute", *args])
    assert result.exit_code == 2, result.output
    assert says in result.output
