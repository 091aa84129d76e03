"""``pfield batch``: plan many problems on every core or on a Ray cluster; results as JSON lines."""

from __future__ import annotations

import signal
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Annotated

import typer

from pfield.cli._exit_codes import FAILED
from pfield.cli._robot_options import (
    EndEffectorOption,
    LockedJointOption,
    PackagePathOption,
    SrdfOption,
    build_robot,
    robot_description,
)


def batch(
    problems: Annotated[list[Path], typer.Argument(help="Scene YAML files, folders of MoveIt sceneNNNN.yaml/"
                                                        "requestNNNN.yaml pairs, or archives of such folders.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Results file (JSON lines, one record per problem).")],
    workers: Annotated[int, typer.Option("--workers", "-j", help="Worker processes (or Ray actors).")] = 1,
    backend: Annotated[str, typer.Option("--backend", help="process or ray.")] = "process",
    address: Annotated[str | None, typer.Option("--address", help="Ray cluster address (default: a local one).")
                       ] = None,
    robot: Annotated[str, typer.Option("--robot", help="Robot of MoveIt problems: a built-in robot (panda, xarm7) "
                                                       "or a URDF file.")] = "panda",
    srdf: SrdfOption = None,
    end_effector: EndEffectorOption = None,
    package_path: PackagePathOption = None,
    locked_joint: LockedJointOption = None,
    scenes: Annotated[list[str] | None, typer.Option("--scene", help="Only this scene folder (repeatable).")] = None,
    limit: Annotated[int | None, typer.Option("--limit", help="At most N problems per scene.")] = None,
    timeout: Annotated[float | None, typer.Option("--timeout", help="Seconds per problem before it is cancelled.")
                       ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed mixed with each problem's scene and index.")] = 0,
    resume: Annotated[bool, typer.Option("--resume", help="Skip problems already in --out; append the rest.")
                      ] = False,
) -> None:
    """Plan every problem and write one JSON line per problem to --out (in the problems' order).

    MoveIt problems are planned for --robot: joints are matched by name (the request's other joints are
    ignored), and the robot's joints a joint goal does not name are locked at the request's start values.

    Fields: scene, index, success, status, seconds, cpu_seconds, steps, planner, joint_names, positions,
    times, clearances, error. Exit code 0 when every problem was planned (whether or not it reached its goal),
    1 when a problem could not be planned (status error) or no Ray cluster answers at --address, 2 for bad
    arguments (--workers, --backend, --timeout, --address and an unwritable --out are checked before anything is
    read; a --robot URDF is read, its meshes found, before anything is planned) or a problem file or archive that
    cannot be read or is out of bounds.
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from pfield._console import console as make_console
    from pfield._files import check_writable
    from pfield.batch import check_reachable, check_settings, finished_keys, plan_many, write_records
    from pfield.cli._node import cli_errors
    from pfield.scene import read_problems

    console = make_console(stderr=True)
    with cli_errors():
        check_settings(workers, backend, seed, timeout, address)  # before anything is read
        if address is not None:  # and before --out is opened: a refused run changes nothing
            check_reachable(address)
        check_writable("--out", out)
        description = robot_description(robot, srdf, end_effector, package_path, locked_joint)
        if not description.is_builtin:  # its files (meshes through --package-path) are read now, not per problem
            build_robot(description)
        todo = read_problems(problems, robot=description, scenes=scenes, limit=limit)
        done = finished_keys(out) if resume else set()
        todo = [p for p in todo if p.key not in done]
        counts = {"reached": 0, "error": 0}
        with Progress(TextColumn("planning {task.description}"), BarColumn(), MofNCompleteColumn(),
                      TextColumn("{task.fields[counts]}"), TimeElapsedColumn(), console=console) as progress:
            task = progress.add_task("", total=len(todo), counts="")

            def report(record: dict[str, object]) -> None:
                status = str(record["status"])
                counts[status] = counts.get(status, 0) + 1
                progress.update(task, advance=1, description=f"{record['scene']}/{record['index']}",
                                counts=", ".join(f"{k} {v}" for k, v in counts.items() if v))

            records = plan_many(todo, workers=workers, backend=backend, seed=seed, timeout=timeout, address=address,
                                progress=report)
            kept = _Counted(records)
            try:
                written = write_records(kept, out, append=resume)
            except KeyboardInterrupt:  # every finished record is on disk, line by line
                signal.signal(signal.SIGINT, signal.SIG_IGN)  # the stop is under way: a second Ctrl-C adds nothing
                progress.stop()
                console.print(f"interrupted: {kept.count} problems planned and kept in {out}; the same command "
                              f"with --resume plans the rest", highlight=False)
                raise typer.Exit(FAILED) from None  # unfinished: --resume finishes it
    summary = ", ".join(f"{k} {v}" for k, v in sorted(counts.items()) if v) or "nothing to do"
    console.print(f"{written} problems planned ({len(done)} already in {out}): {summary}; results in {out}",
                  highlight=False)
    if counts["error"]:
        raise typer.Exit(1)


class _Counted:
    """The records, counted as they are taken (what an interrupted batch kept)."""

    def __init__(self, records: Iterable[dict[str, object]]) -> None:
        self._records, self.count = iter(records), 0

    def __iter__(self) -> Iterator[dict[str, object]]:
        for record in self._records:
            self.count += 1
            yield record


def register(app: typer.Typer) -> None:
    """Add ``batch`` to ``app``."""
    app.command("batch")(batch)
