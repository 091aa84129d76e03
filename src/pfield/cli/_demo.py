"""``pfield demo``: the built-in end-to-end demonstration (what ``make demo`` runs)."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def demo(
        output_dir: Path = typer.Option(Path("demo_output"), "--output-dir", "-o", help="Where PNGs go."),
        only: list[str] = typer.Option([], "--only", help="Run only these sections (repeatable)."),
    ) -> None:
        """Run the built-in demo: plans, plots and a scripted node session, on built-in defaults."""
        from pfield.demo import run_demo

        raise typer.Exit(run_demo(output_dir, only))
