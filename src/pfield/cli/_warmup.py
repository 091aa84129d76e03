"""``pfield warmup``: a fast self-check of this installation (the compiled core, the built-in robots' link models,
one task-space and one whole-body plan), with what each step checked."""

from __future__ import annotations

import typer


def warmup() -> None:
    """Check that pfield works here: the compiled core imports, signed distances of every shape are right, the
    built-in robots' link models load (their fits ship with pfield; a cache in $PFIELD_CACHE_DIR or
    ~/.cache/pfield comes first), and a task-space and a whole-body plan reach their goals.

    Prints what each step checked; exit status 1 when a step fails. `make demo` runs it first.
    """
    from rich.table import Table

    from pfield import warmup as self_check
    from pfield._console import console as make_console

    console = make_console(stderr=True)
    with console.status("checking") as status:
        def report(done: int, total: int, name: str) -> None:
            if done < total:
                status.update(f"checking {name} ({done + 1}/{total})")

        result = self_check.check(report)
    table = Table(show_header=True, header_style="bold", box=None)
    for column in ("", "step", "checked", "s"):
        table.add_column(column, justify="right" if column == "s" else "left")
    for step in self_check.STEPS:
        failure = result.failures.get(step.name)
        table.add_row("[red]✗[/red]" if failure else "[green]✓[/green]", step.name,
                      f"[red]{failure}[/red]" if failure else result.checked[step.name],
                      f"{result.seconds[step.name]:.2f}")
    console.print(table)
    passed = len(self_check.STEPS) - len(result.failures)
    console.print(f"self-check {'passed' if result.ok else 'FAILED'}: {passed}/{len(self_check.STEPS)} steps in "
                  f"{result.total_seconds:.1f} s", style=None if result.ok else "bold red", highlight=False)
    if not result.ok:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Add ``warmup`` to ``app``."""
    app.command("warmup")(warmup)
