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
        from pfield.errors import InvalidInput

        try:
            code = run_demo(output_dir, only)
        except InvalidInput as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2) from None
        raise typer.Exit(code)
