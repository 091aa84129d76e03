"""Executing trajectories in MuJoCo: a pose holds under gravity, a free-space plan is followed to its goal, a
trajectory into a box is caught by the contact counter, and bad input is refused without changing anything."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from tests.sim.conftest import FREE_GOAL

from pfield.errors import InvalidInput
from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Box, Obstacle
from pfield.planning import PlannedPath
from pfield.planning.retime import TimedJointTrajectory, retime_joint_path
from pfield.robot import RobotModel
from pfield.sim import Simulation
from pfield.sim.simulation import hermite_reference
from pfield.spatial import Pose


def test_without_gravity_compensation_a_pose_holds_with_the_servo_offset_gravity_demands(panda: RobotModel) -> None:
    ready = panda.named_configuration("ready")
    sim = Simulation(panda, gravity_compensation=False, q0=ready)
    state = sim.step(positions=ready, dt=3.0)
    assert state.time == pytest.approx(3.0)
    # at rest the servo's torque kp·(q_ref − q) carries gravity: q_ref − q = g(q)/kp (pinocchio's g, URDF inertias)
    model = panda.pinocchio_model
    gravity = pin.computeGeneralizedGravity(model, model.createData(), panda.pinocchio_configuration(state.positions))
    offset = ready - state.positions
    np.testing.assert_allclose(offset, gravity / sim.sim_model.gains.kp, atol=1e-6)
    assert np.max(np.abs(offset)) > 1e-3  # gravity is on: the offset is real, not zero
    assert np.max(np.abs(offset)) < 0.01  # and within a servo's bound (rad)
    np.testing.assert_allclose(state.velocities, 0.0, atol=1e-6)


def test_with_gravity_compensation_a_pose_holds_exactly(panda: RobotModel) -> None:
    ready = panda.named_configuration("ready")
    sim = Simulation(panda, q0=ready)
    state = sim.step(positions=ready, dt=1.0)
    np.testing.assert_allclose(state.positions, ready, atol=1e-9)


@pytest.mark.parametrize("step", [0.003, 0.01, 0.02, 0.2])
def test_a_step_of_the_reference_that_saturates_a_joint_settles(panda: RobotModel, step: float) -> None:
    """A reference step large enough to hit a wrist joint's 12 N·m limit (kp 2000: from 6 mrad) settles, and the
    joint rests at the new reference. At the former 2 ms step, the implicit integrator kept joint 7 chattering at
    ±0.111 rad/s for ever after a 0.01 rad step (why: pfield.sim.model.DEFAULT_TIMESTEP)."""
    q = np.array([0.0428, -0.6864, 0.2643, -2.2083, 0.1783, 1.6193, 1.1663])  # where the servo test's arm stopped
    sim = Simulation(panda, q0=q)
    for joint in (4, 6):
        reference = q.copy()
        reference[joint] += step
        sim.reset(q)
        state = sim.step(positions=reference, dt=2.0)
        np.testing.assert_allclose(state.velocities, 0.0, atol=1e-6)
        np.testing.assert_allclose(state.positions, reference, atol=1e-6)


def test_a_free_space_plan_is_followed_to_its_goal(panda: RobotModel, free_plan: PlannedPath) -> None:
    sim = Simulation(panda)
    report = sim.execute(free_plan, FREE_GOAL)
    assert free_plan.trajectory is not None
    assert report.duration == pytest.approx(free_plan.trajectory.duration)
    assert report.simulated_time == pytest.approx(report.duration + 0.5, abs=2 * sim.timestep)
    assert 0.0 < report.max_tracking_error < 0.02  # rad: reported, and small for a servo with feed-forward
    assert report.max_tracking_joint in panda.joint_names
    assert report.final_position_error <= 0.01  # the bound (the plan itself stops within 5 mm)
    assert report.final_pose.translation_distance(FREE_GOAL) == pytest.approx(report.final_position_error)
    assert report.final_tracking_error < 1e-3
    assert report.obstacle_contacts == 0 and report.contacts.self_steps == 0
    assert report.steps == round(report.simulated_time / sim.timestep)


def test_a_trajectory_into_a_box_produces_contacts(panda: RobotModel, free_plan: PlannedPath) -> None:
    middle = free_plan.positions[len(free_plan) // 2]
    box = Obstacle("crate", Box(length=0.15, width=0.15, height=0.15), Pose(middle))  # on the end effector's path
    report = Simulation(panda, [box]).execute(free_plan)
    assert report.contacts.obstacle_steps > 0 and report.obstacle_contacts > 0
    assert report.contacts.obstacle_pairs and all(p.endswith("/crate") for p in report.contacts.obstacle_pairs)
    assert report.contacts.obstacle_penetration > 0.0


def test_the_base_overlapping_an_obstacle_is_reported(panda: RobotModel) -> None:
    plinth = Obstacle("plinth", Box(length=0.3, width=0.3, height=0.1), Pose((0.0, 0.0, 0.05)))
    assert Simulation(panda, [plinth]).base_overlaps == ("world/plinth",)


def test_a_velocity_command_moves_the_reference_at_that_rate(panda: RobotModel) -> None:
    ready = panda.named_configuration("ready")
    sim = Simulation(panda, q0=ready)
    rate = np.zeros(7)
    rate[0] = 0.2
    for _ in range(50):
        state = sim.step(velocities=rate, dt=0.01)
    assert state.time == pytest.approx(0.5)
    assert state.positions[0] == pytest.approx(ready[0] + 0.1, abs=2e-3)
    np.testing.assert_allclose(state.positions[1:], ready[1:], atol=1e-3)
    assert state.velocities[0] == pytest.approx(0.2, abs=0.01)


def test_hermite_reference_reproduces_a_cubic_and_rests_outside() -> None:
    times = np.array([0.0, 0.4, 1.0, 1.5])
    trajectory = TimedJointTrajectory(("a",), times, times[:, None] ** 3, 3 * times[:, None] ** 2,
                                      6 * times[:, None], np.ones(1), np.ones(1))
    query = np.linspace(-0.5, 2.0, 41)
    positions, velocities = hermite_reference(trajectory, query)
    inside = (query >= 0) & (query <= 1.5)
    np.testing.assert_allclose(positions[inside, 0], query[inside] ** 3, atol=1e-12)
    np.testing.assert_allclose(velocities[inside, 0], 3 * query[inside] ** 2, atol=1e-12)
    np.testing.assert_allclose(positions[query > 1.5, 0], 1.5**3)
    np.testing.assert_allclose(positions[query < 0, 0], 0.0)


def test_a_path_of_another_robot_is_refused(panda: RobotModel, xarm: RobotModel) -> None:
    field = PotentialField(FieldConfig(), xarm.forward_kinematics(xarm.mid_configuration), [])
    other = field.plan_whole_body(xarm, xarm.mid_configuration, dt=0.02, max_iterations=5)
    with pytest.raises(InvalidInput, match=r"path\.trajectory\.joint_names.*panda_joint1"):
        Simulation(panda).execute(other)


def test_bad_input_is_refused_and_changes_nothing(panda: RobotModel, free_plan: PlannedPath) -> None:
    sim = Simulation(panda, q0=panda.named_configuration("ready"))
    sim.step(positions=panda.named_configuration("ready"), dt=0.1)
    before = sim.state
    assert free_plan.trajectory is not None
    bad = free_plan.trajectory.positions.copy()
    bad[3, 2] = np.nan
    cases = [
        (lambda: sim.execute(replace(free_plan, trajectory=replace(free_plan.trajectory, positions=bad))),
         r"path\.trajectory\.positions"),
        (lambda: sim.execute(replace(free_plan, trajectory=None)), r"path\.trajectory.*task-space"),
        (lambda: sim.execute(replace(free_plan, trajectory=replace(
            free_plan.trajectory, times=np.zeros_like(free_plan.trajectory.times)))), r"path\.trajectory\.times"),
        (lambda: sim.execute("plan"), "path"),  # type: ignore[arg-type]
        (lambda: sim.execute(free_plan, goal=(0.4, 0, 0.3)), "goal"),  # type: ignore[arg-type]
        (lambda: sim.execute(free_plan, settle=-1.0), "settle"),
        (lambda: sim.step(), "command"),
        (lambda: sim.step(positions=[0.0] * 6), "positions"),
        (lambda: sim.step(positions=[np.nan] * 7), "positions"),
        (lambda: sim.step(positions=np.full(7, 4.0)), r"positions\[0\]"),
        (lambda: sim.step(velocities=[0.0] * 6 + [np.inf]), "velocities"),
        (lambda: sim.step(velocities=np.zeros(7), dt=0.0), "dt"),
        (lambda: sim.step(velocities=np.zeros(7), dt=1e6), r"dt=1000000.0: must be <= 60 s"),  # hours of stepping
        (lambda: Simulation(panda, timestep=1.0), r"timestep=1.0: must be <= 0.01 s"),
        (lambda: sim.reset([np.nan] * 7), "q"),
    ]
    for call, field in cases:
        with pytest.raises(InvalidInput, match=field):
            call()
    after = sim.state
    assert after.time == before.time
    np.testing.assert_array_equal(after.positions, before.positions)


def test_a_trajectory_beyond_the_limits_is_refused(panda: RobotModel) -> None:
    ready = panda.named_configuration("ready")
    far = ready.copy()
    far[3] = 0.5  # joint 4's upper limit is −0.0698 rad
    trajectory = retime_joint_path(panda.joint_names, np.array([ready, far]), panda.velocity_limits,
                                   panda.acceleration_limits)
    field = PotentialField(FieldConfig(), panda.forward_kinematics(ready), [])
    path = replace(field.plan_whole_body(panda, ready, dt=0.02, max_iterations=2), trajectory=trajectory)
    with pytest.raises(InvalidInput, match=r"positions\[1\]\[3\].*panda_joint4"):
        Simulation(panda).execute(path)


def test_folding_the_arm_onto_itself_counts_self_contacts_apart(panda: RobotModel) -> None:
    ready = panda.named_configuration("ready")
    folded = np.array([0.0, 0.5, 0.0, -3.0, 0.0, 0.0, 0.785])  # coal: link1 and link6 overlap by 2.7 cm here
    sim = Simulation(panda, q0=ready)
    for s in np.linspace(0.0, 1.0, 201)[1:]:
        sim.step(positions=ready + s * (folded - ready), dt=0.01)
    tally = sim.contacts
    assert tally.self_steps > 0 and tally.obstacle_steps == 0
    assert "panda_link1/panda_link6" in tally.self_pairs or "panda_link6/panda_link1" in tally.self_pairs
    assert tally.self_penetration > 0.0
    sim.reset(ready)  # a reset clears the tally
    assert sim.contacts.self_steps == 0
