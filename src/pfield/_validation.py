"""Input validation helpers shared by the value types and config objects.

Each helper takes the *field name* first so that the raised :class:`~pfield.errors.InvalidInput`
names it, e.g. ``InvalidInput("radius", -0.1, "must be > 0")``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.errors import InvalidInput


def as_vector(field: str, value: Any, length: int) -> NDArray[np.float64]:
    """Return ``value`` as a finite, read-only float64 vector of ``length`` elements."""
    try:
        array = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: an integer beyond a double's range
        raise InvalidInput(field, value, f"expected {length} finite numbers") from exc
    if array.shape != (length,):
        raise InvalidInput(field, value, f"expected {length} numbers, got {array.size}")
    # a few values: Python's isfinite on the list costs a fraction of numpy's ufunc and reduction
    if not (all(map(math.isfinite, array.tolist())) if length <= 8 else np.isfinite(array).all()):
        raise InvalidInput(field, value, "must be finite (no NaN or inf)")
    array.setflags(write=False)
    return array


_FLOAT64 = np.dtype(np.float64)


def kernel_vector(value: Any) -> bool:
    """Is ``value`` a writable C-contiguous float64 array of rank 1, the one vector type pfield's compiled
    calls are built for? Such a value may go straight into a kernel; anything else (a list, a view with
    strides, a read-only array from a message buffer, another dtype) is validated into one first, or the
    kernel would compile again for its type (seconds, in the middle of a control loop)."""
    if value.__class__ is not np.ndarray or value.dtype is not _FLOAT64 or value.ndim != 1:
        return False
    flags = value.flags
    return bool(flags.c_contiguous and flags.writeable)


def optional_vector(field: str, value: Any, length: int) -> NDArray[np.float64] | None:
    """None for None or an empty sequence (a message's default: not given); else ``value`` as a finite float64
    vector of ``length`` elements (:func:`as_vector`'s errors), as a writable copy: :func:`kernel_vector`'s type."""
    if value is None:
        return None
    try:
        empty = np.size(value) == 0
    except (TypeError, ValueError):  # ragged: as_vector names the field
        empty = False
    return None if empty else np.array(as_vector(field, value, length))


def as_points(field: str, value: Any, dim: int = 3, *, check_finite: bool = True) -> NDArray[np.float64]:
    """Return ``value`` as a finite ``(N, dim)`` float64 array (a single point becomes ``(1, dim)``).

    ``check_finite=False`` leaves the finiteness check to a compiled kernel that checks each row anyway.
    """
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(field, value, f"expected an array of shape (N, {dim})") from exc
    if array.ndim == 1 and array.shape[0] == dim:
        array = array.reshape(1, dim)
    if array.ndim != 2 or array.shape[1] != dim:
        raise InvalidInput(field, f"array{array.shape}", f"expected shape (N, {dim})")
    if check_finite and not np.all(np.isfinite(array)):
        raise InvalidInput(field, "array", "must be finite (no NaN or inf)")
    return np.ascontiguousarray(array)


def finite(field: str, value: Any) -> float:
    """Return ``value`` as a finite float; booleans are refused (``float(True)`` would pass as 1.0), and so is
    an integer beyond a double's range (``float(10**400)`` raises ``OverflowError``; a double ends near ±1.8e308)."""
    if isinstance(value, bool | np.bool_):
        raise InvalidInput(field, value, "must be a number, not a boolean")
    try:
        number = float(value)
    except OverflowError:
        raise InvalidInput(field, value, "must be a finite number (beyond a double's range, about ±1.8e308)") from None
    except (TypeError, ValueError) as exc:
        raise InvalidInput(field, value, "must be a number") from exc
    if not math.isfinite(number):
        raise InvalidInput(field, value, "must be finite (no NaN or inf)")
    return number


def positive(field: str, value: Any) -> float:
    """Return ``value`` as a finite float > 0."""
    number = finite(field, value)
    if number <= 0.0:
        raise InvalidInput(field, value, "must be > 0")
    return number


def nonnegative(field: str, value: Any) -> float:
    """Return ``value`` as a finite float >= 0."""
    number = finite(field, value)
    if number < 0.0:
        raise InvalidInput(field, value, "must be >= 0")
    return number


def text(field: str, value: Any) -> str:
    """Return ``value`` as a string that is valid UTF-8 (JSON can carry lone surrogates such as ``"\\ud800"``,
    which no encoder, log line or ROS string can hold)."""
    if not isinstance(value, str):
        raise InvalidInput(field, value, "must be a string")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise InvalidInput(field, value.encode("utf-8", "backslashreplace").decode("ascii"),
                           f"is not valid UTF-8 ({exc.reason} at position {exc.start})") from None
    return value


def is_loopback_host(host: str) -> bool:
    """Whether a bind address stays on this machine (``localhost`` or a loopback IP such as 127.0.0.1, ::1):
    serving on any other address needs a token."""
    import ipaddress

    try:
        return host == "localhost" or ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def in_range(field: str, value: Any, low: float, high: float, unit: str = "") -> float:
    """Return ``value`` as a finite float in ``[low, high]`` (the range documented for the field)."""
    number = finite(field, value)
    if not low <= number <= high:
        suffix = f" {unit}" if unit else ""
        raise InvalidInput(field, value, f"must be in [{low:g}, {high:g}]{suffix}")
    return number


def nearest_name(name: str, known: Iterable[str]) -> str | None:
    """The name of ``known`` nearest ``name`` (a misspelling's likely meaning, for a "did you mean" hint), or None
    when none is near (difflib's ratio >= 0.8)."""
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.8)
    return close[0] if close else None


def scaled_norm(values: NDArray[np.float64]) -> float:
    """Euclidean norm of finite ``values`` without overflow or underflow: scale by the largest magnitude
    before squaring (‖v‖ = m·‖v/m‖, m = max|vᵢ|), so 1e308 components give 1e308·‖·‖, not inf."""
    largest = float(np.max(np.abs(values))) if values.size else 0.0
    if largest == 0.0:
        return 0.0
    return largest * float(np.sqrt(np.sum(np.square(values / largest))))


def boolean(field: str, value: Any) -> bool:
    """Return ``value`` as a bool; only ``True``/``False`` (and numpy's) pass, never 1, 0 or strings."""
    if not isinstance(value, bool | np.bool_):
        raise InvalidInput(field, value, "must be a boolean")
    return bool(value)


def integer(field: str, value: Any) -> int:
    """Return ``value`` as an int; booleans, non-integral numbers and non-numbers are refused."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
        raise InvalidInput(field, value, "must be an integer")
    return int(value)


def number(field: str, value: Any) -> float:
    """Return ``value`` as a float when it is a number: an int or a float (numpy's too), as ROS's typed fields
    take them (an int in a float field, as ros2's YAML arguments allow). Strings and booleans are refused where
    ``float()`` would read ``"0.02"`` or ``True``; NaN and inf pass (ROS floats carry them), :func:`finite`
    refuses them."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.integer | np.floating):
        raise InvalidInput(field, value, f"must be a number, not {_type_name(value)}")
    try:
        return float(value)
    except OverflowError:
        raise InvalidInput(field, value, "must be within a double's range (about ±1.8e308)") from None


def _type_name(value: Any) -> str:
    names = {str: "a string", bytes: "bytes", bool: "a boolean", np.bool_: "a boolean", type(None): "null",
             list: "a list", dict: "a mapping"}
    return names.get(type(value), f"a {type(value).__name__}")
