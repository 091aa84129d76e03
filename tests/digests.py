"""One fingerprint of many arrays, for the tests that hold the compiled core to the numba engine's results.

Before numba was removed (issue 32) each of those tests compared the core with its numba twin bit for bit; the
digest recorded then, of outputs checked equal to numba's one by one, now stands for the twin: any change of a
single bit (value, signed zero, NaN payload), dtype or shape changes it.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from typing import Any

import numpy as np


def digest(values: Iterable[Any]) -> str:
    """The sha256 (hex) of every value's dtype, shape and bytes, in order (scalars as 1-element arrays)."""
    hashed = hashlib.sha256()
    for value in values:
        array = np.ascontiguousarray(value)
        hashed.update(f"{array.dtype.str}{array.shape}".encode())
        hashed.update(array.tobytes())
    return hashed.hexdigest()
