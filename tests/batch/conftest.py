"""Problem sets of the batch tests: two short MotionBenchMaker box problems, a task-space scene file and a
malformed request, in one folder (planned in well under a second each)."""

from __future__ import annotations

import tarfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ARCHIVE = ROOT.parent / "shared" / "benchmarks" / "mbm" / "panda_problems_dev.tar.bz2"
SCENE_FILE = ROOT / "examples" / "manipulator" / "scene.yaml"
NUMBERS = ("0001", "0002")


@pytest.fixture(scope="session")
def problem_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``box_panda/`` with problems 1 and 2 of the MBM box scene, and problem 3 whose request has no goal."""
    if not ARCHIVE.exists():
        pytest.fail(f"{ARCHIVE} is missing (the shared MBM problems)")
    root = tmp_path_factory.mktemp("batch")
    members = [f"problems/box_panda/{kind}{n}.yaml" for n in NUMBERS for kind in ("scene", "request")]
    with tarfile.open(ARCHIVE) as opened:
        opened.extractall(root, members=[opened.getmember(m) for m in members], filter="data")
    folder = root / "problems" / "box_panda"
    (folder / "scene0003.yaml").write_text((folder / "scene0001.yaml").read_text())
    (folder / "request0003.yaml").write_text("start_state: {joint_state: {name: [panda_joint1], position: [0.0]}}\n")
    return folder


@pytest.fixture(scope="session")
def problem_paths(problem_folder: Path) -> list[Path]:
    return [problem_folder, SCENE_FILE]
