"""The process backend: a ``spawn`` pool of worker processes, each with its own :class:`Workspace`.

``spawn`` (not ``fork``) so that a worker never inherits the parent's threads or locks (numba's, a Ray
client's, a web server's); each worker imports pfield afresh and loads the compiled kernels from numba's
cache on disk (the cache lives beside the source, so workers of one tree share it and do not recompile).
The robots are built once per worker by the pool's initializer; each problem then travels alone.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from pfield.batch._solve import Workspace, _error, solve
from pfield.scene import Problem, RobotSpec

__all__ = ["run_in_process", "run_processes"]

_WORKSPACE: Workspace | None = None


def _start_worker(robots: tuple[RobotSpec, ...]) -> None:
    global _WORKSPACE
    _WORKSPACE = Workspace(robots, warm=True)


def _solve_in_worker(problem: Problem, timeout: float | None, seed: int) -> dict[str, Any]:
    assert _WORKSPACE is not None, "the pool initializer builds the workspace"
    return solve(problem, _WORKSPACE, timeout, seed)


def run_in_process(problems: Sequence[Problem], robots: tuple[RobotSpec, ...], timeout: float | None,
                   seed: int) -> Iterator[dict[str, Any]]:
    """The records of ``problems`` in order, planned one after the other in this process."""
    workspace = Workspace(robots)
    for problem in problems:
        yield solve(problem, workspace, timeout, seed)


def run_processes(problems: Sequence[Problem], robots: tuple[RobotSpec, ...], workers: int, timeout: float | None,
                  seed: int) -> Iterator[dict[str, Any]]:
    """The records of ``problems`` in order, planned by ``workers`` spawned processes.

    At most ``2 · workers`` problems are in flight (so a long input is not pickled all at once); a worker
    that dies (a crash in native code) turns the problems it held into ``"error"`` records and the pool is
    started again for the rest.
    """
    context = multiprocessing.get_context("spawn")
    position = 0
    while position < len(problems):
        with ProcessPoolExecutor(workers, mp_context=context, initializer=_start_worker,
                                 initargs=(robots,)) as pool:
            pending: list[tuple[Problem, Future[dict[str, Any]]]] = []
            broken = False
            while position < len(problems) or pending:
                while not broken and position < len(problems) and len(pending) < 2 * workers:
                    problem = problems[position]
                    pending.append((problem, pool.submit(_solve_in_worker, problem, timeout, seed)))
                    position += 1
                problem, future = pending.pop(0)
                try:
                    yield future.result()
                except BrokenProcessPool:
                    broken = True
                    yield _error(problem, "error", "the worker process died while planning this problem")
                    # the pool is unusable: requeue what it still held and start a new pool
                    position -= len(pending)
                    pending.clear()
                    break
