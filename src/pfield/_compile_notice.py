"""Say so when numba compiles: the first use of a kernel after an install or an edit takes seconds, not µs.

numba announces each cache miss with a ``numba:compile`` event (a kernel loaded from the on-disk cache
raises none). The first such event of the process logs one warning naming the kernel, how long compiling
usually takes and how to do it ahead of time (``pfield warmup``); each finished top-level compile is
logged at INFO with its duration. :func:`quiet` silences the warning while ``pfield warmup`` reports its
own progress. Installed when this module is imported (first thing ``import pfield`` does).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from numba.core import event

__all__ = ["COLD_COMPILE_SECONDS", "LOGGER_NAME", "compiles", "install", "quiet"]

LOGGER_NAME = "pfield.compile"
_LOG = logging.getLogger(LOGGER_NAME)

COLD_COMPILE_SECONDS = (300, 600)
"""Usual range (s) of compiling every pfield kernel with an empty cache in one process: 320-610 s of CPU on
2-core x86-64 machines (numba compiles on one core; ``benchmarks/bench_startup``). ``pfield warmup`` shares
it between two processes where there are two cores (0.53× that wall time, the same CPU)."""


class _Listener(event.Listener):
    """Logs the first compile of the process (warning) and every finished top-level compile (info)."""

    def __init__(self) -> None:
        self._state = threading.local()
        self._announced = False
        self._quiet = 0
        self._lock = threading.Lock()
        self.compiles = 0

    def _depth(self) -> int:
        return getattr(self._state, "depth", 0)

    def on_start(self, ev: Any) -> None:
        depth = self._depth()
        self._state.depth = depth + 1
        if depth:
            return  # a kernel compiled because an outer one calls it: the outer one was announced
        self._state.started = time.perf_counter()
        with self._lock:
            self.compiles += 1
            announce = not self._announced and not self._quiet
            self._announced = self._announced or announce
        if announce:
            low, high = COLD_COMPILE_SECONDS
            _LOG.warning("compiling numba kernels (first use of %s since pfield was installed or changed): this "
                         "call takes seconds; all kernels usually compile in %d-%d s once, then load from the "
                         "cache. `pfield warmup` compiles them ahead of time.", _name(ev), low, high)

    def on_end(self, ev: Any) -> None:
        self._state.depth = depth = max(self._depth() - 1, 0)
        if depth == 0:
            _LOG.info("compiled %s in %.1f s", _name(ev), time.perf_counter() - self._state.started)

    @contextmanager
    def quiet(self) -> Iterator[None]:
        with self._lock:
            self._quiet += 1
        try:
            yield
        finally:
            with self._lock:
                self._quiet -= 1


def _name(ev: Any) -> str:
    dispatcher = (ev.data or {}).get("dispatcher")
    function = getattr(dispatcher, "py_func", None)
    return f"{function.__module__}.{function.__qualname__}" if function is not None else "a kernel"


_LISTENER = _Listener()
_INSTALLED = False


def install() -> None:
    """Register the listener with numba (idempotent)."""
    global _INSTALLED
    if not _INSTALLED:
        event.register("numba:compile", _LISTENER)
        _INSTALLED = True


def compiles() -> int:
    """How many top-level kernel compiles this process has started (a kernel loaded from the cache is none)."""
    return _LISTENER.compiles


def quiet() -> Any:
    """Context manager: no first-compile warning inside (the caller reports compiling itself)."""
    return _LISTENER.quiet()


install()
