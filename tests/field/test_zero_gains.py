"""A zero gain switches its term off, and every law stays finite: the seed's "repulsive only" field."""

from __future__ import annotations

import numpy as np
import pytest

from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Obstacle, Sphere
from pfield.spatial import Pose, Twist

BALL = Obstacle("ball", Sphere(radius=0.1), Pose((0.5, 0.0, 0.0)))
REPULSIVE_ONLY = FieldConfig(attractive_gain=0.0, rotational_attractive_gain=0.0, max_repulsive_force=1e12)


def test_repulsive_only_wrench_is_exactly_khatib() -> None:
    field = PotentialField(REPULSIVE_ONLY, Pose((1.0, 1.0, 1.0), (0.0, 0.0, 1.0, 0.0)), [BALL])
    d = 0.05
    wrench = field.wrench(Pose((0.4 - d, 0.0, 0.0)))
    khatib = 0.3 * (1 / d - 1 / 0.1) / d**2
    np.testing.assert_allclose(wrench.force, (-khatib, 0.0, 0.0), rtol=1e-12)
    np.testing.assert_array_equal(wrench.torque, (0.0, 0.0, 0.0))


def test_repulsive_only_twist_is_finite_and_zero_away_from_obstacles() -> None:
    field = PotentialField(REPULSIVE_ONLY, Pose((1.0, 0.0, 0.0)), [BALL])
    for position in [(0.0, 0.0, 0.0), (0.39, 0.0, 0.0), (0.5, 0.0, 0.0), (1.0, 0.0, 0.0)]:
        twist = field.twist(Pose(position), previous=Twist(), dt=0.02)
        assert np.all(np.isfinite(twist.linear)) and np.all(np.isfinite(twist.angular))
    far = field.twist(Pose((0.0, 0.0, 0.0)))
    np.testing.assert_array_equal(far.linear, (0.0, 0.0, 0.0))
    np.testing.assert_array_equal(far.angular, (0.0, 0.0, 0.0))


def test_plan_without_attraction_reports_stagnation_not_nan() -> None:
    field = PotentialField(REPULSIVE_ONLY, Pose((1.0, 0.0, 0.0)), [BALL])
    path = field.plan(Pose((0.0, 0.0, 0.0)), dt=0.02, goal_tolerance=0.01, max_iterations=2000)
    assert not path.success
    assert path.failure_reason.startswith("stagnation")
    assert np.all(np.isfinite(path.positions))


@pytest.mark.parametrize("changes", [{"damper_gain": 0.0}, {"circulation_gain": 0.0},
                                     {"repulsive_gain": 0.0}])
def test_zero_avoidance_gains_still_plan_around_the_ball(changes: dict[str, float]) -> None:
    """Dampers keep the path out of the ball whatever the other avoidance gains are (0 included)."""
    field = PotentialField(FieldConfig(**changes), Pose((1.0, 0.0, 0.05)), [BALL])
    path = field.plan(Pose((0.0, 0.0, 0.0)), dt=0.02, goal_tolerance=0.01, max_iterations=3000)
    assert np.all(np.isfinite(path.positions))
    assert float(np.min(path.clearances)) > 0.0


def test_whole_body_autonomy_without_attraction_is_finite() -> None:
    from pfield.robot import RobotModel
    from pfield.shared_control.autonomy import whole_body_autonomy_vector

    robot = RobotModel.builtin("xarm7")
    field = PotentialField(REPULSIVE_ONLY, Pose((0.5, 0.2, 0.4)),
                           [Obstacle("near", Sphere(radius=0.05), Pose((0.3, 0.0, 0.45)))])
    twist = whole_body_autonomy_vector(field, robot, [0, -0.6, 0, 0.9, 0, 1.5, 0])
    assert np.all(np.isfinite(twist.linear)) and np.all(np.isfinite(twist.angular))
