"""Shared pytest configuration."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

# Keep matplotlib headless in every test process.
os.environ.setdefault("MPLBACKEND", "Agg")


def _pin_numpy_kernels() -> bool:
    """On a CPU with AVX-512, have numpy and OpenBLAS use their AVX2 kernels, as on the machines the tests' exact
    values were recorded on: numpy dispatches its ufuncs (sin, cos, exp, ...) and OpenBLAS its matrix products by CPU,
    and their AVX-512 kernels round differently in the last bits, so the inputs that the exact-value tests build with
    numpy (rotations, Jacobian products, fitted link models) differ there (a Xeon with AVX-512, 2026-12-06; the core
    is built without AVX-512 as well, CMakeLists.txt: both were needed). Set before numpy is first imported (its
    dispatch is fixed at import); xdist workers and the subprocesses that inherit the environment inherit it. Which
    of numpy's targets to switch off, numpy says itself (a short subprocess: the AVX-512 targets it dispatches to
    beyond its baseline; their names differ between numpy versions). A variable already set is kept. True when the
    kernels are pinned."""
    try:
        avx512 = " avx512f" in Path("/proc/cpuinfo").read_text()
    except OSError:  # not Linux: no known machine of the project's
        return False
    if not avx512:
        return False
    if "NPY_DISABLE_CPU_FEATURES" not in os.environ:
        if "numpy" in sys.modules:
            warnings.warn("numpy was imported before tests/conftest.py could pin its kernels to AVX2: exact-value "
                          "tests may fail on this AVX-512 machine", stacklevel=1)
            return False
        query = ("import numpy as np; core = getattr(np, '_core', None) or np.core; u = core._multiarray_umath; "
                 "print(','.join(f for f in u.__cpu_dispatch__ if (f.startswith('AVX512') or f == 'X86_V4') "
                 "and f not in u.__cpu_baseline__ and u.__cpu_features__.get(f)))")
        found = subprocess.run([sys.executable, "-c", query], capture_output=True, text=True, check=False)
        if found.returncode != 0:
            warnings.warn(f"could not ask numpy for its AVX-512 targets ({found.stderr.strip()[-200:]}): exact-value "
                          "tests may fail on this AVX-512 machine", stacklevel=1)
            return False
        os.environ["NPY_DISABLE_CPU_FEATURES"] = found.stdout.strip()
    os.environ.setdefault("OPENBLAS_CORETYPE", "Haswell")
    return True


PINNED = _pin_numpy_kernels()

# The fitted robot link models of the test run (and of every server, worker and example process it starts, which
# inherit the environment) go under build/ of this checkout, not into the user's ~/.cache/pfield; they persist
# between runs there, as a user's cache does (pfield.robot._fit.cache_root). Pinned runs keep their own: link
# models fitted with numpy's AVX-512 kernels (a run before the pin) are not read by them.
os.environ.setdefault("PFIELD_CACHE_DIR", str(Path(__file__).resolve().parents[1] / "build" /
                                              ("test-cache-avx2" if PINNED else "test-cache")))

from hypothesis import settings  # noqa: E402  (after the pin: numpy is not imported before it)

# CI runs the property tests on hypothesis's fixed example sequence, so a submission's result does not depend
# on the draw; developers' runs keep exploring new examples.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

# HYPOTHESIS_PROFILE=nightly (a nightly or pre-release run, not make test): the ci profile's fixed sequence with
# ten times the cases, for the property tests that size themselves with property_cases.cases(n) (n: their count in
# make test) and a thousand for those that keep hypothesis's default. HYPOTHESIS_PROFILE=ci as CI=1 does.
settings.register_profile("nightly", parent=settings.get_profile("ci"), max_examples=1000)
if os.environ.get("HYPOTHESIS_PROFILE"):
    settings.load_profile(os.environ["HYPOTHESIS_PROFILE"])


# make test runs pytest on two workers, each test file whole on one (Makefile: --dist loadfile), handed out in
# collection order. The files that take longest start first, so that none of them starts when the other worker
# has little left (measured one by one on 2 cores, slowest first); only in a worker, so a plain run keeps its
# order. Each file's tests keep their order, and a file not listed keeps its place after these.
LONGEST_FIRST = (
    "test_docs.py",
    "test_output_contract.py",
    "viz/test_viewer_browser.py",
    "transport/test_fuzz.py",
    "transport/test_http_memory.py",
    "cli/test_ros2_verbs.py",
    "batch/test_ray.py",
    "test_core_build.py",
    "transport/test_http_limits.py",
    "cli/test_static_transforms.py",
    "mobile/test_mobile_plots.py",
)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if not hasattr(config, "workerinput"):  # not a pytest-xdist worker
        return
    rank = {name: place for place, name in enumerate(LONGEST_FIRST)}
    here = Path(__file__).parent

    def place(item: pytest.Item) -> int:
        return rank.get(item.path.relative_to(here).as_posix(), len(rank)) if item.path.is_relative_to(here) \
            else len(rank)

    items.sort(key=place)
