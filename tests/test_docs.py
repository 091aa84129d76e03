"""Every shell block and Python snippet of README.md and docs/*.md runs as written, and says what it prints.

How a block is run and checked:

* ``bash`` blocks run with ``bash -euo pipefail`` in one working folder per document (with ``src``, ``tests``,
  ``examples``, ``ros`` and ``benchmarks`` linked from the repository and ``../shared`` beside it, so relative
  paths work and written files stay out of the tree), against a real ``pfield serve`` this test starts on a
  free 127.0.0.1 port (``PFIELD_URL``).
  A line ``pfield serve ARGS &`` starts another real server with those arguments on a free port (and points
  ``PFIELD_URL`` at it for the rest of the block). Every command must exit 0.
* ``python`` blocks run in-process, statement by statement, in that folder. A statement with a trailing
  ``# -> VALUE`` comment is checked: its ``repr`` must match VALUE, where numbers count as equal when the
  value rounds (or, written ``0.1488...``, truncates) to the digits shown, and a lone ``…`` stands for
  anything.
* After a block, ``<!-- expect: TEXT -->`` (repeatable) requires TEXT (``…`` = anything) in its output and
  ``<!-- expect-files: A B -->`` the files it writes.
* Before a block, ``<!-- docs-test: serve-check -->`` marks a list of ``pfield serve`` variants: each is started,
  must answer, and is stopped. ``<!-- docs-test: ros2 -->`` marks commands of a ROS 2 install (the ``ros2``
  CLI): they run with ``ros2`` replaced by ``pfield`` (the CLI mirrors ros2 verbatim, DESIGN §3.2) against the
  HTTP node; the same requests over rclpy are tested in ``tests/transport/test_ros2_manager.py``.
  ``<!-- docs-test: ros2-node -->`` marks ``pfield ros2 node`` lines: each starts the real rclpy node in a
  private network namespace and must run until it is stopped with SIGTERM (exit 0). ``<!-- docs-test: ros2-robot
  -->`` marks a session with a robot (README's "Drive a robot"): the whole block runs in one private network
  namespace beside the tests' arm (``tests/servo/sim_arm.py``: the Panda in MuJoCo publishing ``/joint_states``,
  following the servo's commands and serving FollowJointTrajectory on ``/panda_arm_controller``), a line
  ``pfield ros2 node ARGS &`` starts the real node and waits until it is up, and ``ros2`` is
  ``tests/docs_ros2.py`` (the verbs the block uses, over rclpy); at the end every job is stopped and the node
  must exit 0. ``<!-- docs-test: skip:
  REASON -->`` leaves a block out, with the reason (installs, the test suite itself, a ROS 2 install's
  colcon/launch).
"""

from __future__ import annotations

import ast
import math
import os
import re
import shutil
import signal
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from serve_process import pfield_serve

REPO = Path(__file__).resolve().parents[1]
DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
VENV_BIN = Path(sys.executable).parent
LINKED = ("src", "tests", "examples", "ros", "benchmarks")
SHARED = REPO.parent / "shared"  # the reference data beside the clone (``../shared`` in the docs)
FOOTPRINT = "[[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25], [0.4, -0.25]]"

_FENCE = re.compile(r"^```(\w*)\n(.*?)^```\n", re.S | re.M)
_COMMENT = re.compile(r"<!--\s*(.*?)\s*-->", re.S)


@dataclass
class Block:
    document: str
    line: int
    language: str
    code: str
    marker: str = ""  # docs-test marker before the block
    expects: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        return f"{self.document}:{self.line}"


def _blocks(path: Path) -> list[Block]:
    text = path.read_text()
    blocks = []
    for match in _FENCE.finditer(text):
        language = match.group(1)
        if language not in ("bash", "python"):
            continue
        before = text[:match.start()].rstrip("\n").rsplit("\n", 1)[-1]
        marker = ""
        if (found := _COMMENT.fullmatch(before.strip())) and found.group(1).startswith("docs-test:"):
            marker = found.group(1).removeprefix("docs-test:").strip()
        block = Block(path.name, text[:match.start()].count("\n") + 1, language, match.group(2), marker)
        rest = text[match.end():]
        while (comment := re.match(r"[ \t]*<!--\s*(expect|expect-files):\s*(.*?)\s*-->\n?", rest, re.S)):
            (block.expects if comment.group(1) == "expect" else block.files).append(" ".join(comment.group(2).split()))
            rest = rest[comment.end():]
        if block.files:
            block.files = " ".join(block.files).split()
        blocks.append(block)
    return blocks


ALL_BLOCKS = [block for path in DOCS for block in _blocks(path)]


# ---- matching printed values against what the text says ----------------------------------------------------
_TOKEN = re.compile(r"(?P<number>[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?)(?P<more>\.\.\.|…)?|(?P<gap>\.\.\.|…)"
                    r"|(?P<word>[A-Za-z_][A-Za-z_0-9]*)")
_NOISE = {"array", "np", "dtype", "float64", "float32", "int64", "Pose", "position", "orientation", "Twist",
          "linear", "angular", "np_float64"}


def _tokens(text: str, expected: bool) -> list[tuple[str, Any]]:
    text = re.sub(r"<\w+\.(\w+): [^>]+>", r"\1", text)  # enum reprs: <PoseState.INSCRIBED: 1> -> INSCRIBED
    tokens: list[tuple[str, Any]] = []
    for match in _TOKEN.finditer(text):
        if match.group("number") is not None:
            tokens.append(("number", (match.group("number"), bool(match.group("more")))))
        elif match.group("gap"):
            tokens.append(("gap", None))
        elif not expected and match.group("word") in _NOISE:
            continue
        else:
            tokens.append(("word", match.group("word")))
    return tokens


def _number_matches(shown: str, truncated: bool, actual: str) -> bool:
    """``actual`` rounds to ``shown`` (to its digits), or truncates to it when the text wrote ``shown...``."""
    value, target = float(actual), float(shown)
    if "e" in shown.lower():
        return math.isclose(value, target, rel_tol=1e-9)
    scale = 10.0 ** (len(shown.split(".")[1]) if "." in shown else 0)
    if abs(value - target) <= 0.5 / scale + 1e-12:
        return True
    return truncated and abs(math.trunc(value * scale) / scale - target) < 1e-12


def _match(expected: list[tuple[str, Any]], actual: list[tuple[str, Any]]) -> bool:
    if not expected:
        return not actual
    kind, value = expected[0]
    if kind == "gap":
        return any(_match(expected[1:], actual[i:]) for i in range(len(actual) + 1))
    if not actual or actual[0][0] != kind:
        return False
    if kind == "number":
        if not _number_matches(value[0], value[1], actual[0][1][0]):
            return False
    elif value != actual[0][1]:
        return False
    return _match(expected[1:], actual[1:])


def value_matches(expected_text: str, value: Any) -> bool:
    """Does ``repr(value)`` say what ``expected_text`` says (numbers to the digits shown, ``…`` = anything)?"""
    return _match(_tokens(expected_text, True), _tokens(repr(value), False))


def test_value_matching_rules() -> None:
    assert value_matches("(True, 353, 0.1488...)", (True, 353, 0.14885))
    assert not value_matches("(True, 353, 0.1488...)", (True, 354, 0.14885))
    assert value_matches("(True, ('joint1', …, 'joint7'), (965, 7))", (True, ("joint1", "joint2", "joint7"), (965, 7)))
    assert value_matches("[[-0.9004, 0.]]", __import__("numpy").array([[-0.90040001, 0.0]]))
    assert not value_matches("[[-0.9004, 0.]]", __import__("numpy").array([[-0.9104, 0.0]]))


# ---- running -------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def workdirs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """One working folder per document, with the repository's folders linked in and ``../shared`` resolving
    to the reference data beside the clone, as it does from the repository."""
    folders = {}
    for path in DOCS:
        work = tmp_path_factory.mktemp(path.stem)
        for name in LINKED:
            (work / name).symlink_to(REPO / name)
        if SHARED.is_dir() and not (work.parent / "shared").exists():
            (work.parent / "shared").symlink_to(SHARED)
        folders[path.name] = work
    return folders


@pytest.fixture(scope="module")
def shared_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The node the blocks without their own ``pfield serve &`` talk to (with the example map for the costmap)."""
    work = tmp_path_factory.mktemp("shared_serve")
    with pfield_serve("--package-path", f"my_robot_description={REPO / 'tests/data/my_robot_description'}",
                      "--map", str(REPO / "src/pfield/data/maps/example.yaml"), "--footprint", FOOTPRINT,
                      log=work / "serve.log", cwd=work, stop=signal.SIGINT) as (url, _):
        yield url


_PRELUDE = r"""
__servers=()
__stop_servers() {
  local p
  for p in "${__servers[@]}"; do kill -TERM "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done
}
trap __stop_servers EXIT
__free_port() { python -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
__wait_server() {  # URL PID LOG
  python - "$1" "$2" "$3" <<'PY'
import os, sys, time, httpx
url, pid, log = sys.argv[1], int(sys.argv[2]), sys.argv[3]
deadline = time.monotonic() + 300
while time.monotonic() < deadline:
    try:
        if httpx.get(url + "/nodes", timeout=2).status_code == 200:
            sys.exit(0)
    except httpx.TransportError:
        pass
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        break
    time.sleep(0.3)
sys.stderr.write(open(log).read())
sys.exit(1)
PY
}
__pfield_serve() {  # `pfield serve ARGS &` of the docs: a real server on a free port, PFIELD_URL pointing at it
  local port; port=$(__free_port)
  pfield serve "$@" --port "$port" > "serve_$port.log" 2>&1 &
  local pid=$!
  __servers+=("$pid")
  export PFIELD_URL="http://127.0.0.1:$port"
  __wait_server "$PFIELD_URL" "$pid" "serve_$port.log"
  echo "pfield serve $* (test: --port $port) answers" >&2
}
__pfield_serve_check() {  # `pfield serve ARGS` of a list of variants: starts, answers, stops
  local port; port=$(__free_port)
  pfield serve "$@" --port "$port" > "serve_$port.log" 2>&1 &
  local pid=$!
  __wait_server "http://127.0.0.1:$port" "$pid" "serve_$port.log"
  kill -TERM "$pid"; wait "$pid" || [ $? -eq 143 ]  # stopped by the signal is fine
  echo "pfield serve $* (test: --port $port) started and stopped" >&2
}
__pfield_ros2_node() {  # `pfield ros2 node ARGS` in a private network namespace: runs until SIGTERM, exits 0
  PFIELD_ROS2_ARGS="$*" unshare -n -m bash -c '
    ip link set lo up; mount -t tmpfs tmpfs /dev/shm
    export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=58 FASTDDS_BUILTIN_TRANSPORTS=UDPv4
    rm -f ros2_node.log  # so that the log of the node before cannot announce this one
    pfield ros2 node $PFIELD_ROS2_ARGS > ros2_node.log 2>&1 &
    pid=$!
    for i in $(seq 1 600); do
      grep -qs "Ctrl-C stops" ros2_node.log && break
      kill -0 $pid 2>/dev/null || { cat ros2_node.log >&2; exit 1; }
      sleep 0.5
    done
    sleep 1; kill -TERM $pid; wait $pid; status=$?
    cat ros2_node.log >&2; exit $status'
  echo "pfield ros2 node $* ran and stopped cleanly" >&2
}
"""


_ROBOT_SESSION = r"""
__bg='s/^([[:space:]]*)pfield ros2 node\b(.*)&[[:space:]]*(#.*)?$/\1__pfield_ros2_node_bg\2/'
PFIELD_DOCS_BLOCK=$(printf '%s' "$PFIELD_DOCS_BLOCK" | sed -E "$__bg") \
unshare -n -m bash -euo pipefail -c '
  ip link set lo up; mount -t tmpfs tmpfs /dev/shm
  export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=59 FASTDDS_BUILTIN_TRANSPORTS=UDPv4
  __node=""
  __finish() {
    local status=$? p
    for p in $(jobs -p); do [ "$p" = "$__node" ] || kill -INT "$p" 2>/dev/null || true; done
    if [ -n "$__node" ]; then
      kill -TERM "$__node"; wait "$__node" || { echo "pfield ros2 node exited $?" >&2; status=1; }
    fi
    wait || true
    ! grep "dropped message" ros2_node.log >&2 || status=1  # every message of the block must be accepted
    [ $status -eq 0 ] || cat ros2_node.log sim_arm.log >&2 2>/dev/null || true
    exit $status
  }
  trap __finish EXIT
  python tests/servo/sim_arm.py panda --sphere "$PFIELD_DOCS_SPHERE" --out sim_arm.json > sim_arm.log 2>&1 &
  ros2() { python tests/docs_ros2.py "$@"; }
  __pfield_ros2_node_bg() {  # `pfield ros2 node ARGS &`: the real node in the background, until it is up
    rm -f ros2_node.log
    pfield ros2 node "$@" > ros2_node.log 2>&1 &
    __node=$!
    for i in $(seq 1 600); do
      grep -qs "Ctrl-C stops" ros2_node.log && return 0
      kill -0 $__node 2>/dev/null || { cat ros2_node.log >&2; return 1; }
      sleep 0.5
    done
    return 1
  }
  eval "$PFIELD_DOCS_BLOCK"
'
"""
ROBOT_SPHERE = "0.55,-0.25,0.3,0.08"
"""The obstacle of the "Drive a robot" block, placed in the arm's simulation too (x, y, z, radius m)."""


def _bash_script(block: Block) -> str:
    code = block.code
    if block.marker == "ros2-robot":
        return _PRELUDE + _ROBOT_SESSION
    if block.marker == "ros2":
        code = re.sub(r"^(\s*)ros2 ", r"\1pfield ", code, flags=re.M)
        code = re.sub(r"^(\s*pfield topic echo)(?!.*--once)", r"\1 --once", code, flags=re.M)
    code = re.sub(r"^(\s*)pfield serve\b(.*?)\s*&\s*(#.*)?$", r"\1__pfield_serve\2", code, flags=re.M)
    if block.marker == "serve-check":
        code = re.sub(r"^(\s*)pfield serve\b", r"\1__pfield_serve_check", code, flags=re.M)
    if block.marker == "ros2-node":
        code = re.sub(r"^(\s*)pfield ros2 node\b", r"\1__pfield_ros2_node", code, flags=re.M)
    return _PRELUDE + code


BLOCK_TIMEOUT = 480.0
"""Seconds a bash block may run (below pytest's 600 s time-out, so the block's own output is shown)."""


def _run_bash(block: Block, work: Path, url: str) -> str:
    env = os.environ | {"PFIELD_URL": url, "PATH": f"{VENV_BIN}{os.pathsep}{os.environ['PATH']}",
                        "MPLBACKEND": "Agg", "PYTHONPATH": str(REPO / "src")}
    if block.marker == "ros2-robot":
        env |= {"PFIELD_DOCS_BLOCK": block.code, "PFIELD_DOCS_SPHERE": ROBOT_SPHERE}
    # its own session, so that a block that overruns is stopped whole (the nodes and the arm in its namespace too)
    # and its output so far and its logs are shown, before pytest's own time-out would hide them
    process = subprocess.Popen(["bash", "-euo", "pipefail", "-c", _bash_script(block)], cwd=work, env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        stdout, stderr = process.communicate(timeout=BLOCK_TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        stdout, stderr = process.communicate()
        logs = "".join(f"\n--- {log.name} (last lines)\n" + "\n".join(log.read_text().splitlines()[-40:])
                       for log in (work / "ros2_node.log", work / "sim_arm.log") if log.exists())
        pytest.fail(f"{block.name} still running after {BLOCK_TIMEOUT} s:\n{(stdout + stderr)[-6000:]}{logs}")
    output = stdout + stderr
    assert process.returncode == 0, f"{block.name} failed (exit {process.returncode}):\n{output[-6000:]}"
    return output


def _run_python(block: Block, work: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    monkeypatch.chdir(work)
    lines = block.code.splitlines()
    namespace: dict[str, Any] = {"__name__": "__docs__"}
    checked = []
    for statement in ast.parse(block.code).body:
        source = "\n".join(lines[statement.lineno - 1:statement.end_lineno])
        last = lines[(statement.end_lineno or statement.lineno) - 1]
        expected = last.split("# ->", 1)[1].strip() if "# ->" in last else None
        if isinstance(statement, ast.Expr):
            value = eval(compile(ast.Expression(statement.value), block.name, "eval"), namespace)
            if expected is not None:
                assert value_matches(expected, value), f"{block.name}: {source.strip()!r} gave {value!r}, " \
                                                       f"the text says {expected}"
                checked.append(expected)
        else:
            assert expected is None, f"{block.name}: '# ->' after a statement that has no value: {source!r}"
            exec(compile(ast.Module([statement], []), block.name, "exec"), namespace)
    return "\n".join(checked)


@pytest.mark.parametrize("block", [b for b in ALL_BLOCKS], ids=[b.name for b in ALL_BLOCKS])
def test_doc_block(block: Block, workdirs: dict[str, Path], shared_server: str,
                   monkeypatch: pytest.MonkeyPatch) -> None:
    if block.marker.startswith("skip:"):
        pytest.skip(block.marker.removeprefix("skip:").strip())
    work = workdirs[block.document]
    if block.marker in ("ros2-node", "ros2-robot") and shutil.which("unshare") is None:
        pytest.fail("pfield ros2 node blocks need unshare (a private network namespace)")
    output = (_run_bash(block, work, shared_server) if block.language == "bash"
              else _run_python(block, work, monkeypatch))
    flat = " ".join(output.split())
    for text in block.expects:
        pattern = ".*?".join(re.escape(part.strip()) for part in re.split(r"…|\.\.\.", text))
        assert re.search(pattern, flat), f"{block.name}: the text says the output shows {text!r}; it was:\n" \
                                         f"{output[-4000:]}"
    for name in block.files:
        target = work / name
        assert target.exists() and (target.is_dir() or target.stat().st_size > 0), f"{block.name} wrote no {name}"


def test_every_block_is_run_or_says_why_not() -> None:
    """A docs-test marker is one of the known ones; a skip gives its reason."""
    for block in ALL_BLOCKS:
        assert block.marker in ("", "serve-check", "ros2", "ros2-node", "ros2-robot") or (
            block.marker.startswith("skip:") and len(block.marker) > len("skip: ") + 10), block.name
