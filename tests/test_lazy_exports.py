"""The packages' lazy exports (pfield._lazy, PEP 562): each name a package lists loads from its home module when it
is first read, not at the package's import, and ``dir()`` (what tab completion lists) shows it before that."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

LAZY = {
    "pfield": {"RobotModel": "pfield.robot.model", "PotentialField": "pfield.field.field"},
    "pfield.planning": {"plan_whole_body": "pfield.planning.whole_body", "WholeBodyStepper": "pfield.planning.stepper",
                        "plan_task_space": "pfield.planning.task_space"},
    "pfield.node": {"make_resolver": "pfield.node._planning", "parse_transform_option": "pfield.node._frames"},
    "pfield.robot": {"fit_cache_directory": "pfield.robot._fit"},
    "pfield.transport": {"ServerLimits": "pfield.transport._server"},
}
"""Package → its lazy names → the module each is defined in."""

PROBE = """
import importlib, json, sys
package, name, home = sys.argv[1:4]
module = importlib.import_module(package)
before = home in sys.modules
listed = sorted(set(module.__all__) - set(dir(module)))
value = getattr(module, name)
try:
    getattr(module, "no_such_name")
    refused = ""
except AttributeError as error:
    refused = str(error)
print(json.dumps({"before": before, "unlisted": listed, "after": home in sys.modules,
                  "defined_in": getattr(value, "__module__", ""), "plain": name in vars(module), "refused": refused}))
"""


@pytest.mark.parametrize(("package", "name", "home"),
                         [(p, n, h) for p, names in LAZY.items() for n, h in names.items()])
def test_a_lazy_name_loads_on_first_read(package: str, name: str, home: str) -> None:
    done = subprocess.run([sys.executable, "-c", PROBE, package, name, home], capture_output=True, text=True,
                          check=True)
    seen = json.loads(done.stdout)
    assert not seen["before"], f"import {package} imported {home}"
    assert seen["unlisted"] == [], f"dir({package}) misses {seen['unlisted']}"
    assert seen["after"] and seen["defined_in"] == home
    assert seen["plain"]  # once read, a plain attribute of the package
    assert seen["refused"] == f"module {package!r} has no attribute 'no_such_name'"
