"""Demo section: node_session."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

TITLE = "node_session"


def run(out_dir: Path, console: Console) -> None:
    console.print("[yellow]not built yet[/yellow]")
