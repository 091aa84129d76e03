"""Demo section: costmap."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

TITLE = "costmap"


def run(out_dir: Path, console: Console) -> None:
    console.print("[yellow]not built yet[/yellow]")
