"""The 2D simulation: ray casting, kinematics, the seed's grid cases, corridor and doorway, scenario files."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pfield.errors import InvalidInput, ResourceNotFound
from pfield.mobile.scenarios import BUILTIN_SCENARIOS, load_scenario
from pfield.mobile.sim import integrate_pose, simulate
from pfield.mobile.world import World2D


def test_raycast_hits_circles_and_polygon_edges_exactly():
    world = World2D.build(circles=[[2.0, 0.0, 0.5]], polygons=[[(-1.0, 1.0), (1.0, 1.0), (1.0, 1.5), (-1.0, 1.5)]])
    ranges = world.raycast((0.0, 0.0), [0.0, math.pi / 2, math.pi, math.atan2(1.0, 1.0)], 5.0)
    assert ranges[:3] == pytest.approx([1.5, 1.0, math.inf])
    assert ranges[3] == pytest.approx(math.sqrt(2.0))  # the polygon's corner (1, 1)
    assert world.raycast((2.0, 0.0), [0.0], 5.0)[0] == pytest.approx(0.5)  # from inside: the exit
    assert world.raycast((0.0, 0.0), [0.0], 1.0)[0] == math.inf  # beyond range_max
    assert world.clearance((0.0, 0.0)) == pytest.approx(1.0)
    with pytest.raises(InvalidInput, match="circles"):
        World2D.build(circles=[[0.0, 0.0, -1.0]])
    with pytest.raises(InvalidInput, match=r"polygons\[0\]"):
        World2D.build(polygons=[[(0.0, 0.0), (1.0, 0.0)]])


def test_diff_drive_integration_is_exact_on_a_circle():
    pose = np.array([0.0, 0.0, 0.0])
    for _ in range(100):
        pose = integrate_pose(pose, np.array([1.0, 0.0, 2 * math.pi / 10.0]), 0.1)  # one turn in 10 s
    assert pose == pytest.approx([0.0, 0.0, 0.0], abs=1e-9)
    quarter = integrate_pose(np.zeros(3), np.array([1.0, 0.0, math.pi / 2]), 1.0)
    assert quarter == pytest.approx([2 / math.pi, 2 / math.pi, math.pi / 2])


@pytest.mark.parametrize("drive", ["holonomic", "diff_drive"])
def test_seed_grid_cannot_go_through_with_first_set_and_can_with_second(drive):
    blocked = simulate(BUILTIN_SCENARIOS["grid_blocked"].with_drive(drive))
    assert blocked.outcome == "stuck"
    assert "goal_reached" not in blocked.states
    assert blocked.poses[-1, 0] < -4.0  # stalled in front of the grid's first column
    passed = simulate(BUILTIN_SCENARIOS["grid_pass"].with_drive(drive))
    assert passed.outcome == "goal_reached"
    assert passed.final_distance_to_goal <= passed.scenario.params.goal_tolerance + 1e-9


@pytest.mark.parametrize("name", ["corridor", "doorway"])
@pytest.mark.parametrize("drive", ["holonomic", "diff_drive"])
def test_laser_scenarios_reach_the_goal_without_collision(name, drive):
    result = simulate(BUILTIN_SCENARIOS[name].with_drive(drive))
    assert result.outcome == "goal_reached"
    assert result.min_clearance > result.scenario.robot_radius
    speeds = np.linalg.norm(result.commands[:, :2], axis=1)
    assert speeds.max() <= result.scenario.params.max_spd_norm + 1e-12


def test_scenario_yaml_file(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text("start: [0, 0, 0]\ngoal: [2, 0]\npoints: [[1, 0.05]]\nduration: 20\n"
                    "params: {ka: 1.0, attraction: linear, kr_dist: 0.0, kr_height: 0.5, kr_slope: 5.0}\n"
                    "config: {drive: diff_drive}\n")
    scenario = load_scenario(path)
    assert scenario.name == "mine" and scenario.config.drive == "diff_drive"
    assert simulate(scenario).outcome == "goal_reached"
    with pytest.raises(ResourceNotFound):
        load_scenario("no_such_scenario")
    path.write_text("start: [0, 0, 0]\ngoal: [2, 0]\nwalls: []\n")
    with pytest.raises(InvalidInput, match="walls"):
        load_scenario(path)
    path.write_text("start: [0, 0]\ngoal: [2, 0]\nparams: {}\n")
    with pytest.raises(InvalidInput, match="start"):
        load_scenario(path)


def test_collision_and_timeout_outcomes_and_progress():
    corridor = BUILTIN_SCENARIOS["corridor"]  # without repulsion the straight line cuts the inner corner
    blind = dataclasses.replace(corridor, params=dataclasses.replace(corridor.params, kr_height=0.0))
    crashed = simulate(blind)
    assert crashed.outcome == "collision" and crashed.states[-1] == "collision"
    assert crashed.min_clearance < corridor.robot_radius
    doorway = BUILTIN_SCENARIOS["doorway"]
    seen = []
    short = simulate(dataclasses.replace(doorway, duration=1.0), progress=lambda t, total: seen.append((t, total)))
    assert short.outcome == "timeout"
    assert len(seen) == len(short.times) == 20 and seen[-1] == (pytest.approx(0.95), 1.0)
    assert short.poses.shape == (20, 3) and short.commands.shape == (20, 3)
