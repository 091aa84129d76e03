"""The ``pfield`` command line (typer), mirroring ``ros2`` verbs where the seed uses them.

Each area registers its commands from its own module; library code never imports this package.
"""

from __future__ import annotations

import typer

from pfield.cli import _costmap, _demo, _manipulator, _mobile, _node, _ros2, _viewer

app = typer.Typer(
    name="pfield",
    help="Potential-field motion planning and shared control (standalone node, tools and demos).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

for _module in (_demo, _node, _manipulator, _mobile, _costmap, _ros2, _viewer):
    _module.register(app)

__all__ = ["app"]
