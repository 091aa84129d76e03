"""The C++ original timed side by side: runs ``pf_anchor_bench`` (``../shared/benchmarks/anchor-cpp``) in the same run.

``make anchor`` builds it once into ``build/anchor-cpp`` (git-ignored; ``make bench`` builds it when missing).
:func:`cpp_figures` runs the program for the sections a benchmark module needs and returns its medians
(µs per call; ms per plan for ``task_space`` and ``whole_body``), keyed by (section, scene, params, figure).
Without the program the modules fall back to REFERENCE.md's figures and say so in their notes.
Environment: ``PFIELD_ANCHOR_BENCH`` (path of the program), ``PFIELD_NO_ANCHOR=1`` (do not run it).
"""

from __future__ import annotations

import json
import os
import subprocess
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = ROOT / "build" / "anchor-cpp" / "install" / "bin" / "pf_anchor_bench"
Key = tuple[str, str, str, str]


def program() -> Path | None:
    """The anchor program, when built (``make anchor``) and not switched off."""
    if os.environ.get("PFIELD_NO_ANCHOR"):
        return None
    path = Path(os.environ.get("PFIELD_ANCHOR_BENCH", PROGRAM))
    return path if path.is_file() and os.access(path, os.X_OK) else None


@cache
def cpp_figures(sections: tuple[str, ...]) -> dict[Key, dict[str, float]]:
    """Timing lines of one anchor run over ``sections``: key → the line (``median``, ``min``, ``steps`` …).

    Empty when the program is missing or fails (the caller then uses REFERENCE.md's figures).
    """
    path = program()
    if path is None:
        return {}
    from pfield.robot.catalog import example_robot_data_root

    data = example_robot_data_root()
    urdf = data / "robots" / "xarm_description" / "urdf" / "xarm7.urdf"
    command = [str(path), "--urdf", str(urdf), "--package", f"example-robot-data={data}", "--only", ",".join(sections)]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=900, check=True)
    except (OSError, subprocess.SubprocessError):
        return {}
    figures: dict[Key, dict[str, float]] = {}
    for line in done.stdout.splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        if row.get("kind") == "timing":
            figures[(row["section"], row["scene"], row["params"], row["figure"])] = row
    return figures


def cpp_median(figures: dict[Key, dict[str, float]], key: Key, fallback: float) -> tuple[float, str]:
    """(median of ``key`` from this run, "C++ measured in this run (min …)") or (``fallback``, "C++ from
    REFERENCE.md"). The minimum over the C++ batches is the figure least disturbed when the machine is shared;
    compare it with pfield's CPU time."""
    row = figures.get(key)
    if row is None:
        return fallback, "C++ from REFERENCE.md"
    return float(row["median"]), f"C++ measured in this run (min of its batches {float(row['min']):.3g})"
