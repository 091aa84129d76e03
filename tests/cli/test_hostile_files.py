"""Hostile files on the command line (issue 31, F5–F8): every one refused by the real ``pfield`` process with
exit status 2 and one line on stderr, no traceback, within 30 s and 500 MB.

Each file is made in ``tmp_path`` from a few kilobytes: YAML aliases that expand to a billion nodes, YAML nested
10 000 deep, bytes that are not UTF-8, a 50 MB scene, a FIFO, a link to ``/dev/zero``, archives that expand far
beyond their size or hold too many members, a truncated archive, a member that climbs out of the destination,
and output paths that cannot be written. The process's peak memory is measured by a small parent process of its
own (:data:`MEASURE`): Linux counts a child's copy of its parent's memory before ``exec`` in the child's peak.
"""

from __future__ import annotations

import bz2
import gzip
import io
import json
import os
import subprocess
import sys
import tarfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from serve_process import PFIELD, REPO

SECONDS = 30.0
PEAK_MB = 500.0
SCENE = REPO / "examples" / "manipulator" / "scene.yaml"
MOVEIT = REPO / "examples" / "batch" / "moveit"


@dataclass(frozen=True)
class Finished:
    code: int
    stdout: str
    stderr: str
    seconds: float
    peak_mb: float


# A small parent for the measured process: the peak RSS that Linux reports for a child includes its parent's
# memory at the fork (the child's copy of it until exec), so a child of the test session would report the session's
# size. Forked from this parent instead, the child's peak is its own (at least this parent's few MB). The parent
# also ends a hang: it kills the child after its timeout.
MEASURE = """
import resource, subprocess, sys
timeout, peak_file = float(sys.argv[1]), sys.argv[2]
try:
    code = subprocess.run(sys.argv[3:], timeout=timeout).returncode
except subprocess.TimeoutExpired:
    code = -9
with open(peak_file, "w") as out:
    out.write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))
sys.exit(code if code >= 0 else 128 - code)
"""


def run_pfield(*args: str, cwd: Path) -> Finished:
    """``pfield ARGS`` in ``cwd``: exit status, output, wall time and the process's own peak RSS."""
    out, err, peak = cwd / "stdout.txt", cwd / "stderr.txt", cwd / "peak_kb.txt"
    with out.open("wb") as stdout, err.open("wb") as stderr:
        start = time.monotonic()
        code = subprocess.run([sys.executable, "-c", MEASURE, str(4 * SECONDS), str(peak), str(PFIELD), *args],
                              stdout=stdout, stderr=stderr, cwd=cwd, check=False).returncode
        seconds = time.monotonic() - start
    return Finished(code, out.read_text(), err.read_text(), seconds, int(peak.read_text()) / 1024)


def assert_refused(done: Finished, *phrases: str) -> None:
    """Exit status 2, one line ``error: ...`` on stderr holding ``phrases``, no traceback, within the bounds."""
    lines = done.stderr.splitlines()
    assert done.code == 2, done.stderr
    assert len(lines) == 1 and lines[0].startswith("error: "), done.stderr
    assert "Traceback" not in done.stderr + done.stdout
    for phrase in phrases:
        assert phrase in lines[0]
    assert done.seconds < SECONDS and done.peak_mb < PEAK_MB, (done.seconds, done.peak_mb)


# -- the files ---------------------------------------------------------------------------------------------

def billion_laughs(tail: str = "") -> str:
    """Nine levels of nine aliases: 9**9 (387 million) scalars once expanded, 400 bytes written."""
    lines = ["a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for level in range(1, 9):
        name, below = chr(ord("a") + level), chr(ord("a") + level - 1)
        lines.append(f"{name}: &{name} [" + ", ".join([f"*{below}"] * 9) + "]")
    return "\n".join(lines) + "\n" + tail


def write(path: Path, text: str | bytes) -> Path:
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return path


def laughs(tmp: Path) -> Path:
    return write(tmp / "laughs.yaml", billion_laughs("obstacles: *i\n"))


def deep(tmp: Path) -> Path:
    return write(tmp / "deep.yaml", "[" * 10_000 + "]" * 10_000)


def deep_block(tmp: Path) -> Path:
    return write(tmp / "deep_block.yaml", "- " * 10_000 + "x\n")


def not_utf8(tmp: Path) -> Path:
    return write(tmp / "latin1.yaml", "obstacles: []\n# café\n".encode("latin-1"))


def fifty_megabytes(tmp: Path) -> Path:
    path = write(tmp / "large.yaml", "obstacles: []\n")
    with path.open("r+b") as handle:
        handle.truncate(50 * 2**20)  # sparse: the bound is on the size, checked before reading
    return path


def fifo(tmp: Path) -> Path:
    os.mkfifo(tmp / "pipe.yaml")  # nobody writes: reading it would wait forever
    return tmp / "pipe.yaml"


def dev_zero(tmp: Path) -> Path:
    (tmp / "zero.yaml").symlink_to("/dev/zero")  # endless zeros
    return tmp / "zero.yaml"


def string_number(tmp: Path) -> Path:
    return write(tmp / "strings.yaml", 'delta_time: "0.02"\n')


def boolean_number(tmp: Path) -> Path:
    return write(tmp / "booleans.yaml", "params: {attractive_gain: true}\n")


SCENE_FILES: dict[str, tuple[Callable[[Path], Path], str]] = {
    "billion laughs": (laughs, "aliases repeat"),
    "10 000 deep flow": (deep, "nested deeper than 100 levels"),
    "10 000 deep block": (deep_block, "nested deeper than 100 levels"),
    "not UTF-8": (not_utf8, "not UTF-8 text (byte 0xe9"),
    "50 MB": (fifty_megabytes, "over the limit of 8388608"),
    "FIFO": (fifo, "is a FIFO"),
    "link to /dev/zero": (dev_zero, "is a character device (/dev/zero)"),
    "string for a number": (string_number, "delta_time='0.02': must be a number, not a string"),
    "boolean for a number": (boolean_number, "params.attractive_gain=True: must be a number, not a boolean"),
}


def tar_header(name: str, size: int) -> bytes:
    info = tarfile.TarInfo(name)
    info.size = size
    return info.tobuf(format=tarfile.GNU_FORMAT)


def compressed_zeros(compress: Callable[[bytes], bytes], header: bytes, mebibytes: int) -> bytes:
    """``header`` and ``mebibytes`` MiB of zeros as concatenated compressed streams (gzip and bzip2 read them as
    one): one MiB is compressed once and repeated, so a gigabyte costs a millisecond to make."""
    chunk = compress(b"\0" * 2**20)
    return compress(header) + chunk * mebibytes


def gzip_bomb(tmp: Path) -> Path:
    """1 MB of gzip declaring one 1 GiB member: the tester's archive that filled /tmp with a gigabyte."""
    data = compressed_zeros(gzip.compress, tar_header("problems/box/scene0001.yaml", 2**30), 1024)
    return write(tmp / "bomb.tar.gz", data + gzip.compress(b"\0" * 1024))


def bzip2_bomb(tmp: Path) -> Path:
    """Members of 1 MiB of zeros each, 80 MiB in all: the total passes the bound, no member alone does."""
    chunk = bz2.compress(b"\0" * 2**20)
    parts = [bz2.compress(tar_header(f"problems/box/filler{i:03d}.bin", 2**20)) + chunk for i in range(80)]
    return write(tmp / "bomb.tar.bz2", b"".join(parts) + bz2.compress(b"\0" * 1024))


def many_members(tmp: Path) -> Path:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as archive:
        for i in range(10_001):
            archive.addfile(tarfile.TarInfo(f"problems/box/empty{i:05d}.yaml"))
    return write(tmp / "many.tar.gz", buffer.getvalue())


def truncated(tmp: Path) -> Path:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as archive:
        archive.add(MOVEIT, arcname="problems/moveit")
    return write(tmp / "cut.tar.gz", buffer.getvalue()[: len(buffer.getvalue()) // 2])


def climbing(tmp: Path) -> Path:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as archive:
        text = b"obstacles: []\n"
        info = tarfile.TarInfo("../../escaped.yaml")
        info.size = len(text)
        archive.addfile(info, io.BytesIO(text))
    return write(tmp / "climb.tar.gz", buffer.getvalue())


def fifo_archive(tmp: Path) -> Path:
    os.mkfifo(tmp / "pipe.tar.gz")
    return tmp / "pipe.tar.gz"


ARCHIVES: dict[str, tuple[Callable[[Path], Path], str]] = {
    "gzip bomb": (gzip_bomb, "more than 67108864 bytes"),
    "bzip2 bomb": (bzip2_bomb, "more than 67108864 bytes"),
    "10 001 members": (many_members, "more than 10000 members"),
    "truncated gzip": (truncated, "truncated"),
    "member outside the folder": (climbing, "outside the destination"),
    "FIFO": (fifo_archive, "is a FIFO"),
    "billion laughs scene": (laughs, "aliases repeat"),
    "link to /dev/zero": (dev_zero, "is a character device"),
}


# -- the tests ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("case", list(SCENE_FILES))
def test_plan_refuses_a_hostile_scene_file(case: str, tmp_path: Path) -> None:
    make, phrase = SCENE_FILES[case]
    done = run_pfield("plan", "--scene", str(make(tmp_path)), "-o", str(tmp_path / "plan.png"), cwd=tmp_path)
    assert_refused(done, phrase)
    assert not (tmp_path / "plan.png").exists()


@pytest.mark.parametrize("case", list(ARCHIVES))
def test_batch_refuses_a_hostile_archive_or_file(case: str, tmp_path: Path) -> None:
    make, phrase = ARCHIVES[case]
    work = tmp_path / "work"
    work.mkdir()
    done = run_pfield("batch", str(make(tmp_path)), "--out", str(work / "results.jsonl"), cwd=work)
    assert_refused(done, phrase)
    assert not (work / "results.jsonl").exists()
    assert not (tmp_path / "escaped.yaml").exists() and not (work / "escaped.yaml").exists()


def test_a_billion_laughs_moveit_pair_is_one_short_error_record(tmp_path: Path) -> None:
    """One unreadable pair of a problem set is one record with status error (exit 1), as any bad pair is: its
    error quotes a few characters, not the gigabytes the tester's results file held."""
    folder = tmp_path / "laughs_panda"
    folder.mkdir()
    write(folder / "scene0001.yaml", billion_laughs("world: {collision_objects: *i}\n"))
    write(folder / "request0001.yaml", billion_laughs("goal_constraints: *i\n"))
    done = run_pfield("batch", str(folder), "--out", str(tmp_path / "results.jsonl"), cwd=tmp_path)
    assert done.code == 1, done.stderr
    assert "Traceback" not in done.stderr + done.stdout
    assert done.seconds < SECONDS and done.peak_mb < PEAK_MB, (done.seconds, done.peak_mb)
    (record,) = map(json.loads, (tmp_path / "results.jsonl").read_text().splitlines())
    assert record["status"] == "error" and "aliases repeat" in record["error"] and len(record["error"]) < 300


@pytest.mark.parametrize(("command", "option"), [
    (["batch", str(SCENE), "--out"], "--out"),
    (["plan", "--scene", str(SCENE), "-o"], "--output"),
    (["plan", "--scene", str(SCENE), "--csv"], "--csv"),
], ids=["batch --out", "plan -o", "plan --csv"])
def test_an_unwritable_output_is_refused_before_planning(command: list[str], option: str, tmp_path: Path) -> None:
    missing = tmp_path / "nonexistent" / "dir"
    for target, phrase in ((str(missing / "x.out"), f"its folder {missing} does not exist"),
                           ("/proc/x.out", "cannot create a file in /proc"), (str(tmp_path), "is a folder")):
        done = run_pfield(*command, target, cwd=tmp_path)
        assert_refused(done, f"{option}=", phrase)
        assert done.seconds < 10.0  # refused before anything is planned (a plan and its plot take longer)
    assert not (tmp_path / "nonexistent").exists()  # the plot once made the missing folders
