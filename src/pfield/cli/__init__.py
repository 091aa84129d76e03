"""The ``pfield`` command line (typer), mirroring ``ros2`` verbs where the seed uses them.

Each area registers its commands from its own module; library code never imports this package.
"""

from __future__ import annotations

from typing import Annotated

import typer

from pfield.cli import (
    _batch,
    _costmap,
    _demo,
    _execute,
    _introspection,
    _manipulator,
    _mobile,
    _node,
    _ros2,
    _viewer,
    _warmup,
)

app = typer.Typer(
    name="pfield",
    help="Potential-field motion planning and shared control (standalone node, tools and demos).",
    no_args_is_help=True,
    add_completion=True,  # --install-completion / --show-completion (bash, zsh, fish, PowerShell)
    pretty_exceptions_enable=False,
)


def _print_version(value: bool) -> None:
    if value:
        from pfield import __version__

        typer.echo(f"pfield {__version__}")
        raise typer.Exit()


@app.callback()
def _main(version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                                help="print the version and exit")] = False) -> None:
    """Potential-field motion planning and shared control (standalone node, tools and demos)."""


for _module in (_demo, _warmup, _node, _manipulator, _batch, _mobile, _costmap, _ros2, _introspection, _viewer,
                _execute):
    _module.register(app)

__all__ = ["app"]
