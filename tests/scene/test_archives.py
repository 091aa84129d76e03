"""Problem archives unpacked within bounds: the compressions told by their first bytes, the size and member
bounds checked before anything beyond them is written, members kept inside the destination, damage reported."""

from __future__ import annotations

import io
import os
import tarfile
from pathlib import Path

import pytest

from pfield.errors import InvalidInput
from pfield.scene import _archives
from pfield.scene._archives import extract_archive

MOVEIT = Path(__file__).resolve().parents[2] / "examples" / "batch" / "moveit"


def archive(path: Path, members: list[tuple[tarfile.TarInfo, bytes]], mode: str = "w:gz") -> Path:
    with tarfile.open(path, mode) as opened:
        for info, data in members:
            info.size = len(data) if info.isreg() else 0
            opened.addfile(info, io.BytesIO(data) if info.isreg() else None)
    return path


def member(name: str, data: bytes = b"obstacles: []\n", kind: bytes = tarfile.REGTYPE, link: str = "") -> tuple[
        tarfile.TarInfo, bytes]:
    info = tarfile.TarInfo(name)
    info.type, info.linkname = kind, link
    return info, data


@pytest.mark.parametrize("mode", ["w", "w:gz", "w:bz2", "w:xz"])
def test_every_compression_is_told_by_its_first_bytes(mode: str, tmp_path: Path) -> None:
    path = tmp_path / "problems.tar.gz"  # the name says gzip; the content decides
    with tarfile.open(path, mode) as opened:
        opened.add(MOVEIT, arcname="problems/moveit")
    extract_archive(path, tmp_path / "out")
    assert sorted(p.name for p in (tmp_path / "out" / "problems" / "moveit").iterdir()) == sorted(
        p.name for p in MOVEIT.iterdir())


def test_the_member_count_is_bounded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_archives, "MAX_ARCHIVE_MEMBERS", 3)
    extract_archive(archive(tmp_path / "three.tar.gz", [member(f"f{i}.yaml") for i in range(3)]), tmp_path / "a")
    with pytest.raises(InvalidInput, match="more than 3 members") as raised:
        extract_archive(archive(tmp_path / "four.tar.gz", [member(f"f{i}.yaml") for i in range(4)]), tmp_path / "b")
    assert raised.value.field == "problems"


def test_a_member_beyond_the_size_bound_is_refused_before_it_is_written(tmp_path: Path,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_archives, "MAX_ARCHIVE_BYTES", 100_000)
    path = archive(tmp_path / "big.tar.gz", [member("small.yaml"), member("big.yaml", b"\0" * 100_001)])
    with pytest.raises(InvalidInput, match="members hold more than 100000 bytes"):
        extract_archive(path, tmp_path / "out")
    assert (tmp_path / "out" / "small.yaml").exists() and not (tmp_path / "out" / "big.yaml").exists()


def test_the_decompressed_stream_itself_is_bounded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Padding and headers count too: 30 empty members are 15 kB of tar stream."""
    monkeypatch.setattr(_archives, "MAX_ARCHIVE_BYTES", 10_000)
    with pytest.raises(InvalidInput, match="more than 10000 bytes once decompressed"):
        extract_archive(archive(tmp_path / "empty.tar.gz", [member(f"e{i}", b"") for i in range(30)]), tmp_path / "o")


def test_a_huge_pax_header_is_refused_before_it_is_read_into_memory(tmp_path: Path) -> None:
    info, data = member("a.yaml")
    info.pax_headers = {"comment": "x" * (2 * 2**20)}
    with tarfile.open(tmp_path / "pax.tar.gz", "w:gz", format=tarfile.PAX_FORMAT) as opened:
        info.size = len(data)
        opened.addfile(info, io.BytesIO(data))
    with pytest.raises(InvalidInput, match="header is larger than 1048576 bytes"):
        extract_archive(tmp_path / "pax.tar.gz", tmp_path / "out")


@pytest.mark.parametrize(("entry", "words"), [
    (member("../../escaped.yaml"), "outside the destination"),
    (member("zero.yaml", b"", tarfile.SYMTYPE, "/dev/zero"), "absolute path"),
    (member("up.yaml", b"", tarfile.SYMTYPE, "../../../etc/passwd"), "outside the destination"),
    (member("pipe.yaml", b"", tarfile.FIFOTYPE), "special file"),
    (member("null", b"", tarfile.CHRTYPE), "special file"),
])
def test_members_stay_inside_the_destination_and_are_files_or_folders(entry: tuple[tarfile.TarInfo, bytes],
                                                                      words: str, tmp_path: Path) -> None:
    destination = tmp_path / "a" / "b" / "out"
    with pytest.raises(InvalidInput, match=words):
        extract_archive(archive(tmp_path / "bad.tar.gz", [entry]), destination)
    assert not list(tmp_path.rglob("escaped.yaml"))


def test_an_absolute_member_name_lands_inside_the_destination(tmp_path: Path) -> None:
    extract_archive(archive(tmp_path / "abs.tar.gz", [member("/tmp/escaped.yaml")]), tmp_path / "out")
    assert (tmp_path / "out" / "tmp" / "escaped.yaml").read_text() == "obstacles: []\n"


@pytest.mark.parametrize("mode", ["w:gz", "w:bz2", "w:xz", "w"])
def test_a_truncated_archive_says_so(mode: str, tmp_path: Path) -> None:
    path = tmp_path / "cut.tar"
    with tarfile.open(path, mode) as opened:
        opened.add(MOVEIT, arcname="problems/moveit")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(InvalidInput, match=r"truncated|unexpected end of data"):
        extract_archive(path, tmp_path / "out")


def test_garbage_and_non_files_are_refused(tmp_path: Path) -> None:
    (tmp_path / "noise.tar.gz").write_bytes(b"\x1f\x8b" + os.urandom(4000))
    with pytest.raises(InvalidInput, match="cannot read the archive"):
        extract_archive(tmp_path / "noise.tar.gz", tmp_path / "out")
    os.mkfifo(tmp_path / "pipe.tar.gz")
    with pytest.raises(InvalidInput, match="is a FIFO"):
        extract_archive(tmp_path / "pipe.tar.gz", tmp_path / "out")
    (tmp_path / "zero.tar.gz").symlink_to("/dev/zero")
    with pytest.raises(InvalidInput, match="character device"):
        extract_archive(tmp_path / "zero.tar.gz", tmp_path / "out")
