"""Every ``pfield`` process starts without the modules only some commands use: the command line imports what a
command needs when the command runs (the tests start a few hundred of these processes, users one per command)."""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("pinocchio", "coal", "rclpy", "mujoco", "matplotlib", "scipy", "fastapi", "uvicorn", "httpx", "yaml",
         "rich.console", "pfield.interfaces", "pfield.robot", "pfield.scene", "pfield.node", "pfield.transport.http")
"""Modules a command may need, none of which the ``pfield`` command line itself (its parser, help and version)
imports."""

PROBE = f"""
import sys
import pfield.cli
print(" ".join(sorted(name for name in {HEAVY!r} if name in sys.modules)))
"""


def test_the_command_line_imports_no_command_s_modules() -> None:
    done = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True)
    assert done.stdout.split() == [], f"imported by `import pfield.cli`: {done.stdout.strip()}"

