"""PlanOptions and PlanStatus: one validated options object and one outcome enum for every planner."""

from __future__ import annotations

import math

import pytest

import pfield
from pfield.errors import InvalidInput
from pfield.field import FieldConfig
from pfield.planning import CancelToken, PlanOptions, PlanStatus
from pfield.planning.options import DEFAULT_MAX_ITERATIONS, MAX_ITERATIONS_LIMIT, MIN_STAGNATION_STEPS, SEED_LIMIT


def test_defaults_and_the_zero_or_negative_iteration_rule() -> None:
    options = PlanOptions()
    assert (options.dt, options.goal_tolerance, options.max_iterations) == (0.01, 0.01, DEFAULT_MAX_ITERATIONS)
    assert PlanOptions(max_iterations=0).max_iterations == 30000
    assert PlanOptions(max_iterations=-5).max_iterations == 30000
    assert PlanOptions(max_iterations=MAX_ITERATIONS_LIMIT).max_iterations == 2_000_000
    assert PlanOptions().global_seed == 0
    assert PlanOptions(global_seed=SEED_LIMIT - 1).global_seed == 2**32 - 1


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({"dt": 0.0}, "dt"), ({"dt": -1.0}, "dt"), ({"dt": math.nan}, "dt"), ({"dt": True}, "dt"),
        ({"goal_tolerance": 0.0}, "goal_tolerance"), ({"goal_tolerance": "small"}, "goal_tolerance"),
        ({"rotation_tolerance": 0.0}, "rotation_tolerance"), ({"rotation_tolerance": math.pi}, "rotation_tolerance"),
        ({"max_iterations": True}, "max_iterations"), ({"max_iterations": 10.0}, "max_iterations"),
        ({"max_iterations": "100"}, "max_iterations"), ({"max_iterations": MAX_ITERATIONS_LIMIT + 1}, "max_iterations"),
        ({"stagnation_window": 0.0}, "stagnation_window"), ({"stagnation_progress": -1e-3}, "stagnation_progress"),
        ({"cancel": True}, "cancel"),
        ({"global_seed": -1}, "global_seed"), ({"global_seed": SEED_LIMIT}, "global_seed"),
        ({"global_seed": True}, "global_seed"), ({"global_seed": 1.0}, "global_seed"),
    ],
)
def test_bad_options_name_the_field(changes: dict[str, object], name: str) -> None:
    with pytest.raises(InvalidInput) as info:
        PlanOptions(**changes)  # type: ignore[arg-type]
    assert info.value.field == name


def test_build_applies_the_given_keywords_only_and_refuses_unknown_names() -> None:
    base = PlanOptions(dt=0.02, max_iterations=100)
    assert PlanOptions.build(base) is base
    assert PlanOptions.build(base, dt=None, goal_tolerance=0.005) == PlanOptions(dt=0.02, goal_tolerance=0.005,
                                                                                 max_iterations=100)
    assert PlanOptions.build(None, max_iterations=0) == PlanOptions()
    with pytest.raises(InvalidInput) as info:
        PlanOptions.build(base, delta_time=0.1)
    assert info.value.field == "delta_time"
    with pytest.raises(InvalidInput):
        PlanOptions.build("fast")  # type: ignore[arg-type]


def test_resolved_takes_the_missing_values_from_the_field_config() -> None:
    config = FieldConfig(rotation_tolerance=0.1, stagnation_window=2.0, stagnation_progress=0.01)
    resolved = PlanOptions(dt=0.05).resolved(config)
    assert (resolved.rotation_tolerance, resolved.stagnation_window, resolved.stagnation_progress) == (0.1, 2.0, 0.01)
    assert resolved.stagnation_steps == 40
    assert PlanOptions(rotation_tolerance=0.2).resolved(config).rotation_tolerance == 0.2
    assert PlanOptions(dt=0.5, stagnation_window=1.0).stagnation_steps == MIN_STAGNATION_STEPS
    with pytest.raises(InvalidInput):
        _ = PlanOptions().stagnation_steps


def test_the_options_carry_a_cancel_token() -> None:
    token = CancelToken()
    options = PlanOptions(cancel=token)
    assert options.cancel is token and not token.cancelled
    token.cancel()
    assert options.cancel.cancelled and int(token.flag[0]) == 1


def test_one_status_enum_exported_everywhere() -> None:
    assert pfield.PlanStatus is PlanStatus and pfield.PlanOptions is PlanOptions
    assert [s.success for s in PlanStatus].count(True) == 1 and PlanStatus.REACHED.success
    assert len({int(s) for s in PlanStatus}) == len(PlanStatus)
    for name in ("REACHED", "STAGNATION", "ITERATION_LIMIT", "COLLISION", "SELF_COLLISION", "NOT_FINITE",
                 "START_INVALID", "GOAL_INVALID", "CANCELLED", "GLOBAL_NO_PATH", "GLOBAL_TIME_LIMIT"):
        assert name in PlanStatus.__members__
