"""The compiled core ships in a wheel: ``pip wheel .`` (the portable build) makes a wheel that installs into a new
virtual environment and runs there with no compiler on PATH (docs/core.md)."""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PORTABLE_BUILD = REPO / "build" / "portable"
"""The portable build tree of docs/core.md, kept between runs: ``make test`` builds it beside its other setup steps
(``make core-portable``), so the wheel below compiles only what changed since. A lock file keeps two builds out of
it at once."""

CHECK = """
import shutil, sys
assert not any(shutil.which(tool) for tool in ("c++", "g++", "gcc", "cc", "clang")), "a compiler is on PATH"
import pfield._core
assert pfield._core.__file__.startswith(sys.prefix), pfield._core.__file__
from pfield.mobile import VectorFieldParams, velocity
from pfield.mobile.sim import simulate
command = velocity([[3.0, 0.0]], [0.0, 0.0], [[1.5, 0.1]], VectorFieldParams())
print("velocity", command.tolist())
"""


@pytest.mark.slow
def test_a_portable_wheel_installs_and_runs_without_a_compiler(tmp_path: Path) -> None:
    dist = tmp_path / "dist"
    PORTABLE_BUILD.parent.mkdir(exist_ok=True)
    with (PORTABLE_BUILD.parent / "portable.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # the Makefile's `flock build/portable.lock` takes the same lock
        subprocess.run([sys.executable, "-m", "pip", "wheel", str(REPO), "--no-deps", "--no-build-isolation", "-q",
                        "-w", str(dist), "-C", "cmake.define.PFIELD_NATIVE=OFF", "-C", f"build-dir={PORTABLE_BUILD}"],
                       check=True, cwd=tmp_path)
    (wheel,) = dist.glob("pfield-*.whl")
    env = tmp_path / "env"
    subprocess.run([sys.executable, "-m", "venv", str(env)], check=True)
    python = env / "bin" / "python"
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               check=True, capture_output=True, text=True).stdout.strip())
    # pfield's dependencies from this environment (a .pth adds the directory, not its editable pfield hooks)
    (site / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel)], check=True)
    bare = {"PATH": str(env / "bin"), "HOME": str(tmp_path), "LANG": os.environ.get("LANG", "C.UTF-8")}
    run = subprocess.run([str(python), "-c", CHECK], env=bare, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.startswith("velocity [[")
