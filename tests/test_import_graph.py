"""The import graph of ``src/pfield`` follows DESIGN §1: no cycles, and imports only point down the layers.

Every ``import`` and ``from … import`` is read with :mod:`ast` — at module level and inside functions alike
(a function-level import that goes up a layer is still an upward dependency) — except those under
``if TYPE_CHECKING:``, which never run. ``from pfield import geometry`` counts as an import of
``pfield.geometry``.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from importlib.machinery import EXTENSION_SUFFIXES
from pathlib import Path

import pfield

ROOT = Path(pfield.__file__).resolve().parent

LAYERS: tuple[tuple[str, ...], ...] = (
    ("cli",),
    ("demo",),  # the built-in demonstration: drives a real node through its transport
    ("warmup",),  # the self-check: uses every computational package below
    ("transport",),
    ("node",),
    ("batch",),  # many plans on every core or a Ray cluster: problems from scene, the planners' public API
    ("scene",),  # problems in: MoveIt PlanningScene/MotionPlanRequest and pfield scene YAML (uses interfaces)
    ("viz", "sim"),  # plots and viewer; sim: the physics check in MuJoCo (both use every computational package below)
    ("interfaces",),
    ("pfield",),  # the package's public face (pfield/__init__.py) re-exports the packages below
    ("shared_control",),  # autonomy vector, assistance and its compiled kernel, on the planners and the robot
    ("planning",),
    ("robot",),
    ("field",),
    ("geometry",),
    ("mobile", "costmap"),  # 2D packages: spatial and the bottom layer only
    ("spatial",),
    ("safety",),  # the output contract: every command finite and within its limits (numpy and the bottom layer)
    ("_layout", "_validation", "_files", "_lazy", "_console"),
    ("_core",),  # the compiled core (C++, nanobind): imports nothing of pfield
    ("_enums",),  # enums that print their names (outcomes: PlanStatus, PoseState)
    ("errors",),
)
"""DESIGN §1, top to bottom; a module may import its own layer's package and anything in a lower layer."""
RANK = {name: len(LAYERS) - level for level, names in enumerate(LAYERS) for name in names}

ALLOWED_UPWARD = {
    # PotentialField.plan / plan_whole_body delegate lazily to the planners (DESIGN §7: the one exception)
    ("pfield.field.field", "pfield.planning.task_space"),
    ("pfield.field.field", "pfield.planning.whole_body"),
}
KNOWN_VIOLATIONS: set[tuple[str, str]] = set()


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str) -> bool:
    """A module of ``src/pfield``: a .py file, a package, or a compiled extension (``pfield._core``)."""
    relative = Path(*name.split(".")[1:]) if "." in name else Path()
    if (ROOT / relative).with_suffix(".py").is_file() or (ROOT / relative / "__init__.py").is_file():
        return True
    return any((ROOT / relative.parent / (relative.name + suffix)).is_file() for suffix in EXTENSION_SUFFIXES)


def _is_type_checking(test: ast.expr) -> bool:
    """``if TYPE_CHECKING:`` or ``if typing.TYPE_CHECKING:`` (not ``if not TYPE_CHECKING:``, whose body runs)."""
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or \
        (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    skipped: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            skipped |= {id(inner) for statement in node.body for inner in ast.walk(statement)}
    return skipped


def _import_statements(path: Path, typing_too: bool = False) -> Iterator[ast.Import | ast.ImportFrom]:
    """The import statements of a file that run (those under ``if TYPE_CHECKING:`` never do; ``typing_too``: those
    as well)."""
    tree = ast.parse(path.read_text(), str(path))
    skipped = set() if typing_too else _type_checking_nodes(tree)
    yield from (node for node in ast.walk(tree) if isinstance(node, ast.Import | ast.ImportFrom)
                and id(node) not in skipped)


def _imported(module: str, path: Path, node: ast.Import | ast.ImportFrom) -> Iterator[tuple[str, str | None]]:
    """(module, name) of each pfield name an import statement binds (name None where a module is imported)."""
    if isinstance(node, ast.Import):
        yield from ((alias.name, None) for alias in node.names if alias.name.split(".")[0] == "pfield")
        return
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    if node.level:
        base = package.split(".")[: len(package.split(".")) - node.level + 1]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module or ""
    if target.split(".")[0] != "pfield":
        return
    for alias in node.names:
        submodule = f"{target}.{alias.name}"
        yield (submodule, None) if _is_module(submodule) else (target, alias.name)


def _imports(path: Path) -> Iterator[tuple[str, int]]:
    module = _module_name(path)
    for node in _import_statements(path):
        yield from ((target, node.lineno) for target, _ in _imported(module, path, node))


def _edges() -> list[tuple[str, str, int]]:
    return [(_module_name(path), target, line) for path in sorted(ROOT.rglob("*.py")) for target, line in
            _imports(path)]


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "pfield"


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan 1972)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in graph.get(node, ()):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                item = stack.pop()
                on_stack.discard(item)
                component.append(item)
                if item == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def _runtime_edges() -> list[tuple[str, str, int]]:
    return [(a, b, line) for a, b, line in _edges() if (a, b) not in ALLOWED_UPWARD | KNOWN_VIOLATIONS]


def test_every_package_has_a_layer() -> None:
    packages = {_layer(module) for module, _, _ in _edges()} | {_layer(target) for _, target, _ in _edges()}
    assert packages <= set(RANK), f"packages without a layer in DESIGN §1: {sorted(packages - set(RANK))}"


def test_imports_only_point_down_the_layers() -> None:
    upward = [f"{a}:{line} imports {b} ({_layer(a)} → {_layer(b)})" for a, b, line in _runtime_edges()
              if _layer(a) != _layer(b) and RANK[_layer(a)] <= RANK[_layer(b)]]
    assert not upward, "imports that go up DESIGN §1's layers:\n" + "\n".join(upward)


def test_there_are_no_import_cycles() -> None:
    modules: dict[str, set[str]] = {}
    packages: dict[str, set[str]] = {}
    for a, b, _ in _runtime_edges():
        if a != b:
            modules.setdefault(a, set()).add(b)
        if _layer(a) != _layer(b):
            packages.setdefault(_layer(a), set()).add(_layer(b))
    assert not _cycles(packages), f"package cycles: {_cycles(packages)}"
    assert not _cycles(modules), f"module cycles: {_cycles(modules)}"


def test_the_exceptions_are_still_needed() -> None:
    """An exception that no longer matches an import is stale and must go."""
    present = {(a, b) for a, b, _ in _edges()}
    assert (ALLOWED_UPWARD | KNOWN_VIOLATIONS) <= present, sorted((ALLOWED_UPWARD | KNOWN_VIOLATIONS) - present)


def test_the_walker_sees_function_level_and_aliased_imports() -> None:
    edges = {(a, b) for a, b, _ in _edges()}
    assert ("pfield.field.field", "pfield.planning.task_space") in edges  # inside PotentialField.plan
    assert ("pfield.spatial", "pfield._core") in edges  # ``from pfield._core import spatial``
    assert ("pfield.field.field", "pfield.planning.result") not in edges  # only under TYPE_CHECKING


SHARED_PRIVATE = {"pfield._console", "pfield._core", "pfield._enums", "pfield._files", "pfield._layout",
                  "pfield._lazy", "pfield._validation"}
"""pfield's own private modules, below every package (DESIGN §1's bottom layers): every package may use them."""


def _private_imports() -> Iterator[str]:
    """Imports of another package's private module (``pfield.node._base``) or private name (``_fast_twist``)."""
    for path in sorted(ROOT.rglob("*.py")):
        module = _module_name(path)
        for node in _import_statements(path, typing_too=True):  # a type's private home is private too
            for target, name in _imported(module, path, node):
                shared = any(target == bottom or target.startswith(bottom + ".") for bottom in SHARED_PRIVATE)
                if _layer(target) == _layer(module) or shared:
                    continue
                private_module = any(part.startswith("_") for part in target.split(".")[1:])
                private_name = name is not None and name.startswith("_") and not \
                    (name.startswith("__") and name.endswith("__"))
                if private_module or private_name:
                    yield f"{module}:{node.lineno} imports {target}" + (f".{name}" if name else "")


def test_packages_use_each_others_public_names() -> None:
    """A package reaches another through its public names: its package face or a public module (issue 32)."""
    found = list(_private_imports())
    assert not found, "imports of another package's private module or name:\n" + "\n".join(found)
