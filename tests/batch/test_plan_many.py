"""plan_many: stable order, the same records with 1 and 2 workers, per-problem errors, bad arguments."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from pfield.batch import (
    RECORD_FIELDS,
    TIMING_FIELDS,
    Workspace,
    check_settings,
    plan_many,
    problem_seed,
    ray_endpoint,
    solve,
)
from pfield.errors import InvalidInput
from pfield.planning import PlanOptions, PlanStatus
from pfield.scene import Problem, read_problems
from pfield.spatial import Pose


def _untimed(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k not in TIMING_FIELDS} for r in records]


@pytest.fixture(scope="module")
def one_worker(problem_paths: list[Path]) -> list[dict[str, Any]]:
    return list(plan_many(read_problems(problem_paths), workers=1))


def test_records_follow_the_input_order_and_a_malformed_problem_fails_alone(one_worker: list[dict[str, Any]]) -> None:
    assert [(r["scene"], r["index"]) for r in one_worker] == [("box_panda", 1), ("box_panda", 2), ("box_panda", 3),
                                                              ("scene", 0)]
    assert all(tuple(r) == RECORD_FIELDS for r in one_worker)
    good = [r for r in one_worker if r["index"] != 3]
    assert [r["status"] for r in good] == ["reached"] * 3
    assert all(r["success"] and r["error"] == "" and len(r["positions"]) == len(r["times"]) == r["steps"] + 1
               for r in good)
    assert good[0]["joint_names"] == [f"panda_joint{i}" for i in range(1, 8)] and good[2]["joint_names"] == []
    bad = one_worker[2]
    assert (bad["status"], bad["success"], bad["positions"]) == ("error", False, [])
    assert bad["error"].startswith("request0003.yaml: request.goal_constraints")


def test_two_workers_give_the_same_records(problem_paths: list[Path], one_worker: list[dict[str, Any]]) -> None:
    two = list(plan_many(read_problems(problem_paths), workers=2))
    assert _untimed(two) == _untimed(one_worker)


def test_a_problem_that_fails_while_planning_is_reported_and_the_batch_goes_on(problem_paths: list[Path]) -> None:
    good = read_problems(problem_paths)[0]
    missing_joint = Problem("broken", 7, good.obstacles, {"panda_joint1": 0.0}, goal_joints=good.goal_joints,
                            robot=good.robot, config=good.config, options=good.options)
    seen: list[str] = []
    records = list(plan_many([missing_joint, good], progress=lambda r: seen.append(r["status"])))
    assert [r["status"] for r in records] == seen == ["error", "reached"]
    assert records[0]["error"].startswith("InvalidInput: start") and "panda_joint2" in records[0]["error"]


def test_one_worker_in_this_process_is_warmed_up_before_its_first_problem(
        problem_paths: list[Path], monkeypatch: pytest.MonkeyPatch) -> None:
    """As a spawned worker is: every robot of the batch makes its warm-up plan before the first problem is timed,
    so no record's time carries the robot's first use."""
    import pfield.batch._solve as solving

    events: list[str] = []
    warm = solving._warm_plan
    monkeypatch.setattr(solving, "_warm_plan", lambda robot: events.append(f"warm {robot.name}") or warm(robot))
    problem = read_problems(problem_paths)[0]
    records = list(plan_many([problem], workers=1, progress=lambda r: events.append(f"record {r['index']}")))
    assert records[0]["status"] == "reached" and events == ["warm panda", "record 1"], events


def test_the_problem_seed_depends_on_the_key_and_seed_only() -> None:
    a, b = Problem("s", 1, start=Pose(), goal=Pose()), Problem("s", 2, start=Pose(), goal=Pose())
    assert problem_seed(0, a) == problem_seed(0, Problem("s", 1, start=Pose((1, 0, 0)), goal=Pose()))
    assert len({problem_seed(0, a), problem_seed(0, b), problem_seed(1, a)}) == 3
    assert solve("nope", Workspace())["status"] == "error"  # type: ignore[arg-type]


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"workers": 0}, "workers"), ({"workers": 1.5}, "workers"), ({"workers": True}, "workers"),
    ({"backend": "mpi"}, "backend"), ({"seed": "x"}, "seed"), ({"timeout": -1.0}, "timeout"),
    ({"timeout": float("inf")}, "timeout"), ({"address": "127.0.0.1:6379"}, "address"),
    ({"backend": "ray", "address": "127.0.0.1"}, "address"), ({"backend": "ray", "address": "host:0"}, "address"),
    ({"backend": "ray", "address": "ray://:6379"}, "address"), ({"backend": "ray", "address": "head:²"}, "address"),
])
def test_bad_arguments_are_refused_before_anything_runs(kwargs: dict[str, Any], field: str) -> None:
    problem = Problem("s", 0, start=Pose(), goal=Pose((0.1, 0, 0)))
    with pytest.raises(InvalidInput) as raised:
        plan_many([problem], **kwargs)
    assert raised.value.field == field


def test_ray_addresses_are_read_as_host_and_port() -> None:
    assert ray_endpoint("127.0.0.1:6379") == ("127.0.0.1", 6379)
    assert ray_endpoint("ray://head.local:10001") == ("head.local", 10001)
    assert ray_endpoint("[::1]:6379") == ("::1", 6379)
    for bad in ("auto", "6379", "head:", "head:65536", "head:x1", "head:²", "head:" + "9" * 5000, "ray://a://b:1"):
        assert ray_endpoint(bad) is None, bad
    for other in ("auto", "local", "ray://head:10001", "head:6379"):  # what ray.init takes besides HOST:PORT
        assert check_settings(1, "ray", 0, None, other) == (1, None)


def test_bad_problem_lists_are_refused_naming_the_entry() -> None:
    problem = Problem("s", 0, start=Pose(), goal=Pose((0.1, 0, 0)))
    for problems, field in (([problem, "p"], "problems[1]"), ([problem, problem], "problems"), ("s.yaml", "problems")):
        with pytest.raises(InvalidInput) as raised:
            plan_many(problems)  # type: ignore[arg-type]
        assert raised.value.field == field


def test_a_plan_still_running_at_its_timeout_is_cancelled_and_reported() -> None:
    # a tolerance no plan can meet and a stagnation window longer than the plan: it would run 10^6 steps
    endless = PlanOptions(dt=0.01, goal_tolerance=1e-300, max_iterations=1_000_000, stagnation_window=1e6,
                          stagnation_progress=1e-300, global_fallback=False)
    problem = Problem("endless", 0, start=Pose((0.3, 0.0, 0.5)), goal=Pose((0.31, 0.0, 0.5)), options=endless)
    quick = Problem("quick", 0, start=Pose((0.3, 0.0, 0.5)), goal=Pose((0.305, 0.0, 0.5)))
    slow, fast = plan_many([problem, quick], timeout=0.02)
    assert (slow["status"], slow["success"]) == ("timeout", False)
    assert slow["steps"] < 1_000_000 and len(slow["positions"]) == slow["steps"] + 1  # the waypoints so far
    assert slow["error"] == "timeout: still planning after 0.02 s"
    assert fast["status"] == "reached"


def test_a_script_without_a_main_guard_gets_error_records_naming_the_fix(tmp_path: Path) -> None:
    script = tmp_path / "unguarded.py"
    script.write_text(
        "import json\n"
        "from pfield.batch import plan_many\n"
        "from pfield.scene import Problem\n"
        "from pfield.spatial import Pose\n"
        "problems = [Problem('s', i, start=Pose(), goal=Pose((0.01, 0, 0))) for i in range(3)]\n"
        "print(json.dumps([r['status'] + ':' + r['error'] for r in plan_many(problems, workers=2)]))\n")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    statuses = json.loads(done.stdout.strip().splitlines()[-1])
    assert len(statuses) == 3 and all(s.startswith("error:") and "__main__" in s for s in statuses)


@pytest.mark.parametrize("name", ["panda", "xarm7"])
def test_a_workers_warm_up_plan_runs_the_field_and_its_global_fallback(name: str) -> None:
    """The warm-up of a worker goes through every planner a problem of its robot uses (so their kernels are
    loaded before the first problem is timed): the field stagnates, the fallback reaches the goal."""
    from pfield.batch._solve import _warm_plan
    from pfield.robot import RobotModel

    path = _warm_plan(RobotModel.builtin(name))
    assert path.success and path.status == PlanStatus.REACHED
    assert path.planner == "field+global"
