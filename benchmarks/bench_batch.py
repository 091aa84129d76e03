"""Many plans: MotionBenchMaker plans per second with 1 and 2 workers, and the Ray backend's overhead.

* **MBM plans/s**: the first problems of each of the four scenes of ``../shared/benchmarks/mbm/`` (3 per scene
  with ``--quick``, 25 otherwise), planned by :func:`pfield.batch.plan_many` with the process backend and
  1 or 2 workers. Two figures per worker count: the whole call (worker start-up included: spawning, importing
  pfield, building the Panda, reading its fitted link model from pfield's cache), and the steady rate: the
  problems over the whole call less the pool's start-up, which is what a long batch sees. The start-up is
  timed on one copy of the set's first problem per worker (so the workers build the same robot and load the
  same link model as for the set), less that problem's own planning time. Target: the steady rate with
  2 workers ≥ 1.8 × the rate with 1 (on an otherwise idle 2-core machine; CPU time is in the note, since
  other processes sharing the machine slow the wall clock).
* **Ray overhead per problem**: 100 tiny task-space problems (a few steps each) on a local Ray cluster of
  2 actors, started inside a private network namespace (``unshare -n``, loopback only) as the tests do;
  the time per record on Ray once both actors have delivered, less the in-process time per problem; the
  actors' start-up (new processes importing pfield and building the robot) is reported apart.

Scriptable: ``python -m benchmarks.bench_batch [--quick]`` prints the rows; ``--ray-overhead N`` (used by
``run`` inside the namespace) prints the Ray figures as JSON.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import secrets
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from benchmarks._common import BenchRow
from pfield.batch import plan_many
from pfield.scene import Problem, read_problems
from pfield.spatial import Pose

SECTION = "many plans (pfield batch)"
ARCHIVE = Path(__file__).resolve().parents[2] / "shared" / "benchmarks" / "mbm" / "panda_problems_dev.tar.bz2"
ROOT = Path(__file__).resolve().parents[1]


def _rates(problems: list[Problem], workers: int) -> tuple[float, float, float]:
    """(whole-call plans/s, steady plans/s, summed plan CPU seconds).

    The steady rate leaves out the pool's start-up: N / (whole call − start-up), where the start-up is the
    whole call for ``workers`` copies of the first problem with the same worker count (spawning, imports, the
    problems' robot) less that problem's planning time. Records arrive in input order, so the rate
    between arrivals would depend on where the long problems sit.
    """
    copies = [dataclasses.replace(problems[0], scene="start-up", index=i) for i in range(workers)]
    begin = time.perf_counter()
    planned = list(plan_many(copies, workers=workers))
    startup = time.perf_counter() - begin - max(record["seconds"] for record in planned)
    begin = time.perf_counter()
    cpu = sum(record["cpu_seconds"] for record in plan_many(problems, workers=workers))
    elapsed = time.perf_counter() - begin
    return len(problems) / elapsed, len(problems) / max(elapsed - startup, 1e-9), cpu


def _mbm_rows(quick: bool) -> list[BenchRow]:
    if not ARCHIVE.exists():
        return [BenchRow(SECTION, "MBM plans/s: skipped", 0.0, "", note=f"{ARCHIVE} not found")]
    problems = read_problems([ARCHIVE], limit=3 if quick else 25)
    rows, steady_one = [], None
    for workers in (1, 2):
        whole, steady, cpu = _rates(problems, workers)
        steady_one = steady if workers == 1 else steady_one
        speedup = f"; steady speed-up {steady / steady_one:.2f}× over 1 worker" if workers == 2 and steady_one else ""
        rows.append(BenchRow(SECTION, f"MBM plans/s, {workers} worker{'s' * (workers > 1)} (steady)", steady,
                             "plans/s", higher_is_better=True,
                             target=1.8 * steady_one if workers == 2 and steady_one else None,
                             note=f"{len(problems)} problems (4 scenes); whole call incl. start-up {whole:.2f} "
                                  f"plans/s; plan CPU {cpu:.1f} s ({len(problems) / cpu:.2f} plans per CPU-second)"
                                  f"{speedup}; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"))
    return rows


def _tiny_problems(count: int) -> list[Problem]:
    return [Problem("tiny", i, start=Pose((0.3, 0.0, 0.5)), goal=Pose((0.3 + 0.001 * (1 + i % 5), 0.0, 0.5)))
            for i in range(count)]


def ray_overhead(count: int) -> dict[str, float]:
    """Seconds: in-process total, Ray total (local cluster, 2 actors), and Ray's start-up (first record)."""
    import ray

    problems = _tiny_problems(count)
    list(plan_many(problems[:5]))  # imports done, the robot's link model read
    begin = time.perf_counter()
    list(plan_many(problems))
    local = time.perf_counter() - begin
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, _node_ip_address="127.0.0.1")
    try:
        list(plan_many(problems[:4], workers=2, backend="ray"))  # workers' imports and robots built
        begin = time.perf_counter()
        arrivals = [time.perf_counter() for _ in plan_many(problems, workers=2, backend="ray")]
        total = time.perf_counter() - begin
    finally:
        ray.shutdown()
    steady = (arrivals[-1] - arrivals[1]) / (count - 2)  # per record, once both actors delivered
    return {"local": local, "ray": total, "startup": arrivals[1] - begin, "steady": steady, "count": float(count)}


def _ray_rows(quick: bool) -> list[BenchRow]:
    if shutil.which("unshare") is None:
        return [BenchRow(SECTION, "Ray overhead: skipped", 0.0, "", note="unshare not found")]
    count = 40 if quick else 100
    command = ["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$@"', "sh", sys.executable, "-m",
               "benchmarks.bench_batch", "--ray-overhead", str(count)]
    with tempfile.TemporaryDirectory(prefix="pfield-ray-") as home:  # nothing read from or left in ~/.ray
        env = dict(os.environ, HOME=home, RAY_USAGE_STATS_ENABLED="0", RAY_AUTH_MODE="token",
                   RAY_AUTH_TOKEN=secrets.token_hex(32))
        done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=600, check=False, env=env)
    if done.returncode != 0:
        return [BenchRow(SECTION, "Ray overhead: failed", 0.0, "", note=done.stderr.strip()[-300:])]
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    overhead = (figures["steady"] - figures["local"] / count) * 1e3
    return [BenchRow(SECTION, "Ray backend overhead per problem (local cluster, 2 actors)", overhead, "ms",
                     note=f"{count} tiny task-space problems: Ray {figures['ray']:.2f} s vs in-process "
                          f"{figures['local']:.3f} s; actors' start-up to their first records "
                          f"{figures['startup']:.2f} s")]


def run(quick: bool) -> list[BenchRow]:
    return _mbm_rows(quick) + _ray_rows(quick)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_batch", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer problems")
    parser.add_argument("--ray-overhead", type=int, default=None, metavar="N", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.ray_overhead is not None:
        print(json.dumps(ray_overhead(args.ray_overhead)))
        return
    for row in run(args.quick):
        print(f"{row.name}: {row.value:.3g} {row.unit} — {row.note}")


if __name__ == "__main__":
    main()
