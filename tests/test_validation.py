"""The shared validation helpers refuse what ``float()`` would silently accept."""

from __future__ import annotations

import numpy as np
import pytest

from pfield._validation import as_vector, finite, is_loopback_host, nonnegative, positive
from pfield.errors import InvalidInput


@pytest.mark.parametrize("helper", [finite, positive, nonnegative])
@pytest.mark.parametrize("value", [True, False, np.bool_(True), float("nan"), float("inf"), "abc", None])
def test_booleans_non_finite_and_non_numbers_are_refused_naming_the_field(helper: object, value: object) -> None:
    with pytest.raises(InvalidInput) as info:
        helper("gain", value)  # type: ignore[operator]
    assert info.value.field == "gain"


@pytest.mark.parametrize("value", [10**400, -(10**400), "1e999"])
def test_numbers_beyond_a_double_are_refused_not_overflowing(value: object) -> None:
    """``float(10**400)`` raises OverflowError, which a transport would answer 500 (issue 31 F3)."""
    for helper in (finite, positive, nonnegative):
        with pytest.raises(InvalidInput) as info:
            helper("influence_distance", value)
        assert info.value.field == "influence_distance"
    with pytest.raises(InvalidInput) as info:
        as_vector("translation", [value, 0.0, 0.0], 3)
    assert info.value.field == "translation"


def test_numbers_and_numeric_strings_pass() -> None:
    assert finite("gain", "0.5") == 0.5
    assert positive("gain", np.float32(2.0)) == 2.0
    assert nonnegative("gain", 0) == 0.0


@pytest.mark.parametrize(("host", "loopback"), [("localhost", True), ("127.0.0.1", True), ("127.8.0.3", True),
                                                 ("::1", True), ("0.0.0.0", False), ("192.168.1.5", False),
                                                 ("::", False), ("example.org", False), ("", False)])
def test_a_bind_address_is_loopback_only_on_this_machine(host: str, loopback: bool) -> None:
    assert is_loopback_host(host) is loopback
