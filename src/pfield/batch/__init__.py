"""Many plans: :func:`plan_many` runs problems on every core (processes) or on a Ray cluster.

```python
from pfield.batch import plan_many
from pfield.scene import read_problems

problems = read_problems(["problems.tar.bz2"], limit=5)
for record in plan_many(problems, workers=2):
    print(record["scene"], record["index"], record["status"])
```

Results are records (JSON-ready dicts, :data:`RECORD_FIELDS`) in the order of ``problems``, whatever the
number of workers or the backend; every field but the timings (:data:`TIMING_FIELDS`) is a pure function
of the problem and ``seed``. :func:`write_records` / :func:`finished_keys` are the JSON-lines file and its
resume set (``pfield batch … --out results.jsonl --resume``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import IO, Any

from pfield._files import open_regular
from pfield._validation import integer, positive
from pfield.batch._ray import check_reachable, ray_endpoint
from pfield.batch._solve import RECORD_FIELDS, TIMING_FIELDS, Workspace, problem_seed, solve
from pfield.errors import InvalidInput
from pfield.scene import Problem

__all__ = ["BACKENDS", "RECORD_FIELDS", "TIMING_FIELDS", "Workspace", "check_reachable", "check_settings",
           "finished_keys", "plan_many", "problem_seed", "ray_endpoint", "solve", "write_records"]

BACKENDS = ("process", "ray")
Progress = Callable[[dict[str, Any]], None]


def check_settings(workers: Any = 1, backend: Any = "process", seed: Any = 0, timeout: Any = None,
                   address: Any = None) -> tuple[int, float | None]:
    """:func:`plan_many`'s settings checked (``InvalidInput`` naming the field): (workers, timeout). The CLI
    calls it before it reads a problem, so a wrong setting is refused at once."""
    count = integer("workers", workers)
    if count < 1:
        raise InvalidInput("workers", workers, "must be >= 1")
    if backend not in BACKENDS:
        raise InvalidInput("backend", backend, f"expected one of {', '.join(BACKENDS)}")
    integer("seed", seed)
    limit = None if timeout is None else positive("timeout", timeout)
    if limit is not None and not math.isfinite(limit):
        raise InvalidInput("timeout", timeout, "must be finite (or None for no limit)")
    if address is not None:
        if backend != "ray" or not isinstance(address, str) or not address:
            raise InvalidInput("address", address, "a non-empty Ray address, only with backend='ray'")
        if address not in ("auto", "local") and ("://" not in address or address.startswith("ray://")) \
                and ray_endpoint(address) is None:
            raise InvalidInput("address", address, "expected HOST:PORT (ray start --head prints it), "
                                                   "ray://HOST:PORT, auto or local")
    return count, limit


def _check(problems: Iterable[Problem], workers: Any, backend: Any, seed: Any, timeout: Any,
           address: Any) -> tuple[list[Problem], int, float | None]:
    if isinstance(problems, str | bytes | Path) or not isinstance(problems, Iterable):
        raise InvalidInput("problems", problems, "expected an iterable of pfield.scene.Problem")
    items = list(problems)
    for i, problem in enumerate(items):
        if not isinstance(problem, Problem):
            raise InvalidInput(f"problems[{i}]", problem, "expected a pfield.scene.Problem")
    keys = [p.key for p in items]
    if len(set(keys)) != len(keys):
        twice = sorted({k for k in keys if keys.count(k) > 1})
        raise InvalidInput("problems", twice, "two problems have the same (scene, index)")
    count, limit = check_settings(workers, backend, seed, timeout, address)
    return items, count, limit


def plan_many(problems: Iterable[Problem], workers: int = 1, backend: str = "process", seed: int = 0, *,
              timeout: float | None = None, address: str | None = None,
              progress: Progress | None = None) -> Iterator[dict[str, Any]]:
    """Plan every problem; yield one record per problem, in the order given.

    Args:
        problems: :class:`~pfield.scene.Problem` values (:func:`pfield.scene.read_problems` makes them);
            their ``(scene, index)`` keys must be unique.
        workers: processes (``"process"``; 1 plans in this process) or Ray actors (``"ray"``), >= 1.
        backend: ``"process"`` (a ``spawn`` pool on this machine) or ``"ray"`` (extra ``ray``).
        seed: mixed with each problem's key (:func:`problem_seed`), so a problem's result does not depend on
            which worker plans it or when.
        timeout: seconds per problem (> 0) after which its plan is cancelled (status ``"timeout"``).
        address: the Ray cluster to connect to (``"127.0.0.1:6379"``, ``"ray://HOST:PORT"``, ``"auto"``, or
            another address ``ray.init`` takes); None starts a local one. A ``HOST:PORT`` where nothing answers
            within 5 s raises :class:`~pfield.errors.Unreachable`.
        progress: called with each record as it is yielded (the CLI draws a rich progress bar with it).

    A problem that cannot be planned yields a record with status ``"error"`` and the reason in ``error``;
    the batch goes on. The arguments are checked before anything runs (``InvalidInput`` naming the field).
    The process pool spawns its workers: a script that calls this with ``workers > 1`` must do so under
    ``if __name__ == "__main__":`` (as for every ``spawn`` pool).
    """
    items, count, limit = _check(problems, workers, backend, seed, timeout, address)
    robots = tuple(dict.fromkeys(p.robot for p in items if p.robot is not None))
    return _records(items, robots, count, backend, seed, limit, address, progress)


def _records(items: list[Problem], robots: tuple[Any, ...], count: int, backend: str, seed: int,
             limit: float | None, address: str | None, progress: Progress | None) -> Iterator[dict[str, Any]]:
    from pfield.batch import _process

    if not items:
        return
    if backend == "ray":
        from pfield.batch._ray import run_ray

        results = run_ray(items, robots, count, limit, seed, address)
    elif count == 1:
        results = _process.run_in_process(items, robots, limit, seed)
    else:
        results = _process.run_processes(items, robots, min(count, len(items)), limit, seed)
    for record in results:
        if progress is not None:
            progress(record)
        yield record


def finished_keys(path: str | Path) -> set[tuple[str, int]]:
    """The ``(scene, index)`` of every complete record in a JSON-lines result file (none if it is missing).

    A last line cut short by an interrupted run is not a record and is ignored (and overwritten by
    :func:`write_records` when resuming), as is any other line that is not a record (bytes that are not
    UTF-8 too). The file is read line by line, and only when it is a regular file (a FIFO would block)."""
    keys: set[tuple[str, int]] = set()
    file = Path(path)
    if not file.exists():
        return keys
    with open_regular("results", file) as lines:
        for line in lines:
            try:
                record = json.loads(line)
                keys.add((str(record["scene"]), int(record["index"])))
            except (ValueError, KeyError, TypeError):  # UnicodeDecodeError is a ValueError
                continue
    return keys


def _complete_lines(file: Path) -> None:
    """Cut an interrupted last line off ``file`` (so appended records start on a line of their own)."""
    data = file.read_bytes()
    if data and not data.endswith(b"\n"):
        file.write_bytes(data[: data.rfind(b"\n") + 1])


def write_records(records: Iterable[dict[str, Any]], path: str | Path, append: bool = False) -> int:
    """Write records as JSON lines (flushed one by one, so an interrupted run keeps what it finished);
    ``append`` adds to an existing file. Returns the number written."""
    file = Path(path)
    if append and file.exists():
        _complete_lines(file)
    written = 0
    out: IO[str]
    with file.open("a" if append else "w", encoding="utf-8") as out:
        for record in records:
            out.write(json.dumps(record) + "\n")
            out.flush()
            written += 1
    return written
