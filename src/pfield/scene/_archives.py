"""Problem archives unpacked within bounds: at most :data:`MAX_ARCHIVE_BYTES` of tar stream (headers and
member data, decompressed) and :data:`MAX_ARCHIVE_MEMBERS` members, every member inside the destination.

An archive is small on disk and may be anything once decompressed: 5 MB of gzip can hold a terabyte of zeros,
a member's header may declare any size, and a pax header is read into memory whole. The bounds are checked
on the decompressed stream itself, before tar reads from it: a member whose declared size would pass the
bound is refused before any of it is written, and no single read may exceed :data:`_LARGEST_READ` (tar reads
member data in 16 KiB pieces; only a header is read at once). Members pass :mod:`tarfile`'s ``"data"``
filter: no absolute paths, no ``..`` out of the destination, no links leading out of it, no devices or FIFOs.
"""

from __future__ import annotations

import bz2
import gzip
import lzma
import tarfile
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import BinaryIO, cast

from pfield._files import open_regular
from pfield.errors import InvalidInput, short_repr

__all__ = ["MAX_ARCHIVE_BYTES", "MAX_ARCHIVE_MEMBERS", "extract_archive"]

MAX_ARCHIVE_BYTES = 64 * 2**20
"""Largest tar stream of a problem archive once decompressed (64 MiB): every problem is read into memory
(about twice its YAML size), and MotionBenchMaker's Panda and UR5 sets take 2.2 and 5.8 MB."""
MAX_ARCHIVE_MEMBERS = 10_000
"""Most members (files and folders) of a problem archive: 5 000 problems (the UR5 set has 1 408 members)."""
_LARGEST_READ = 2**20
_COMPRESSIONS: tuple[tuple[bytes, Callable[[BinaryIO], object]], ...] = (
    (b"\x1f\x8b", lambda raw: gzip.GzipFile(fileobj=raw)), (b"BZh", bz2.BZ2File), (b"\xfd7zXZ\x00", lzma.LZMAFile))


class _OutOfBounds(Exception):
    pass


class _BoundedStream:
    """The decompressed tar stream, which refuses to be read or sought beyond ``limit`` bytes or read more
    than :data:`_LARGEST_READ` at once (the three calls :mod:`tarfile` makes of an uncompressed file)."""

    def __init__(self, stream: BinaryIO, limit: int) -> None:
        self._stream = stream
        self._limit = limit

    def read(self, size: int = -1) -> bytes:
        if size < 0 or size > _LARGEST_READ:
            raise _OutOfBounds(f"a member header is larger than {_LARGEST_READ} bytes")
        self._check(self._stream.tell() + size)
        return self._stream.read(size)

    def seek(self, offset: int, whence: int = 0) -> int:
        self._check(offset if whence == 0 else self._stream.tell() + offset)
        return self._stream.seek(offset, whence)

    def tell(self) -> int:
        return self._stream.tell()

    def _check(self, end: int) -> None:
        if end > self._limit:
            raise _OutOfBounds(f"it holds more than {self._limit} bytes once decompressed")


def _decompressed(raw: BinaryIO) -> BinaryIO:
    """``raw`` decompressed by the compression its first bytes name (gzip, bzip2, xz), else ``raw``."""
    start = raw.read(6)
    raw.seek(0)
    for magic, opener in _COMPRESSIONS:
        if start.startswith(magic):
            return cast(BinaryIO, opener(raw))
    return raw


def _members(archive: tarfile.TarFile) -> Iterator[tarfile.TarInfo]:
    """The members of ``archive`` as they are read, refused past the count or the total declared size."""
    total = 0
    for count, member in enumerate(archive, 1):
        total += member.size
        if count > MAX_ARCHIVE_MEMBERS:
            raise _OutOfBounds(f"it holds more than {MAX_ARCHIVE_MEMBERS} members")
        if total > MAX_ARCHIVE_BYTES:
            raise _OutOfBounds(f"its members hold more than {MAX_ARCHIVE_BYTES} bytes ({short_repr(member.name)} "
                               f"declares {member.size})")
        yield member


def extract_archive(path: Path, folder: Path, field: str = "problems") -> None:
    """Unpack the tar archive ``path`` (plain, gzip, bzip2 or xz, told by its first bytes) into ``folder``
    within the bounds of the module text. Raises :class:`~pfield.errors.InvalidInput` naming ``field`` and
    the path for a file that is not a regular file, a damaged or truncated archive, a member that would land
    outside ``folder`` and an archive beyond the bounds."""
    try:
        with open_regular(field, path) as raw, _decompressed(raw) as stream, \
                tarfile.open(fileobj=_BoundedStream(stream, MAX_ARCHIVE_BYTES), mode="r:") as archive:  # type: ignore[call-overload]
            archive.extractall(folder, members=_members(archive), filter="data")
    except _OutOfBounds as exc:
        raise InvalidInput(field, str(path), f"archive refused: {exc}") from None
    except EOFError as exc:  # a compressed stream cut short (zlib, bz2 and lzma alike)
        raise InvalidInput(field, str(path), f"cannot read the archive: it is truncated ({exc})") from None
    except (OSError, tarfile.TarError, zlib.error, lzma.LZMAError) as exc:
        raise InvalidInput(field, str(path), f"cannot read the archive ({exc})") from None
