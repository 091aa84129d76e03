"""Shared pytest configuration."""

from __future__ import annotations

import os

# Keep matplotlib headless in every test process.
os.environ.setdefault("MPLBACKEND", "Agg")

from hypothesis import settings

# CI runs the property tests on hypothesis's fixed example sequence, so a submission's result does not depend
# on the draw; developers' runs keep exploring new examples.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

# The cold-compile test of `pfield warmup` runs first. On a fresh checkout numba's cache is empty, so that test
# compiles every kernel into it (tests/cli/test_warmup.py) and every later test, server and worker process loads
# the kernels instead of compiling them again.
COLD_WARMUP_TEST = "tests/cli/test_warmup.py::test_warmup_command_compiles_every_kernel_with_progress"


def pytest_collection_modifyitems(items: list) -> None:  # type: ignore[type-arg]
    first = [item for item in items if item.nodeid == COLD_WARMUP_TEST]
    items[:] = first + [item for item in items if item.nodeid != COLD_WARMUP_TEST]
