"""``pfield batch``: JSON lines out, --resume after an interrupted run plans only the rest, bad arguments."""

from __future__ import annotations

import json
import os
from pathlib import Path

from typer.testing import CliRunner

from pfield.batch import finished_keys
from pfield.cli import app


def _keys(path: Path) -> list[tuple[str, int]]:
    return [(r["scene"], r["index"]) for r in map(json.loads, path.read_text().splitlines())]


def test_resume_after_an_interrupted_run_plans_only_the_rest(problem_paths: list[Path], tmp_path: Path) -> None:
    out = tmp_path / "results.jsonl"
    runner = CliRunner()
    first = runner.invoke(app, ["batch", *map(str, problem_paths), "--out", str(out)])
    assert first.exit_code == 1, first.output  # problem 3 is malformed: exit 1, the others are planned
    assert _keys(out) == [("box_panda", 1), ("box_panda", 2), ("box_panda", 3), ("scene", 0)]
    lines = out.read_text().splitlines()
    # an interrupted run: two complete records and half of the third
    out.write_text(lines[0] + "\n" + lines[1] + "\n" + lines[2][: len(lines[2]) // 2])
    resumed = runner.invoke(app, ["batch", *map(str, problem_paths), "--out", str(out), "--resume"])
    assert resumed.exit_code == 1, resumed.output
    assert "2 problems planned (2 already in" in resumed.output
    assert _keys(out) == [("box_panda", 1), ("box_panda", 2), ("box_panda", 3), ("scene", 0)]
    assert out.read_text().splitlines()[:2] == lines[:2]  # the finished records are kept as they were
    again = runner.invoke(app, ["batch", *map(str, problem_paths), "--out", str(out), "--resume"])
    assert again.exit_code == 0 and "0 problems planned (4 already in" in again.output, again.output
    # one line however long, though not a terminal (rich's 80 columns split the file's name across lines of a log)
    [summary] = [line for line in again.output.splitlines() if line.startswith("0 problems planned")]
    assert summary.endswith(f"results in {out}")


def test_bad_arguments_exit_2_naming_the_option(problem_paths: list[Path], tmp_path: Path) -> None:
    runner = CliRunner()
    out = str(tmp_path / "x.jsonl")
    for args, words in ((["--workers", "0"], "workers"), (["--backend", "mpi"], "backend"),
                        (["--robot", "r2d2"], "robot"), (["--limit", "0"], "limit"),
                        (["--address", "127.0.0.1:1"], "address")):
        result = runner.invoke(app, ["batch", *map(str, problem_paths), "--out", out, *args])
        assert result.exit_code == 2 and words in result.output, (args, result.output)
    missing = runner.invoke(app, ["batch", str(tmp_path / "nothing"), "--out", out])
    assert missing.exit_code == 2 and "no such file" in missing.output
    # one file of a MoveIt pair is not read as a pfield scene: the folder is asked for
    moveit = Path(__file__).resolve().parents[2] / "examples" / "batch" / "moveit"
    for name in ("request0001.yaml", "scene0001.yaml"):
        single = runner.invoke(app, ["batch", str(moveit / name), "--out", out])
        assert single.exit_code == 2 and "a MoveIt file, not a pfield scene" in single.output, single.output
        assert "give that folder" in single.output
    # the settings are refused before a problem is read (the problem path here does not exist)
    early = runner.invoke(app, ["batch", str(tmp_path / "nothing"), "--out", out, "--workers", "0"])
    assert early.exit_code == 2 and "workers" in early.output and "no such file" not in early.output, early.output


def test_a_ray_address_where_no_cluster_answers_fails_at_once(problem_paths: list[Path], tmp_path: Path) -> None:
    """Ray's own connection retries such an address for minutes; the batch gives up within CONNECT_TIMEOUT (nothing
    listens on loopback port 1: refused at once), exit 1 as for any service that may answer later."""
    out = tmp_path / "kept.jsonl"
    out.write_text('{"scene": "s", "index": 0}\n')
    result = CliRunner().invoke(app, ["batch", *map(str, problem_paths), "--out", str(out),
                                      "--backend", "ray", "--address", "127.0.0.1:1"])
    assert result.exit_code == 1, result.output
    assert "no Ray cluster answers at 127.0.0.1:1" in result.output and "ray start --head" in result.output
    assert out.read_text() == '{"scene": "s", "index": 0}\n'  # refused before --out was opened


def test_resume_reads_only_a_regular_results_file_and_skips_lines_that_are_not_records(
        problem_paths: list[Path], tmp_path: Path) -> None:
    runner = CliRunner()
    scene = str(problem_paths[-1])  # the task-space scene file: one quick plan
    pipe = tmp_path / "results.fifo"
    os.mkfifo(pipe)  # reading it to resume would wait for a writer forever
    refused = runner.invoke(app, ["batch", scene, "--out", str(pipe), "--resume"])
    assert refused.exit_code == 2 and "results=" in refused.output and "is a FIFO" in refused.output, refused.output
    out = tmp_path / "results.jsonl"
    out.write_bytes(b'{"scene": "scene", "index": 0}\n\xff\xfe not UTF-8 \xff\n')
    assert finished_keys(out) == {("scene", 0)}
    again = runner.invoke(app, ["batch", scene, "--out", str(out), "--resume"])
    assert again.exit_code == 0 and "0 problems planned (1 already in" in again.output, again.output


def test_ctrl_c_stops_a_batch_at_once_keeping_what_it_planned(tmp_path: Path) -> None:
    """Ctrl-C (to the whole process group, as a terminal sends it) in the middle of a two-worker batch: a worker that
    took it could die holding the pool's queue lock while the other waited on its pipe, and the batch hung at exit
    (2 runs in 4). The workers leave Ctrl-C to the parent, which stops them and says what it kept."""
    import signal
    import subprocess
    import sys
    import time

    ur5 = Path(__file__).resolve().parents[2].parent / "shared" / "benchmarks" / "mbm" / "ur5"
    out = tmp_path / "records.jsonl"
    command = [str(Path(sys.executable).with_name("pfield")), "batch", str(ur5 / "ur5_problems.tar.bz2"), "--robot",
               str(ur5 / "ur5.urdf"), "--srdf", str(ur5 / "ur5.srdf"), "--end-effector", "tool0", "--package-path",
               f"meshes={ur5 / 'meshes'}", "--workers", "2", "--out", str(out)]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    deadline = time.monotonic() + 300
    while not (out.exists() and len(out.read_text().splitlines()) >= 20):
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.05)
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    kept = len(out.read_text().splitlines())
    assert process.returncode == 1 and "Traceback" not in stderr, stderr
    assert f"interrupted: {kept} problems planned and kept in" in " ".join(stderr.split()) and 20 <= kept < 700
    assert all(json.loads(line)["status"] for line in out.read_text().splitlines())  # whole records only


def test_another_robots_problems_are_refused_before_planning(tmp_path: Path) -> None:
    """The UR5's MotionBenchMaker archive without --robot: 700 'error' records whose reason spoke of the Panda's
    joints, exit 1. Problems that name none of the robot's joints are another robot's: refused at once, exit 2."""
    ur5 = Path(__file__).resolve().parents[2].parent / "shared" / "benchmarks" / "mbm" / "ur5"
    result = CliRunner().invoke(app, ["batch", str(ur5 / "ur5_problems.tar.bz2"), "--limit", "1", "--out",
                                      str(tmp_path / "never.jsonl")])
    said = " ".join(result.output.split())
    assert result.exit_code == 2 and "names none of the joints of panda" in said and "another robot's problem" in said
    assert not (tmp_path / "never.jsonl").exists()
