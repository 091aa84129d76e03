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
