"""Cooperative cancellation of a running plan.

A :class:`CancelToken` is a one-element ``uint8`` array that the compiled core's planning loops read between
iterations, without the GIL (they cannot wait on a ``threading.Event``): another thread calls :meth:`cancel`,
the loop sees the flag at its next check and ends with the status ``cancelled``. The node's transports
create one per long-running request and cancel it when the client goes away.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["CancelToken", "cancel_flag"]


class CancelToken:
    """A flag a plan checks while it runs; :meth:`cancel` asks it to stop as soon as it can."""

    def __init__(self) -> None:
        self.flag: NDArray[np.uint8] = np.zeros(1, dtype=np.uint8)
        """Read by compiled loops (``flag[0] != 0`` means stop); written only through :meth:`cancel`."""

    def cancel(self) -> None:
        self.flag[0] = 1

    @property
    def cancelled(self) -> bool:
        return bool(self.flag[0])


def cancel_flag(token: CancelToken | None) -> NDArray[np.uint8]:
    """The flag a compiled loop reads: ``token``'s, or without one a fresh flag that nobody cancels.

    Always a one-element ``uint8`` array, the type the core's loops take (``cancel[0] != 0`` ends them)."""
    return (token if token is not None else CancelToken()).flag
