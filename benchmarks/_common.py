"""Shared helpers for the benchmark modules: timing and the result row."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any, NamedTuple


@dataclass(frozen=True)
class BenchRow:
    """One measured figure.

    ``value`` is in ``unit``; ``reference`` is the C++ original's figure in the same unit (REFERENCE.md),
    ``target`` the issue's target; either may be None. Lower is better unless ``higher_is_better``.
    """

    section: str
    name: str
    value: float
    unit: str
    reference: float | None = None
    target: float | None = None
    higher_is_better: bool = False
    note: str = ""

    def ratio(self) -> float | None:
        """value / reference (speed-up factor is 1/ratio for time-like figures)."""
        if self.reference is None or self.reference == 0:
            return None
        return self.value / self.reference

    def meets_target(self) -> bool | None:
        if self.target is None:
            return None
        return self.value >= self.target if self.higher_is_better else self.value <= self.target

    def as_dict(self) -> dict[str, Any]:
        return asdict(self) | {"ratio": self.ratio(), "meets_target": self.meets_target()}


def median_time(fn: Callable[[], object], *, repeat: int = 7, number: int = 1, warmup: int = 2,
                clock: Callable[[], float] = time.perf_counter) -> float:
    """Median time of ``fn`` in seconds per call on ``clock`` (wall time by default), after ``warmup`` calls."""
    for _ in range(warmup):
        fn()
    samples = []
    for _ in range(repeat):
        start = clock()
        for _ in range(number):
            fn()
        samples.append((clock() - start) / number)
    samples.sort()
    return samples[len(samples) // 2]


class Report(NamedTuple):
    """What a module's ``run`` may return instead of bare rows: the rows and other views of them
    (file name → Markdown), which the runner writes beside the rows."""

    rows: list[BenchRow]
    tables: dict[str, str]


HOST_CHECK = "host check: sum(range(10**6)) in pure Python"


def host_check_ms() -> float:
    """A fixed pure-Python workload, median of 5 runs (ms): the host's speed when a module ran.

    Hosts differ and a shared one changes speed from hour to hour; a single-thread figure that moved between two
    runs by about the same factor as this one most likely moved with the host, not with the code (figures of
    several processes or of memory traffic need not follow it)."""
    return 1e3 * median_time(lambda: sum(range(10**6)), repeat=5, warmup=1)


def cpu_time(fn: Callable[[], object], repeat: int, number: int = 1) -> float:
    """Median CPU time of this process per call of ``fn`` (s), after one warm-up call: unlike wall time,
    it does not grow when other processes share the machine."""
    return median_time(fn, repeat=repeat, number=number, warmup=1, clock=time.process_time)


def auto_number(fn: Callable[[], object], budget_s: float = 0.05) -> int:
    """How many calls of ``fn`` fill about ``budget_s`` seconds (at least 1)."""
    fn()
    start = time.perf_counter()
    fn()
    once = max(time.perf_counter() - start, 1e-9)
    return max(1, int(budget_s / once))
