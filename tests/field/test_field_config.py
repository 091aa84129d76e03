"""FieldConfig: defaults of DESIGN §2, validation naming the field, replace/as_dict round trips."""

from __future__ import annotations

import math

import pytest

from pfield.errors import InvalidInput
from pfield.field.config import PARAM_NAMES, FieldConfig


def test_defaults_equal_the_ros_configuration() -> None:
    config = FieldConfig()
    assert config.attractive_gain == 3.0
    assert config.rotational_attractive_gain == 0.15
    assert config.repulsive_gain == 0.3
    assert config.max_linear_velocity == 0.05
    assert config.max_angular_velocity == 0.4
    assert config.max_linear_acceleration == 1.0
    assert config.max_angular_acceleration == 0.2
    assert config.influence_distance == 0.1
    assert config.rotation_tolerance == 0.05


@pytest.mark.parametrize("name", PARAM_NAMES)
@pytest.mark.parametrize("value", [math.nan, math.inf, -1.0, "abc", None, True])
def test_bad_values_name_the_field(name: str, value: object) -> None:
    with pytest.raises(InvalidInput) as info:
        FieldConfig(**{name: value})  # type: ignore[arg-type]
    assert info.value.field == name


@pytest.mark.parametrize(
    "name",
    [n for n in PARAM_NAMES if n not in ("rotational_attractive_gain", "repulsive_gain", "safety_distance",
                                         "circulation_gain", "attractive_gain", "damper_gain")],
)
def test_zero_is_rejected_where_a_positive_value_is_needed(name: str) -> None:
    with pytest.raises(InvalidInput, match=name) as info:
        FieldConfig(**{name: 0.0})
    assert "must be > 0 (" in str(info.value)  # the message says why zero makes no sense


@pytest.mark.parametrize("name", ["attractive_gain", "rotational_attractive_gain", "repulsive_gain",
                                  "damper_gain", "circulation_gain"])
def test_every_gain_may_be_zero(name: str) -> None:
    assert getattr(FieldConfig(**{name: 0.0}), name) == 0.0


def test_zero_repulsion_and_rotation_gains_are_allowed() -> None:
    config = FieldConfig(repulsive_gain=0.0, rotational_attractive_gain=0.0, safety_distance=0.0)
    assert config.repulsive_gain == 0.0


def test_safety_distance_must_be_inside_the_influence_distance() -> None:
    with pytest.raises(InvalidInput, match="safety_distance"):
        FieldConfig(influence_distance=0.1, safety_distance=0.1)


def test_replace_validates_and_keeps_the_original() -> None:
    config = FieldConfig()
    changed = config.replace(attractive_gain=1.5, influence_distance=0.2)
    assert changed.attractive_gain == 1.5 and changed.influence_distance == 0.2
    assert config.attractive_gain == 3.0
    with pytest.raises(InvalidInput, match="max_linear_velocity"):
        config.replace(max_linear_velocity=-1)
    with pytest.raises(InvalidInput, match="no_such_gain"):
        config.replace(no_such_gain=1.0)


def test_as_dict_round_trips_and_integers_become_floats() -> None:
    config = FieldConfig(attractive_gain=2)
    values = config.as_dict()
    assert list(values) == list(PARAM_NAMES)
    assert isinstance(values["attractive_gain"], float)
    assert FieldConfig(**values) == config
    assert list(config.packed()) == [values[name] for name in PARAM_NAMES]
