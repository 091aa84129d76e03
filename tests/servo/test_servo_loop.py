"""The servo loop in process: timeout stop, end-effector twists against FK, steering, joint bounds, singularities,
limits never exceeded (property test) and bad input."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pfield import FieldConfig, Obstacle, Pose, RobotModel, Sphere, Twist
from pfield.errors import InvalidInput
from pfield.robot.collision import capsule_clearances
from pfield.robot.model import MEASURED_BOUNDS_ERROR
from pfield.shared_control import AssistanceScene
from pfield.shared_control.servo import LEAVING_MIN_SCALE, Servo, ServoStatus
from pfield.shared_control.servo_config import ServoConfig
from pfield.spatial import rotate_vectors

PERIOD = 0.002
SAFETY = {ServoStatus.HALT_FOR_COLLISION, ServoStatus.DECELERATE_FOR_COLLISION, ServoStatus.JOINT_BOUND,
          ServoStatus.HALT_FOR_SINGULARITY, ServoStatus.DECELERATE_FOR_APPROACHING_SINGULARITY,
          ServoStatus.DECELERATE_FOR_LEAVING_SINGULARITY}
"""Statuses under which the safety stages may decelerate faster than the acceleration limits."""


@pytest.fixture(scope="module")
def robot() -> RobotModel:
    return RobotModel.builtin("panda")


@pytest.fixture(scope="module")
def empty_scene() -> AssistanceScene:
    return AssistanceScene(config=FieldConfig(), obstacles=[])


def ready(robot: RobotModel) -> np.ndarray:
    return robot.named_configuration("ready").copy()


def run(servo: Servo, q: np.ndarray, twist: Twist | None, steps: int, start: float = 0.0, **command: Any) -> list[Any]:
    """``steps`` steps at PERIOD, the command renewed before each when ``twist`` is given."""
    out = []
    for k in range(steps):
        now = start + k * PERIOD
        if twist is not None:
            servo.command(twist, now, **command)
        out.append(servo.step(q, now))
    return out


def test_a_stale_command_stops_the_robot(robot: RobotModel, empty_scene: AssistanceScene) -> None:
    servo = Servo(robot, ServoConfig(publish_period=PERIOD, incoming_command_timeout=0.05), empty_scene)
    q = ready(robot)
    moving = run(servo, q, Twist((0.05, 0.0, 0.0)), 100)
    assert moving[-1].status == ServoStatus.NO_WARNING and moving[-1].moving
    speeds = []
    for k in range(100, 400):  # no new command: stale after 0.05 s, then a deceleration within the limits
        command = servo.step(q, k * PERIOD)
        speeds.append(np.abs(command.velocities).max())
        if k * PERIOD - 99 * PERIOD > 0.05 + 1e-9:  # the last command came at step 99
            assert command.status == ServoStatus.COMMAND_TIMEOUT
    assert all(b <= a + 1e-12 for a, b in itertools.pairwise(speeds))  # never speeds up again
    assert speeds[-1] == 0.0 and not command.moving and command.assistance is None
    held = servo.step(q, 401 * PERIOD)
    assert np.array_equal(held.positions, command.positions)  # holds where it stopped


def test_end_effector_twist_is_rotated_by_forward_kinematics(robot: RobotModel, empty_scene: AssistanceScene) -> None:
    q = ready(robot)
    q[6] += 0.6  # a tool turned about its axis: the tool frame differs from the world's
    tool = Twist((0.02, -0.01, 0.015), (0.0, 0.1, 0.05))
    orientation = robot.forward_kinematics(q).orientation
    world = Twist(rotate_vectors(orientation, tool.linear), rotate_vectors(orientation, tool.angular))
    config = ServoConfig(publish_period=PERIOD)
    in_tool = Servo(robot, config, empty_scene, arbitration="safety_only")
    in_world = Servo(robot, config, empty_scene, arbitration="safety_only")
    in_tool.command(tool, 0.0, end_effector_frame=True)
    in_world.command(world, 0.0)
    a, b = in_tool.step(q, 0.0), in_world.step(q, 0.0)
    assert a.assistance is not None and b.assistance is not None
    assert np.allclose(a.velocities, b.velocities, rtol=0, atol=1e-12)
    twist = robot.jacobian(q) @ a.assistance.joint_velocities  # the operator's twist mapped to joints (DLS)
    assert twist[:3] == pytest.approx(world.linear, abs=2e-4) and twist[3:] == pytest.approx(world.angular, abs=2e-3)
    # a world-frame command is not the tool-frame one
    assert not np.allclose(world.linear, tool.linear, atol=1e-3)


def test_unitless_commands_are_scaled_as_servo_does(robot: RobotModel, empty_scene: AssistanceScene) -> None:
    config = ServoConfig(publish_period=PERIOD, command_in_type="unitless", scale_linear=0.04, scale_rotational=0.2)
    servo = Servo(robot, config, empty_scene, arbitration="safety_only")
    reference = Servo(robot, ServoConfig(publish_period=PERIOD), empty_scene, arbitration="safety_only")
    q = ready(robot)
    servo.command(Twist((0.5, 0.0, 0.0), (0.0, 0.0, 1.0)), 0.0)
    reference.command(Twist((0.02, 0.0, 0.0), (0.0, 0.0, 0.2)), 0.0)
    assert np.allclose(servo.step(q, 0.0).velocities, reference.step(q, 0.0).velocities, atol=1e-15)


def test_an_obstacle_ahead_steers_and_limits_the_approach(robot: RobotModel) -> None:
    q = ready(robot)
    tip = robot.forward_kinematics(q).position
    config = ServoConfig(publish_period=PERIOD)
    for offset in (-0.03, 0.01):  # off-centre: slides along the ball; ahead: between the fingers, held short
        ball = Obstacle("ball", Sphere(radius=0.05), Pose(position=(tip[0] + 0.13, tip[1] + offset, tip[2])))
        scene = AssistanceScene(config=FieldConfig(), obstacles=[ball])
        servo = Servo(robot, config, scene, arbitration="safety_only")
        commands = run(servo, q, Twist((0.05, 0.0, 0.0)), 1200)
        statuses = {c.status for c in commands}
        assert ServoStatus.DECELERATE_FOR_COLLISION in statuses
        clearances = [c.assistance.nearest_distance for c in commands if c.assistance is not None]
        assert min(clearances) > 0.5 * FieldConfig().safety_distance  # never in contact, about the dampers' margin
        assert "ball" in next(c.message for c in commands if c.status == ServoStatus.DECELERATE_FOR_COLLISION)
        final = robot.forward_kinematics(commands[-1].positions).position
        if offset < 0:
            assert final[1] - tip[1] < -0.01 and final[0] - tip[0] > 0.05  # steered around, kept going
        else:  # held short of the ball's near surface (8 cm ahead) by the dampers on both fingers
            assert final[0] - tip[0] < 0.08 and commands[-1].status == ServoStatus.DECELERATE_FOR_COLLISION


def test_joint_margins_are_never_crossed(robot: RobotModel, empty_scene: AssistanceScene) -> None:
    config = ServoConfig(publish_period=PERIOD, joint_limit_margins=(0.1,))
    servo = Servo(robot, config, empty_scene, arbitration="safety_only")
    q = ready(robot)
    q[0] = robot.upper_limits[0] - 0.12  # the base joint near its upper limit
    twist = Twist(*np.split(robot.jacobian(q)[:, 0] * 0.3, 2))  # the twist of a pure joint-1 motion toward it
    commands = run(servo, q, twist, 300)
    assert ServoStatus.JOINT_BOUND in {c.status for c in commands}
    assert max(c.positions[0] for c in commands) <= robot.upper_limits[0] - 0.1 + 1e-12
    assert commands[-1].positions[0] > robot.upper_limits[0] - 0.1 - 1e-3  # it got there, and stopped there


def _condition(robot: RobotModel, q: np.ndarray) -> float:
    values = np.linalg.svd(robot.jacobian(q), compute_uv=False)
    return float(values[0] / values[-1])


@pytest.mark.parametrize("elbow", [-1.0, -0.9])
def test_singularity_scales_as_servo_does(robot: RobotModel, empty_scene: AssistanceScene, elbow: float) -> None:
    """Panda arm stretched toward its elbow singularity (condition number κ 25.5 at q4 = -1.0, 31.2 at -0.9; it grows
    as q4 rises): Servo's scale 1 − (κ − 17)/(κ_u − 17), κ_u = 30 approaching, 17 + 2·13 leaving; a halt at κ ≥ 30."""
    q = np.array([0.0, 0.3, 0.0, elbow, 0.0, 1.5, 0.785])
    kappa = _condition(robot, q)
    free = ServoConfig(publish_period=1.0, lower_singularity_threshold=1e3, hard_stop_singularity_threshold=2e3)
    config = ServoConfig(publish_period=1.0)  # a long period: no acceleration limit in the one step compared
    for sign, status, upper in ((1.0, ServoStatus.DECELERATE_FOR_APPROACHING_SINGULARITY, 30.0),
                                (-1.0, ServoStatus.DECELERATE_FOR_LEAVING_SINGULARITY, 43.0)):
        twist = Twist(*np.split(robot.jacobian(q)[:, 3] * 0.1 * sign, 2))  # the twist of the elbow moving
        commands = []
        for each in (config, free):
            servo = Servo(robot, each, empty_scene, arbitration="safety_only")
            servo.command(twist, 0.0)
            commands.append(servo.step(q, 0.0))
        scaled, unscaled = commands
        if sign > 0 and kappa >= 30.0:
            assert scaled.status == ServoStatus.HALT_FOR_SINGULARITY and not scaled.velocities.any()
            continue
        assert scaled.status == status and unscaled.status == ServoStatus.NO_WARNING
        expected = 1.0 - (kappa - 17.0) / (upper - 17.0)
        assert scaled.velocities == pytest.approx(expected * unscaled.velocities, rel=1e-9, abs=1e-15)
    assert 17.0 < kappa < 35.0 and LEAVING_MIN_SCALE > 0


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1), speed=st.sampled_from([0.01, 0.2, 1e3]),
       period=st.sampled_from([0.002, 0.01]), gaps=st.lists(st.sampled_from([0.0, 0.5, 1.0, 1.7, 30.0]),
                                                             min_size=40, max_size=40))
def test_limits_are_never_exceeded(robot: RobotModel, seed: int, speed: float, period: float,
                                   gaps: list[float]) -> None:
    """Random start, commands of any size in any frame, uneven step times: positions within the limits, speeds within
    the URDF limits, and the acceleration limits kept whenever no safety stage spoke."""
    rng = np.random.default_rng(seed)
    low, high = robot.lower_limits, robot.upper_limits
    q = low + rng.uniform(0.02, 0.98, robot.n_joints) * (high - low)
    centres = rng.uniform([0.2, -0.5, 0.0], [0.7, 0.5, 0.9], (3, 3))
    balls = [Obstacle(f"b{i}", Sphere(radius=0.05), Pose(position=tuple(c))) for i, c in enumerate(centres)]
    scene = AssistanceScene(config=FieldConfig(), obstacles=balls)
    servo = Servo(robot, ServoConfig(publish_period=period, joint_limit_margins=(0.05,)), scene)
    now, previous = 0.0, np.zeros(robot.n_joints)
    for gap in gaps:
        direction = rng.normal(size=6)
        servo.command(Twist(direction[:3] * speed, direction[3:] * speed), now, end_effector_frame=bool(gap > 1.0))
        command = servo.step(q, now)
        assert np.all(command.positions >= low) and np.all(command.positions <= high)
        assert np.all(np.abs(command.velocities) <= robot.velocity_limits * (1 + 1e-9))
        if command.status not in SAFETY:
            room = robot.acceleration_limits * command.period * (1 + 1e-9) + 1e-12
            assert np.all(np.abs(command.velocities - previous) <= room), command.status
        previous = command.velocities
        now += gap * period
        if gap * period > max(2 * period, servo.config.incoming_command_timeout):
            previous = np.zeros(robot.n_joints)  # a pause that long ends the stream: the next starts from rest


def test_bad_input_is_refused_and_changes_nothing(robot: RobotModel, empty_scene: AssistanceScene) -> None:
    servo = Servo(robot, ServoConfig(publish_period=PERIOD), empty_scene)
    q = ready(robot)
    servo.command(Twist((0.01, 0.0, 0.0)), 1.0)
    first = servo.step(q, 1.0)
    state = (servo._command, servo._positions, servo._velocities.copy(), servo._last_step)
    bad_steps: list[tuple[Any, float, str]] = [
        ([0.0] * 6, 1.1, "joint_angles"),
        (np.full(7, math.nan), 1.1, "joint_angles"),
        (q + np.array([10.0, 0, 0, 0, 0, 0, 0]), 1.1, r"joint_angles\[0\]"),
        (q, math.nan, "now"),
        (q, 0.5, "now"),  # before the previous step
    ]
    for joints, now, field in bad_steps:
        with pytest.raises(InvalidInput, match=field):
            servo.step(joints, now)
    with pytest.raises(InvalidInput, match="twist"):
        servo.command("fast", 1.1)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="received"):
        servo.command(Twist((0.01, 0.0, 0.0)), math.inf)
    with pytest.raises(InvalidInput, match="ee_frame"):
        Servo(robot, ServoConfig(ee_frame="flange"), empty_scene)
    with pytest.raises(InvalidInput, match="joint_limit_margins"):
        Servo(robot, ServoConfig(joint_limit_margins=(0.1, 0.2)), empty_scene)
    with pytest.raises(InvalidInput, match="scene"):
        Servo(robot).step(q, 0.0)
    assert servo._command is state[0] and servo._positions is state[1] and servo._last_step == state[3]
    assert np.array_equal(servo._velocities, state[2]) and first.moving


def test_a_measured_state_just_past_a_limit_is_taken_at_it(robot: RobotModel, empty_scene: AssistanceScene) -> None:
    """A robot pressed against a limit reports positions past it (MuJoCo's Panda: panda_joint4 0.9 mrad below its
    lower limit): the servo steps from the limit, jogs back inside and holds a jog further out; farther past
    (beyond MEASURED_BOUNDS_ERROR) the state is refused."""
    q = ready(robot)
    q[3] = robot.lower_limits[3] - 0.9e-3
    for direction, moves in ((1.0, True), (-1.0, False)):
        servo = Servo(robot, ServoConfig(publish_period=PERIOD), empty_scene, arbitration="safety_only")
        commands = _jog(servo, q, [0.0, 0.0, 0.0, 0.1 * direction, 0.0, 0.0, 0.0], 50)
        assert all(c.positions[3] >= robot.lower_limits[3] for c in commands)
        assert (commands[-1].velocities[3] > 0.0) if moves else (commands[-1].velocities[3] == 0.0)
    q[3] = robot.lower_limits[3] - MEASURED_BOUNDS_ERROR - 1e-3
    with pytest.raises(InvalidInput, match=r"joint_angles\[3\]"):
        Servo(robot, ServoConfig(publish_period=PERIOD), empty_scene).step(q, 0.0)


def _jog(servo: Servo, q: np.ndarray, velocities: list[float], steps: int) -> list[Any]:
    """``steps`` steps at PERIOD, the joint jog renewed before each."""
    out = []
    for k in range(steps):
        servo.command_joints(velocities, k * PERIOD)
        out.append(servo.step(q, k * PERIOD))
    return out


def test_a_joint_jog_moves_its_joints_only_and_is_scaled_as_servo_does(robot: RobotModel,
                                                                        empty_scene: AssistanceScene) -> None:
    """Servo's joint jog (``~/delta_joint_cmds``): the wrist and the elbow at the jog's speeds once the acceleration
    limit let them get there, every other joint still; ``unitless`` scales by ``scale_joint``; a stale jog stops."""
    q = ready(robot)
    jog = [0.0, 0.0, 0.0, 0.02, 0.0, 0.0, 0.3]
    servo = Servo(robot, ServoConfig(publish_period=PERIOD), empty_scene, arbitration="safety_only")
    commands = _jog(servo, q, jog, 150)  # 0.3 rad/s at 1.4 rad/s² takes 108 steps of 2 ms
    last = commands[-1]
    assert last.status == ServoStatus.NO_WARNING and last.velocities.tolist() == jog
    assert last.assistance is not None and last.assistance.joint_velocities.tolist() == jog  # passed the dampers as is
    moved = np.flatnonzero(last.positions != q)
    assert moved.tolist() == [3, 6]
    rising = [c.velocities[6] for c in commands[:110]]
    assert all(b - a <= robot.acceleration_limits[6] * PERIOD + 1e-12 for a, b in itertools.pairwise(rising))
    unitless = Servo(robot, ServoConfig(publish_period=PERIOD, command_in_type="unitless", scale_joint=0.1),
                     empty_scene, arbitration="safety_only")
    scaled = _jog(unitless, q, [0.0, 0.0, 0.0, 0.2, 0.0, 0.0, 3.0], 150)
    assert np.allclose([c.velocities for c in scaled], [c.velocities for c in commands], rtol=0, atol=1e-15)
    for k in range(150, 400):  # no new jog: stale after incoming_command_timeout (0.1 s), then a stop
        stopped = servo.step(q, k * PERIOD)
    assert stopped.status == ServoStatus.COMMAND_TIMEOUT and not stopped.moving


def test_a_joint_jog_stops_at_its_margin_and_is_not_scaled_for_singularities(robot: RobotModel,
                                                                             empty_scene: AssistanceScene) -> None:
    """At a joint's margin: every jogged joint scaled by one factor (``halt_all_joints_in_joint_mode``) or only that
    joint held; near the elbow singularity a jog goes at its speed (Servo scales twists only)."""
    q = ready(robot)
    q[3] = robot.upper_limits[3] - 0.105  # the elbow 5 mm from its margin of 0.1
    jog = [0.0, 0.0, 0.0, 0.05, 0.0, 0.0, 0.3]
    for halt_all in (True, False):
        config = ServoConfig(publish_period=PERIOD, halt_all_joints_in_joint_mode=halt_all)
        servo = Servo(robot, config, empty_scene, arbitration="safety_only")
        commands = _jog(servo, q, jog, 200)
        bound = [c for c in commands if c.status == ServoStatus.JOINT_BOUND]
        assert bound and max(c.positions[3] for c in commands) <= robot.upper_limits[3] - 0.1 + 1e-12
        wrist = bound[-1].velocities[6]
        if halt_all:  # halted with the elbow
            assert wrist == 0.0
        else:  # left going (the acceleration stage's one factor, set by the elbow's held change, keeps it just short)
            assert wrist == pytest.approx(0.3, abs=1e-3) and bound[-1].velocities[3] == 0.0
    stretched = np.array([0.0, 0.3, 0.0, -1.0, 0.0, 1.5, 0.785])  # κ 25.5: a twist here is scaled (test above)
    servo = Servo(robot, ServoConfig(publish_period=1.0), empty_scene, arbitration="safety_only")
    servo.command_joints([0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0], 0.0)
    command = servo.step(stretched, 0.0)
    assert command.status == ServoStatus.NO_WARNING and command.velocities.tolist() == [0, 0, 0, 0.1, 0, 0, 0]


def test_a_joint_jog_by_an_obstacle_is_held_at_the_dampers(robot: RobotModel) -> None:
    """The jog goes through the same dampers as a twist: turning the base toward a sphere beside the hand, the
    hand's approach is limited and the step never ends inside the safety distance."""
    q = ready(robot)
    hand = robot.forward_kinematics(q).position
    side = np.array([-hand[1], hand[0], 0.0]) / np.hypot(hand[0], hand[1])  # where the base's +turn moves the hand
    config = FieldConfig()
    sphere = Obstacle("ball", Sphere(0.04), Pose(tuple(hand + 0.14 * side)))
    scene = AssistanceScene(config=config, obstacles=[sphere])
    servo = Servo(robot, ServoConfig(publish_period=0.01), scene, arbitration="safety_only")
    positions = q
    statuses = set()
    lowest = math.inf
    for k in range(400):
        servo.command_joints([0.3, 0, 0, 0, 0, 0, 0], k * 0.01)
        command = servo.step(positions, k * 0.01)
        positions = command.positions
        statuses.add(command.status)
        lowest = min(lowest, float(capsule_clearances(robot, positions, [sphere]).obstacle.min()))
    assert ServoStatus.DECELERATE_FOR_COLLISION in statuses
    assert 0.5 * config.safety_distance < lowest < 0.02  # held about the dampers' margin, never in contact


def test_bad_joint_jogs_are_refused_and_change_nothing(robot: RobotModel, empty_scene: AssistanceScene) -> None:
    servo = Servo(robot, ServoConfig(publish_period=PERIOD), empty_scene)
    servo.command_joints([0.1] * 7, 1.0)
    before = servo._command
    for velocities, field in (([0.1] * 6, "velocities"), ([math.nan] * 7, "velocities"), ("fast", "velocities")):
        with pytest.raises(InvalidInput, match=field):
            servo.command_joints(velocities, 1.1)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="received"):
        servo.command_joints([0.1] * 7, math.nan)
    assert servo._command is before


def test_twists_and_jogs_each_read_their_own_halt_all_flag(robot: RobotModel, empty_scene: AssistanceScene) -> None:
    """At the base joint's margin: ``halt_all_joints_in_cartesian_mode`` decides for twists and
    ``halt_all_joints_in_joint_mode`` for joint jogs, each not the other's."""
    q = ready(robot)
    q[0] = robot.upper_limits[0] - 0.12
    twist = Twist(*np.split(robot.jacobian(q)[:, 0] * 0.3, 2))  # the twist of a pure joint-1 motion toward it

    def twists(**flags: bool) -> np.ndarray:
        servo = Servo(robot, ServoConfig(publish_period=PERIOD, **flags), empty_scene, arbitration="safety_only")
        return np.array([c.velocities for c in run(servo, q, twist, 300)])

    def jogs(**flags: bool) -> np.ndarray:
        servo = Servo(robot, ServoConfig(publish_period=PERIOD, **flags), empty_scene, arbitration="safety_only")
        return np.array([c.velocities for c in _jog(servo, q, [0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3], 300)])

    assert np.array_equal(twists(halt_all_joints_in_joint_mode=False), twists())
    assert not np.array_equal(twists(halt_all_joints_in_cartesian_mode=False), twists())
    assert np.array_equal(jogs(halt_all_joints_in_cartesian_mode=False), jogs())
    assert not np.array_equal(jogs(halt_all_joints_in_joint_mode=False), jogs())
