"""Files named by a user: regular files of bounded size read, everything else refused without blocking;
outputs checked before the work."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from pfield._files import check_writable, open_regular, read_bytes, read_text
from pfield.errors import InvalidInput


def test_only_regular_files_are_opened(tmp_path: Path) -> None:
    (tmp_path / "scene.yaml").write_text("a: 1\n")
    (tmp_path / "link.yaml").symlink_to(tmp_path / "scene.yaml")
    with open_regular("scene", tmp_path / "link.yaml") as handle:
        assert handle.read() == b"a: 1\n"
    os.mkfifo(tmp_path / "pipe.yaml")  # without a writer: a blocking open would never return
    (tmp_path / "zero.yaml").symlink_to("/dev/zero")
    for name, words in (("pipe.yaml", "is a FIFO (named pipe), not a regular file"),
                        ("zero.yaml", "is a character device (/dev/zero), not a regular file"),
                        (".", "is a folder"), ("missing.yaml", "no such file")):
        with pytest.raises(InvalidInput, match=re.escape(words)) as info:
            open_regular("scene", tmp_path / name)
        assert info.value.field == "scene" and info.value.value == str(tmp_path / name)


def test_sizes_are_bounded_before_and_while_reading(tmp_path: Path) -> None:
    path = tmp_path / "large.yaml"
    path.write_bytes(b"x" * 100)
    assert read_bytes("scene", path, 100) == b"x" * 100
    with pytest.raises(InvalidInput, match="is 100 bytes, over the limit of 99"):
        read_bytes("scene", path, 99)
    # /proc reports a size of 0 for files that hold more: the read itself stops at the bound
    with pytest.raises(InvalidInput, match="holds more than the limit of 10 bytes"):
        read_bytes("scene", "/proc/self/status", 10)


def test_text_is_utf8_and_the_first_bad_byte_is_named(tmp_path: Path) -> None:
    (tmp_path / "ok.yaml").write_text("name: café\n", encoding="utf-8")
    assert read_text("scene", tmp_path / "ok.yaml", 100) == "name: café\n"
    (tmp_path / "latin1.yaml").write_bytes("name: café\n".encode("latin-1"))
    with pytest.raises(InvalidInput, match="is not UTF-8 text \\(byte 0xe9 at offset 9\\)"):
        read_text("scene", tmp_path / "latin1.yaml", 100)


def test_outputs_are_checked_before_the_work(tmp_path: Path) -> None:
    assert check_writable("--out", tmp_path / "new.jsonl") == tmp_path / "new.jsonl"
    assert list(tmp_path.iterdir()) == []  # the probe leaves nothing behind
    (tmp_path / "old.jsonl").write_text("{}\n")
    check_writable("--out", tmp_path / "old.jsonl")
    for path, words in ((tmp_path / "no" / "such" / "x.jsonl", f"its folder {tmp_path}/no/such does not exist"),
                        (tmp_path, "is a folder"), (Path("/proc/x.jsonl"), "cannot create a file in /proc")):
        with pytest.raises(InvalidInput, match=words) as info:
            check_writable("--out", path)
        assert info.value.field == "--out"
