"""``pfield plot2d`` and ``pfield sim2d``: the mobile base's plots and simulation."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from pfield.cli._exit_codes import FAILED
from pfield.cli._node import ServeContext, cli_errors, register_node_factory

if TYPE_CHECKING:
    from rich.console import Console

    from pfield.node import Node


def _list_scenarios(console: Console) -> None:
    from rich.table import Table

    from pfield.mobile.scenarios import BUILTIN_SCENARIOS

    table = Table("scenario", "sensor", "expected", "description")
    for name, scenario in BUILTIN_SCENARIOS.items():
        table.add_row(name, scenario.sensor, scenario.expected, scenario.description)
    console.print(table)


def _serve_base_controller(context: ServeContext) -> list[Node]:
    """``pfield serve`` also serves ``/base_controller`` (goal, scan, teleop in; ``/cmd_vel`` out)."""
    from pfield.node.base_controller import BaseControllerNode

    return [BaseControllerNode(context.bus)]


def register(app: typer.Typer) -> None:
    """Add ``plot2d`` and ``sim2d`` to ``app`` and the base controller node to ``pfield serve``."""
    register_node_factory(_serve_base_controller)

    @app.command("plot2d")
    def plot2d(
        output_dir: Path = typer.Option(Path("plots2d"), "--output-dir", "-o", help="Where the PNGs go."),
    ) -> None:
        """Plot the 2D vector field of the example parameter sets: radial profiles (unclamped/clamped) and field plots
        (PNG)."""
        from pfield._console import console as make_console
        from pfield._files import writable_folder
        from pfield.viz.plots2d import save_seed_plots

        console = make_console()
        with cli_errors():
            writable_folder("--output-dir", output_dir)
        with console.status("plotting the 2D field"):
            paths = save_seed_plots(output_dir)
        for path in paths:
            console.print(f"wrote {path}")

    @app.command("sim2d")
    def sim2d(
        scenario: str = typer.Argument("grid_pass", help="Built-in scenario name or a scenario YAML file."),
        output_dir: Path = typer.Option(Path("sim2d"), "--output-dir", "-o", help="Where PNG and GIF go."),
        drive: str | None = typer.Option(None, "--drive", help="holonomic or diff_drive (default: scenario's)."),
        gif: bool = typer.Option(True, "--gif/--no-gif", help="Also write an animated GIF."),
        list_scenarios: bool = typer.Option(False, "--list", help="List the built-in scenarios and exit."),
    ) -> None:
        """Simulate the 2D controller in a scenario; writes a PNG and an animated GIF.

        Exit code 0 when the run ends as the scenario expects (goal_reached; stuck for grid_blocked), 1 when it
        ends otherwise (a collision, a timeout, stuck short of a goal it should reach), 2 for bad arguments."""
        from pfield._console import console as make_console
        from pfield._files import writable_folder
        from pfield.demo.tools import run_sim2d

        console = make_console()
        if list_scenarios:
            _list_scenarios(console)
            return
        with cli_errors():
            writable_folder("--output-dir", output_dir)
            result = run_sim2d(scenario, output_dir, drive, gif, console)
        if result.outcome != result.scenario.expected:
            raise typer.Exit(FAILED)
