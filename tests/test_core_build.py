"""The compiled core ships in a wheel: ``pip wheel .`` makes a wheel that installs into a new virtual environment
and plans there with no compiler on PATH; the portable option targets x86-64-v2, not this machine (docs/core.md)."""

from __future__ import annotations

import json
import os
import platform
import shlex
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

CHECK = """
import shutil, sys
assert not any(shutil.which(tool) for tool in ("c++", "g++", "gcc", "cc", "clang")), "a compiler is on PATH"
import pfield._core
assert pfield._core.__file__.startswith(sys.prefix), pfield._core.__file__
from pfield import FieldConfig, Obstacle, PotentialField, Sphere
from pfield.spatial import Pose
tool = (0.707, 0.0, 0.707, 0.0)
field = PotentialField(FieldConfig(), Pose((0.5, 0.2, 0.4), tool),
                       [Obstacle("ball", Sphere(radius=0.1), Pose((0.4, 0.0, 0.1)))])
path = field.plan(Pose((0.227, 0.0, 0.294), tool), dt=0.02, goal_tolerance=0.01, max_iterations=25000)
print("plan", path.success, len(path))
"""


@pytest.mark.slow
def test_a_wheel_installs_and_plans_without_a_compiler(tmp_path: Path) -> None:
    # `pip wheel .` as a user runs it: the default (host-CPU) build, from the build tree that make's editable
    # install keeps (pyproject's build-dir), so an unchanged core is packed, not compiled again
    dist = tmp_path / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", ".", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(dist)], check=True, cwd=REPO)
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
    run = subprocess.run([str(python), "-c", CHECK], env=bare, capture_output=True, text=True, timeout=300,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.split() == ["plan", "True", "353"]  # the README's first plan


@pytest.mark.parametrize("native", [True, False])
def test_the_portable_option_targets_x86_64_v2_and_the_default_the_host(tmp_path: Path, native: bool) -> None:
    # configured, not compiled: every compile command of the core and its module carries the option's -march
    bin_dir = Path(sys.executable).parent
    subprocess.run([str(bin_dir / "cmake"), "-S", str(REPO), "-B", str(tmp_path), "-G", "Ninja",
                    f"-DCMAKE_MAKE_PROGRAM={bin_dir / 'ninja'}", f"-DPython_EXECUTABLE={sys.executable}",
                    f"-DPFIELD_NATIVE={'ON' if native else 'OFF'}", "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON"],
                   check=True, capture_output=True)
    core = REPO / "src" / "core"  # (nanobind's own sources keep the compiler's default, a baseline x86-64)
    commands = [entry for entry in json.loads((tmp_path / "compile_commands.json").read_text())
                if Path(entry["file"]).is_relative_to(core)]
    folders = {Path(entry["file"]).relative_to(core).parts[0] for entry in commands}
    assert {"python", "planning", "robot", "geometry"} <= folders, folders
    marches = {entry["file"]: [word for word in shlex.split(entry["command"]) if word.startswith("-march=")]
               for entry in commands}
    expected = ["-march=native"] if native else ["-march=x86-64-v2"]
    assert all(found == expected for found in marches.values()), marches
    # a native build on x86-64 has no AVX-512 (the same bits with or without it, CMakeLists.txt) but in the mobile
    # base's 2D field (held to tolerances, not bits); x86-64-v2 has none
    without = {entry["file"]: "-mno-avx512f" in shlex.split(entry["command"]) for entry in commands}
    mobile = {file for file in without if Path(file).relative_to(core).parts[0] == "mobile"}
    assert mobile, folders
    if native and platform.machine() in ("x86_64", "AMD64"):
        assert all(flag != (file in mobile) for file, flag in without.items()), without
    else:
        assert not any(without.values()), without
