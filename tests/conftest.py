"""Shared pytest configuration."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

# Keep matplotlib headless in every test process.
os.environ.setdefault("MPLBACKEND", "Agg")

# The fitted robot link models of the test run (and of every server, worker and example process it starts, which
# inherit the environment) go under build/ of this checkout, not into the user's ~/.cache/pfield; they persist
# between runs there, as a user's cache does (pfield.robot._fit.cache_root).
os.environ.setdefault("PFIELD_CACHE_DIR", str(Path(__file__).resolve().parents[1] / "build" / "test-cache"))

from hypothesis import settings

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
