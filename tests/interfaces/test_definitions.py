"""The pydantic models equal the .msg/.srv files field for field (names, types, defaults, constants)."""

from __future__ import annotations

from pathlib import Path

import pytest

import pfield.interfaces.all  # noqa: F401 - registers every type
from pfield.interfaces import registered_services, registered_types
from pfield.interfaces._idl import Definition, interface_file, model_definition, parse_definition, parse_service

REPO = Path(__file__).resolve().parents[2]
OWN = REPO / "ros" / "potential_fields_interfaces"
MESSAGES = sorted(n for n in registered_types() if "/msg/" in n)
SERVICES = sorted(registered_services())


def _comparable(definition: Definition) -> tuple[object, ...]:
    fields = [(f.type, f.name, f.default) for f in definition.fields]
    constants = sorted((c.type, c.name, c.value) for c in definition.constants)
    return fields, constants


def _file(type_name: str) -> Path:
    package, kind, name = type_name.split("/")
    if package == "potential_fields_interfaces":
        return OWN / kind / f"{name}.{kind}"
    path = interface_file(type_name)
    assert path is not None, f"no installed definition file for {type_name}"
    return path


def test_every_own_interface_file_has_a_model() -> None:
    files = {f"potential_fields_interfaces/{p.parent.name}/{p.stem}" for p in OWN.glob("*/*.*") if p.suffix in
             (".msg", ".srv")}
    modelled = {n for n in MESSAGES + SERVICES if n.startswith("potential_fields_interfaces/")}
    assert files == modelled
    assert {"potential_fields_interfaces/srv/PlanPath", "potential_fields_interfaces/srv/RemoveObstacles"} <= files


@pytest.mark.parametrize("type_name", MESSAGES)
def test_message_model_matches_file(type_name: str) -> None:
    package = type_name.split("/")[0]
    expected = parse_definition(_file(type_name).read_text(), package)
    assert _comparable(model_definition(registered_types()[type_name])) == _comparable(expected)


@pytest.mark.parametrize("type_name", SERVICES)
def test_service_models_match_file(type_name: str) -> None:
    service = registered_services()[type_name]
    request, response = parse_service(_file(type_name).read_text(), type_name.split("/")[0])
    assert _comparable(model_definition(service.request)) == _comparable(request)
    assert _comparable(model_definition(service.response)) == _comparable(response)


def test_seed_constants_and_defaults() -> None:
    from pfield.interfaces.geometry_msgs import Quaternion
    from pfield.interfaces.potential_fields_interfaces import FindValidPose_Response, PlanPath_Request

    assert PlanPath_Request.PLANNING_METHOD_TASK_SPACE == "task_space"
    assert PlanPath_Request.PLANNING_METHOD_WHOLE_BODY == "whole_body"
    assert FindValidPose_Response.OUTSIDE == 4
    assert Quaternion().w == 1.0
    assert PlanPath_Request().max_iterations == 0


def test_parser_reads_constants_defaults_bounds_and_comments() -> None:
    text = 'int32 A=3 # c\nstring S="x#y"\nfloat64[<=3] v\nfloat32 w 1.5\nObstacle[] obs\nstring<=5 n "ab"\n'
    definition = parse_definition(text, "pkg")
    assert [(c.name, c.value) for c in definition.constants] == [("A", 3), ("S", "x#y")]
    assert [(f.type, f.name, f.default) for f in definition.fields] == [
        ("float64[]", "v", []), ("float32", "w", 1.5), ("pkg/Obstacle[]", "obs", []), ("string", "n", "ab")]


def test_fixed_size_arrays_keep_their_size_and_zero_default() -> None:
    from pfield.interfaces.geometry_msgs import PoseWithCovariance

    definition = parse_definition("float64[36] covariance\nint8[2] pair\n", "pkg")
    assert [(f.type, f.name, f.default) for f in definition.fields] == [
        ("float64[36]", "covariance", [0.0] * 36), ("int8[2]", "pair", [0, 0])]
    model = model_definition(PoseWithCovariance)
    assert model.fields[1] == definition.fields[0]
