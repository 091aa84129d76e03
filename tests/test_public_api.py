"""The public names of DESIGN §3.3, §3.5 and §3.6 are importable from where users are told to find them."""

from __future__ import annotations

import numpy as np

import pfield


def test_top_level_names_of_the_contract() -> None:
    from pfield import (  # noqa: F401  (the import itself is the test)
        Box,
        Capsule,
        Cylinder,
        Ellipsoid,
        FieldConfig,
        Mesh,
        Obstacle,
        PfieldError,
        PlannedPath,
        Pose,
        PotentialField,
        RobotModel,
        Sphere,
        Twist,
        Wrench,
    )

    assert set(pfield.__all__) >= {"Pose", "Obstacle", "Sphere", "FieldConfig", "PotentialField", "RobotModel"}
    assert set(pfield.__all__) == set(pfield._HOME_OF)  # every exported name loads from its home on first use
    for name in pfield.__all__:
        assert getattr(pfield, name) is not None


def test_design_example_runs_as_written() -> None:
    from pfield import FieldConfig, Obstacle, Pose, PotentialField, Sphere

    obs = Obstacle("ball", Sphere(radius=0.1), Pose(position=(0.4, 0, 0.1)), group="Static")
    d, n = obs.signed_distance(np.array([[0.6, 0.0, 0.1]]))
    np.testing.assert_allclose(d, [0.1])
    np.testing.assert_allclose(n, [[1.0, 0.0, 0.0]])
    field = PotentialField(FieldConfig(), goal=Pose(position=(0.5, 0.2, 0.4)), obstacles=[obs])
    path = field.plan(start=Pose(position=(0.2, 0.0, 0.3)), dt=0.02, goal_tolerance=0.01, max_iterations=25000)
    assert path.success
    assert np.linalg.norm(path.positions[-1] - (0.5, 0.2, 0.4)) <= 0.01


def test_mobile_functional_api_names() -> None:
    from pfield.mobile import VectorFieldParams, gradient, potential, velocity

    params = VectorFieldParams(ka=3.0, kr_dist=0.8, kr_height=1.0, kr_slope=30.0, min_spd_norm=0.1,
                               max_spd_norm=1.0, goal_tolerance=0.1, attraction="power")
    points, goal, obstacles = np.array([[1.0, 0.0]]), np.array([0.0, 0.0]), np.array([[5.0, 5.0]])
    assert potential(points, goal, obstacles, params).shape == (1,)
    assert gradient(points, goal, obstacles, params).shape == (1, 2)
    assert np.linalg.norm(velocity(points, goal, obstacles, params)) <= 1.0


def test_outcome_enums_print_their_names_and_stay_numbers() -> None:
    """Issue 33: ``print(path.status)`` printed ``1``; the number stays for comparisons and wire formats."""
    import json

    from pfield.costmap.find_valid_pose import PoseState
    from pfield.planning import PlanStatus

    status = PlanStatus.STAGNATION
    assert str(status) == "STAGNATION" and f"{status}" == "STAGNATION" and f"{status:d}" == "1"
    assert status == 1 and int(status) == 1 and json.dumps({"status": status}) == '{"status": 1}'
    assert str(PoseState.INSCRIBED) == "INSCRIBED" and PoseState.INSCRIBED == 1
