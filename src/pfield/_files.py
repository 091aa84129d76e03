"""Files named by a user: inputs read only when they are regular files of bounded size, outputs checked before
the work whose result they receive.

A path on the command line, in a problem set or inside an archive may name anything the operating system can
open: a FIFO (reading blocks until a writer comes, forever in a batch), a device (``/dev/zero`` never ends), a
folder, or a file far larger than any scene. An input is opened without blocking and judged by ``fstat`` of
the opened descriptor, so the check follows symbolic links and sees the very file that is then read; at most
``max_bytes`` are read even when the size reported beforehand was smaller (a file still growing, ``/proc``).
Every refusal is an :class:`~pfield.errors.InvalidInput` naming the option or file it came from.
"""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path
from typing import BinaryIO

from pfield.errors import InvalidInput

__all__ = ["PICTURE_SUFFIXES", "check_picture", "check_writable", "open_regular", "read_bytes", "read_text",
           "relative_to_cwd", "writable_folder"]

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "a special file")


def open_regular(field: str, path: str | Path) -> BinaryIO:
    """``path`` opened for binary reading when it is a regular file (after following symbolic links); a FIFO,
    a device, a socket or a folder is refused without blocking."""
    try:
        # O_NONBLOCK: opening a FIFO would otherwise wait for a writer before fstat could refuse it
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        raise InvalidInput(field, str(path), "no such file") from None
    except OSError as exc:
        raise InvalidInput(field, str(path), f"cannot open it ({exc.strerror})") from None
    try:
        mode = os.fstat(descriptor).st_mode
        if not stat.S_ISREG(mode):
            real = os.path.realpath(path)
            target = f" ({real})" if real != os.path.abspath(path) else ""
            raise InvalidInput(field, str(path), f"is {_kind(mode)}{target}, not a regular file")
        os.set_blocking(descriptor, True)
        return os.fdopen(descriptor, "rb")
    except BaseException:
        os.close(descriptor)
        raise


def read_bytes(field: str, path: str | Path, max_bytes: int) -> bytes:
    """The content of the regular file ``path`` (:func:`open_regular`), refused beyond ``max_bytes``."""
    with open_regular(field, path) as handle:
        size = os.fstat(handle.fileno()).st_size
        if size > max_bytes:
            raise InvalidInput(field, str(path), f"is {size} bytes, over the limit of {max_bytes}")
        data = handle.read(max_bytes + 1)
    if len(data) > max_bytes:  # a file that grew, or one whose reported size means nothing (/proc)
        raise InvalidInput(field, str(path), f"holds more than the limit of {max_bytes} bytes")
    return data


def read_text(field: str, path: str | Path, max_bytes: int) -> str:
    """The content of the regular file ``path`` as UTF-8 text (:func:`read_bytes`); other bytes are refused
    naming the first offending byte and its offset."""
    data = read_bytes(field, path, max_bytes)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InvalidInput(field, str(path), f"is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset "
                                             f"{exc.start})") from None


def check_writable(field: str, path: str | Path) -> Path:
    """``path`` as a file pfield may create or overwrite: not a folder, in a folder that exists and takes new
    files (tried with a nameless temporary file, which also catches read-only file systems and ``/proc``).
    Commands call this before the work whose result goes there, so a mistyped path costs nothing."""
    target = Path(path)
    if target.is_dir():
        raise InvalidInput(field, str(path), "is a folder; give a file name")
    folder = target.parent
    if not folder.is_dir():
        raise InvalidInput(field, str(path), f"its folder {folder} does not exist")
    if target.exists():
        if not os.access(target, os.W_OK):
            raise InvalidInput(field, str(path), "is not writable")
        return target
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise InvalidInput(field, str(path), f"cannot create a file in {folder} ({exc.strerror})") from None
    return target


PICTURE_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".tif", ".tiff", ".webp")
"""The picture formats a command's ``--output`` may name (matplotlib writes each by the file's suffix)."""


def check_picture(field: str, path: str | Path) -> Path:
    """``path`` as a picture pfield may write (:func:`check_writable`) in a format it can write, checked before the
    work whose picture it is."""
    target = check_writable(field, path)
    if target.suffix.lower() not in PICTURE_SUFFIXES:
        raise InvalidInput(field, str(path), f"not a picture format pfield writes; end it in one of "
                                             f"{', '.join(PICTURE_SUFFIXES)}")
    return target


def writable_folder(field: str, path: str | Path) -> Path:
    """``path`` as a folder pfield may write files into, created (with its parents) when missing; a file there or
    a place no folder can be made (``/proc``, read-only) is an ``InvalidInput`` naming ``field``."""
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise InvalidInput(field, str(path), "is a file; give a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise InvalidInput(field, str(path), f"cannot write files there ({exc.strerror})") from None
    return folder


def relative_to_cwd(path: Path) -> str:
    """For a message about a path the caller gave: where a relative ``path`` was looked for, ``" (looked for
    ABSOLUTE: relative paths are read from the current folder)"``; "" for an absolute one."""
    if path.is_absolute():
        return ""
    return f" (looked for {Path.cwd() / path}: relative paths are read from the current folder)"
