"""Every script under ``examples/`` runs headless as a real subprocess and writes what its docstring promises.

Each script runs with the venv's Python, ``MPLBACKEND=Agg``, its working directory a fresh temporary folder
(so a script that writes next to itself or into ``demo_output/`` of the current directory is caught), and
its pictures sent to ``--output-dir`` under ``tmp_path``. Long scripts get their short-horizon option
(``--steps``, ``--seconds``, ``--resolution``, documented in each docstring). The scripts run two at a time
in a thread pool; the whole file takes some 10–15 s.
"""

from __future__ import annotations

import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
VENV_PYTHON = REPO / ".venv" / "bin" / "python"
PYTHON = str(VENV_PYTHON) if VENV_PYTHON.exists() else sys.executable


@dataclass(frozen=True)
class Case:
    """How to run one example and what it must leave behind."""

    args: tuple[str, ...]  # extra arguments (the output dir is added when ``writes`` is not empty)
    writes: tuple[str, ...]  # files, relative to --output-dir, that must exist and be non-empty
    prints: tuple[str, ...]  # substrings of stdout that the docstring's "what to look at" promises


CASES: dict[str, Case] = {
    "costmap/find_valid_pose.py": Case(
        (), ("fvp_round.png", "fvp_rectangle.png"), ("round      INSCRIBED", "rectangle  INSCRIBED")),
    "manipulator/autonomy_vector_slice.py": Case(
        ("--resolution", "11"), ("example_autonomy_vector_slice.png",), ("121 constrained twists",)),
    "manipulator/head_on_comparison.py": Case((), ("example_head_on.png",), ("plan: success=True",)),
    "manipulator/panda_whole_body.py": Case((), ("example_panda_whole_body.png",), ("success=True",)),
    "manipulator/whole_body_autonomy.py": Case(
        ("--steps", "40"), (), ("query pose flagged as disagreeing with the joints: True", "after 40 cycles")),
    "mobile/assisted_teleop.py": Case((), ("mobile_assisted_teleop.png",), ("diff_drive",)),
    "mobile/field_api.py": Case((), ("mobile_field_api.png",), ("|command|",)),
    "sim/execute_in_mujoco.py": Case(
        ("--width", "320", "--height", "240"), ("mujoco_run.png",),
        ("steps in contact with obstacles 0", "max tracking error")),
    "mobile/seed_grid.py": Case(
        (),
        tuple(f"mobile_{name}_{drive}.png" for name in ("grid_blocked", "grid_pass")
              for drive in ("holonomic", "diff_drive")),
        ("grid_blocked  holonomic   stuck", "grid_blocked  diff_drive  stuck",
         "grid_pass     holonomic   goal_reached", "grid_pass     diff_drive  goal_reached")),
}

SCRIPTS = sorted(str(path.relative_to(EXAMPLES)) for path in EXAMPLES.rglob("*.py"))


@dataclass(frozen=True)
class Outcome:
    """One finished example run."""

    returncode: int
    stdout: str
    stderr: str
    cwd: Path
    out_dir: Path


def _run(script: str, root: Path) -> Outcome:
    case = CASES[script]
    cwd, out_dir = root / script.replace("/", "__") / "cwd", root / script.replace("/", "__") / "out"
    cwd.mkdir(parents=True)
    args = [*case.args, *(("--output-dir", str(out_dir)) if case.writes else ())]
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONWARNINGS": "default"}
    done = subprocess.run([PYTHON, str(EXAMPLES / script), *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300, check=False)
    return Outcome(done.returncode, done.stdout, done.stderr, cwd, out_dir)


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Outcome]:
    """All examples, run two at a time (the CI machine has two cores)."""
    root = tmp_path_factory.mktemp("examples")
    known = [script for script in SCRIPTS if script in CASES]
    with ThreadPoolExecutor(max_workers=2) as pool:
        return dict(zip(known, pool.map(lambda script: _run(script, root), known), strict=True))


def test_every_example_has_a_case() -> None:
    assert SCRIPTS, "no example scripts found"
    assert set(SCRIPTS) == set(CASES), "add new examples to CASES (and remove deleted ones)"


@pytest.mark.parametrize("script", sorted(CASES))
def test_example_runs_and_writes_its_outputs(script: str, outcomes: dict[str, Outcome]) -> None:
    outcome = outcomes[script]
    assert outcome.returncode == 0, f"{script} failed:\n{outcome.stdout}\n{outcome.stderr}"
    case = CASES[script]
    for name in case.writes:
        target = outcome.out_dir / name
        assert target.is_file() and target.stat().st_size > 0, f"{script} did not write {name}"
    for text in case.prints:
        assert text in outcome.stdout, f"{script} did not print {text!r}:\n{outcome.stdout}"
    assert list(outcome.cwd.iterdir()) == [], f"{script} wrote into its working directory"


@pytest.mark.parametrize("script", sorted(CASES))
def test_example_docstring_says_how_to_run_it(script: str) -> None:
    source = (EXAMPLES / script).read_text()
    assert source.startswith('"""') and f"python examples/{script}" in source.split('"""')[1]
    assert 'if __name__ == "__main__":' in source


def test_assisted_teleop_docstring_predicts_the_printed_gap(outcomes: dict[str, Outcome]) -> None:
    """The docstring's stopping gap is the one the script prints for both drives (it once said 0.47 m)."""
    import re

    docstring = (EXAMPLES / "mobile" / "assisted_teleop.py").read_text().split('"""')[1]
    predicted = float(re.search(r"settles at (\d+\.\d+) m", " ".join(docstring.split())).group(1))
    rows = [line.split() for line in outcomes["mobile/assisted_teleop.py"].stdout.splitlines()
            if line.startswith(("holonomic", "diff_drive"))]
    assert len(rows) == 2
    for row in rows:
        assert round(float(row[-1]), 2) == predicted, row
