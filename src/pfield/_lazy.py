"""Names a package exports but imports on first use (PEP 562), so that importing the package stays light.

``__getattr__, __dir__ = lazy_exports(__name__, {"plan_whole_body": "pfield.planning.whole_body"}, globals())`` in
a package's ``__init__``: the name loads from its home module when first read, then stays a plain attribute, and
``dir(package)`` (what tab completion lists) shows it before that. The package also imports the names under
``TYPE_CHECKING`` for the type checkers.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, homes: Mapping[str, str], namespace: dict[str, Any]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package`` (its ``__name__``) whose names ``homes`` maps to
    the modules they live in; ``namespace``: the package's ``globals()``."""

    def __getattr__(name: str) -> Any:
        home = homes.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(home), name)
        namespace[name] = value  # once loaded, a plain attribute
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *homes})

    return __getattr__, __dir__
