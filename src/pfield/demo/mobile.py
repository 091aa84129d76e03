"""Demo section: the mobile base's 2D vector field — the seed's plots and one simulated scenario."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

TITLE = "mobile base: 2D vector field, plots and simulation"


def run(out_dir: Path, console: Console) -> None:
    """Write the seed's profile and field plots and simulate the doorway scenario (diff drive)."""
    from pfield.demo.tools import run_sim2d
    from pfield.viz.plots2d import save_seed_plots

    target = out_dir / "mobile"
    with console.status("plotting the 2D field (the example parameter sets)"):
        paths = save_seed_plots(target)
    console.print(f"{len(paths)} field plots: " + ", ".join(p.name for p in paths))
    result = run_sim2d("doorway", target, "diff_drive", True, console)
    if result.outcome != result.scenario.expected:  # pfield sim2d's rule (exit 1)
        raise RuntimeError(f"doorway simulation ended with {result.outcome!r}, expected {result.scenario.expected}")
