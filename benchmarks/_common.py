"""Shared helpers for the benchmark modules: timing and the result row."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any, NamedTuple


@dataclass(frozen=True)
class BenchRow:
    """One measured figure.

    ``value`` is in ``unit``; ``reference`` is the C++ original's figure in the same unit (REFERENCE.md),
    ``target`` the issue's target; either may be None. Lower is better unless ``higher_is_better``.
    ``old_value`` is the numba engine's figure of the same row, measured in the same run
    (``benchmarks/_old_engine.py``); None when it was not run. A row only the numba engine has keeps its figure
    there and NaN as ``value``.
    """

    section: str
    name: str
    value: float
    unit: str
    reference: float | None = None
    target: float | None = None
    higher_is_better: bool = False
    note: str = ""
    old_value: float | None = None

    def ratio(self) -> float | None:
        """value / reference (speed-up factor is 1/ratio for time-like figures)."""
        if self.reference is None or self.reference == 0 or math.isnan(self.value):
            return None
        return self.value / self.reference

    def new_old(self) -> float | None:
        """The new engine against the numba engine, oriented so that ≤ 1 means no worse: value / old_value, or
        old_value / value where higher is better (plans/s, success). None without both figures or with a zero."""
        if self.old_value is None or math.isnan(self.value) or math.isnan(self.old_value):
            return None
        top, bottom = (self.old_value, self.value) if self.higher_is_better else (self.value, self.old_value)
        if bottom == 0:
            return 1.0 if top == 0 else None
        return top / bottom

    def meets_target(self) -> bool | None:
        if self.target is None or math.isnan(self.value):
            return None
        return self.value >= self.target if self.higher_is_better else self.value <= self.target

    def as_dict(self) -> dict[str, Any]:
        return asdict(self) | {"ratio": self.ratio(), "meets_target": self.meets_target(), "new_old": self.new_old()}


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
