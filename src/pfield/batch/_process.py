"""The process backend: a ``spawn`` pool of worker processes, each with its own :class:`Workspace`.

``spawn`` (not ``fork``) so that a worker never inherits the parent's threads or locks (the compiled core's, a
Ray client's, a web server's); each worker imports pfield afresh and reads the robots' fitted link models from
pfield's cache on disk (``$PFIELD_CACHE_DIR``, default ``~/.cache/pfield``), so workers do not refit them.
The robots are built once per worker by the pool's initializer; each problem then travels alone.
"""

from __future__ import annotations

import multiprocessing
import signal
import threading
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from typing import Any

from pfield.batch._solve import Workspace, _error, solve
from pfield.scene import Problem, RobotSpec

__all__ = ["run_in_process", "run_processes"]

_WORKSPACE: Workspace | None = None
IN_FLIGHT_PER_WORKER = 16
_NO_WORKERS = ("the worker processes could not start (a script that calls plan_many with workers > 1 must do so "
               "under `if __name__ == \"__main__\":`, as every spawned pool requires)")


def _start_worker(robots: tuple[RobotSpec, ...]) -> None:
    global _WORKSPACE
    # Ctrl-C reaches the whole process group: it is the parent's to handle (it stops the pool). A worker that took
    # it itself could die holding the pool's queue lock while another waited on its pipe: the batch hung at exit.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _WORKSPACE = Workspace(robots, warm=True)


def _solve_in_worker(problem: Problem, timeout: float | None, seed: int) -> dict[str, Any]:
    assert _WORKSPACE is not None, "the pool initializer builds the workspace"
    return solve(problem, _WORKSPACE, timeout, seed)


@contextmanager
def _stopped_on_exit(pool: ProcessPoolExecutor) -> Iterator[None]:
    """Leaves the pool's ``with`` at once when the records stop being asked for (Ctrl-C in the parent, the caller
    closing the generator): the problems not started are cancelled and the workers still planning are terminated,
    where ``shutdown(wait=True)`` would wait for each of them to finish (up to the problems' time limit).

    A worker terminated while it wrote a result leaves half a message in the result pipe, and the pool's manager
    thread waits for the rest of it for ever (the parent's own copy of the pipe's write end keeps it open): the
    process then hung at exit, joining that thread (1 Ctrl-C in about 10 on a two-worker batch). So once the workers
    are gone, the parent closes its write end too: the thread reads the end of the pipe, takes the pool for broken
    and finishes, closing the pool's pipes; the parent waits for that, or the interpreter's exit hook could write to
    a pipe the thread had just closed (a traceback at exit, "Bad file descriptor")."""
    try:
        yield
    except BaseException:
        # a second Ctrl-C must not cut the stop short (the hang would be back): held off until it is done
        main = threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
        try:
            _stop(pool)
        finally:
            if main:
                signal.signal(signal.SIGINT, previous)
        raise


def _stop(pool: ProcessPoolExecutor) -> None:
    """Terminate ``pool``'s workers (killed if they outlast :data:`_WORKER_EXIT`), close the parent's end of the result
    pipe and wait for the manager thread (:func:`_stopped_on_exit`)."""
    # shutdown() lets go of the workers, the manager thread and the result pipe: taken before it
    workers = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    writer = getattr(getattr(pool, "_result_queue", None), "_writer", None)
    pool.shutdown(wait=False, cancel_futures=True)
    for process in workers:  # what Python 3.14's terminate_workers() does
        process.terminate()
    deadline = time.monotonic() + _WORKER_EXIT
    for process in workers:
        process.join(max(0.0, deadline - time.monotonic()))
    for process in workers:
        if process.is_alive():
            process.kill()
            process.join(_WORKER_EXIT)
    if writer is not None and not any(process.is_alive() for process in workers):
        writer.close()
    if manager is not None:  # it closes the pool's pipes: done before the interpreter's exit writes to them
        manager.join(_WORKER_EXIT)


_WORKER_EXIT = 5.0
"""(s) how long the terminated workers are waited for before they are killed, and the manager thread after."""


def run_in_process(problems: Sequence[Problem], robots: tuple[RobotSpec, ...], timeout: float | None,
                   seed: int) -> Iterator[dict[str, Any]]:
    """The records of ``problems`` in order, planned one after the other in this process (warmed up first, as a
    worker is: no record's time carries a robot's first use)."""
    workspace = Workspace(robots, warm=True)
    for problem in problems:
        yield solve(problem, workspace, timeout, seed)


def run_processes(problems: Sequence[Problem], robots: tuple[RobotSpec, ...], workers: int, timeout: float | None,
                  seed: int) -> Iterator[dict[str, Any]]:
    """The records of ``problems`` in order, planned by ``workers`` spawned processes.

    At most ``IN_FLIGHT_PER_WORKER · workers`` problems are in flight: enough that a long problem at the
    head of the order does not leave the other workers idle while its successors wait to be delivered, few
    enough that a long input is not pickled all at once. When a
    worker dies (a crash in native code) the pool breaks: the oldest unfinished problem gets an ``"error"``
    record, and a new pool plans the others again. A pool whose workers cannot start at all ends the batch
    with an ``"error"`` record for every problem left.
    """
    context = multiprocessing.get_context("spawn")
    position = 0
    while position < len(problems):
        with ProcessPoolExecutor(workers, mp_context=context, initializer=_start_worker,
                                 initargs=(robots,)) as pool, _stopped_on_exit(pool):
            pending: list[tuple[Problem, Future[dict[str, Any]]]] = []
            delivered = 0
            while position < len(problems) or pending:
                while position < len(problems) and len(pending) < IN_FLIGHT_PER_WORKER * workers:
                    problem = problems[position]
                    pending.append((problem, pool.submit(_solve_in_worker, problem, timeout, seed)))
                    position += 1
                problem, future = pending.pop(0)
                try:
                    record = future.result()
                except BrokenProcessPool:
                    if not delivered:  # the workers cannot start at all: every problem left fails the same way
                        for rest in (problem, *(p for p, _ in pending), *problems[position:]):
                            yield _error(rest, "error", _NO_WORKERS)
                        return
                    yield _error(problem, "error", "the worker process died while planning this problem")
                    # the pool is unusable: requeue what it still held and start a new pool
                    position -= len(pending)
                    break
                delivered += 1
                yield record
