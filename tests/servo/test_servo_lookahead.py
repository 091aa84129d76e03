"""The servo's look-ahead (stage 7 of pfield.shared_control.servo): no step ends inside the safety distance.

The assistance's dampers hold the approach of every link point on the velocity it answers (tests/test_assistance.py);
the servo's later stages change that velocity before it is executed: stage 4 moves from the previous velocity toward
it within the acceleration limits, so just after the operator turns, the executed velocity still carries some of the
previous one's approach. Stage 7 checks the step actually taken, on the same link model."""

from __future__ import annotations

import numpy as np
import pytest

from pfield import FieldConfig, Obstacle, Pose, RobotModel, Sphere, Twist
from pfield.robot.collision import capsule_clearances
from pfield.shared_control import AssistanceScene
from pfield.shared_control.servo import Servo, ServoStatus
from pfield.shared_control.servo_config import ServoConfig

CONFIG = FieldConfig()  # safety distance d_s 0.01 m
SEEDS = 12


@pytest.fixture(scope="module")
def robot() -> RobotModel:
    return RobotModel.builtin("panda")


def test_no_step_ends_inside_the_safety_distance(robot: RobotModel) -> None:
    """Seeded operators among three balls 10-18 cm around the hand, a new random twist (fixed or end-effector frame,
    up to 0.3 m/s and 1 rad/s) every 50 steps, at 500 Hz and 100 Hz: from a start outside d_s, every commanded
    position's link-model clearance stays at least d_s (the look-ahead's rule: a step ending inside d_s and closer
    than now is not taken), and the look-ahead did have to hold some step (the acceleration stage had carried it
    inside)."""
    halts, lowest = 0, np.inf
    for seed in range(SEEDS):
        rng = np.random.default_rng(seed)
        start = robot.named_configuration("ready") + rng.normal(scale=0.3, size=robot.n_joints)
        start = np.clip(start, robot.lower_limits + 0.1, robot.upper_limits - 0.1)
        tip = robot.forward_kinematics(start).position
        balls: list[Obstacle] = []
        while len(balls) < 3:  # each ball at least 2 d_s clear of the arm
            direction = rng.normal(size=3)
            ball = Obstacle(f"b{len(balls)}", Sphere(radius=0.03 + 0.03 * rng.random()),
                            Pose(position=tuple(tip + direction / np.linalg.norm(direction) * rng.uniform(0.1, 0.18))))
            if capsule_clearances(robot, start, [ball]).obstacle.min() >= 2 * CONFIG.safety_distance:
                balls.append(ball)
        period = (0.002, 0.01)[seed % 2]
        servo = Servo(robot, ServoConfig(publish_period=period, joint_limit_margins=(0.05,)),
                      AssistanceScene(config=CONFIG, obstacles=balls), arbitration="safety_only")
        for k in range(600):
            if k % 50 == 0:
                twist = rng.normal(size=6)
                twist[:3] *= rng.uniform(0.05, 0.3) / np.linalg.norm(twist[:3])
                twist[3:] *= rng.uniform(0.0, 1.0) / np.linalg.norm(twist[3:])
                in_tool = bool(rng.integers(2))
            servo.command(Twist(twist[:3], twist[3:]), k * period, end_effector_frame=in_tool, unitless=False)
            command = servo.step(start, k * period)
            halts += command.status == ServoStatus.HALT_FOR_COLLISION
            lowest = min(lowest, float(capsule_clearances(robot, command.positions, balls).obstacle.min()))
    assert lowest >= CONFIG.safety_distance
    assert halts >= 1
