"""``pfield plan``: a task-space plan in the built-in seed scene or a scene YAML, written as a PNG (and CSV).

The scene file format is :mod:`pfield.scene.files`'s (documented in docs/field.md, "Scene files").
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import typer
from rich.console import Console

from pfield._files import check_writable
from pfield.cli._node import cli_errors
from pfield.scene.files import load_scene

__all__ = ["register"]


def _plan(scene_file: Path | None, output: Path, csv: Path | None, console: Console) -> int:
    from pfield.field import PotentialField
    from pfield.viz.plots import save_path_plot

    with tempfile.TemporaryDirectory() as meshes:
        scene = load_scene(scene_file, Path(meshes))
        field = PotentialField(scene["config"], scene["goal"], scene["obstacles"])
        path = field.plan(scene["start"], dt=scene["dt"], goal_tolerance=scene["goal_tolerance"],
                          max_iterations=scene["max_iterations"])
        save_path_plot(path, output, scene["obstacles"], scene["goal"])
    if csv is not None:
        path.to_csv(csv)
    state = "[green]reached the goal[/green]" if path.success else f"[red]failed[/red]: {path.failure_reason}"
    console.print(f"{state}: {len(path)} waypoints over {path.duration:.2f} s, min clearance "
                  f"{path.min_clearance:.4g} m; plot written to {output}" + (f", waypoints to {csv}" if csv else ""))
    return 0 if path.success else 1


def register(app: typer.Typer) -> None:
    """Add ``pfield plan`` to ``app``."""

    @app.command("plan")
    def plan(
        scene: Path | None = typer.Option(None, "--scene", "-s", help="Scene YAML (default: the seed's scene)."),
        output: Path = typer.Option(Path("plan.png"), "--output", "-o", help="PNG of the path and obstacles."),
        csv: Path | None = typer.Option(None, "--csv", help="Also write the waypoints as CSV."),
    ) -> None:
        """Plan a task-space path with the potential field and plot it (exit 1 when the goal is not reached,
        2 for a bad scene file or output path, checked before planning)."""
        with cli_errors():
            check_writable("--output", output)
            if csv is not None:
                check_writable("--csv", csv)
            code = _plan(scene, output, csv, Console())
        raise typer.Exit(code)
