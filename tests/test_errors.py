"""Error messages stay short whatever the value: a prefix of its ``repr``, found in bounded time."""

from __future__ import annotations

import time

from pfield.errors import VALUE_CHARS, InvalidInput, short_repr


def laughs() -> list[object]:
    """Nine levels of nine references to the level below: 387 million strings when walked in full."""
    level: list[object] = ["lol"] * 9
    for _ in range(8):
        level = [level] * 9
    return level


def test_a_billion_laughs_value_is_quoted_in_80_characters_at_once() -> None:
    started = time.perf_counter()
    message = str(InvalidInput("obstacles[0]", laughs(), "expected a mapping"))
    assert time.perf_counter() - started < 0.1
    assert message.startswith("obstacles[0]=[[[[") and message.endswith("…: expected a mapping")
    assert len(message) == len("obstacles[0]=") + VALUE_CHARS + len(": expected a mapping")


def test_short_values_are_quoted_as_repr_quotes_them() -> None:
    assert str(InvalidInput("radius", -0.1, "must be > 0")) == "radius=-0.1: must be > 0"
    for value in ("ball", [1, 2.5, None], {"b": 1, "a": (2,)}, 3, True):
        assert short_repr(value) == repr(value)  # mappings keep their own order, as repr does


def test_long_strings_huge_integers_and_broken_reprs() -> None:
    assert short_repr("x" * 10**7) == "'" + "x" * (VALUE_CHARS - 2) + "…"
    assert short_repr(10**10_000) == "<an integer of 33220 bits>"  # repr() itself refuses 10 001 digits

    class Broken:
        def __repr__(self) -> str:
            raise RuntimeError("no repr")

    assert short_repr(Broken()) == "<Broken>"
    assert short_repr(list(range(10**6)), limit=20) == "[0, 1, 2, 3, 4, 5, …"


def test_field_and_reason_are_bounded_too() -> None:
    message = str(InvalidInput("k" * 10_000, 1, "r" * 10_000))
    assert len(message) < 1300 and message.count("…") == 2


def test_a_long_file_path_keeps_its_file_name() -> None:
    """A path too long to quote whole is cut in the middle: the file name a reader must fix stays in the message
    (a test's temporary folder under pytest-xdist is longer than the quotation)."""
    from pathlib import Path

    path = "/tmp/pytest-of-root/pytest-323/popen-gw0/test_param_load_sets_the_nodes0/" + "deep/" * 5 + "missing.yaml"
    for value in (path, Path(path)):
        quoted = short_repr(value)
        assert len(quoted) == VALUE_CHARS and quoted.endswith("/missing.yaml'") and quoted.startswith("'/tmp/")
        assert "…" in quoted
    assert short_repr("/short/file.yaml") == "'/short/file.yaml'"
    assert str(InvalidInput("FILE", path, "no such file")).endswith("missing.yaml': no such file")
