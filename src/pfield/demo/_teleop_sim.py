"""A simulated operator teleoperating the end effector (a point) under three kinds of assistance.

Operator (seeded): u_op(t) = sat(K_p (g − p(t − τ)) + b + ε(t)), with reaction delay τ (the operator sees an
old position), a constant bias b (a drift of the input device, random direction) and white noise ε ~ N(0, σ²)
per step, saturated at the operator's top speed. The operator aims straight at the target and does not
steer around obstacles: the assistance has to.

Modes: ``none`` (the operator's command executed), ``servo`` (MoveIt Servo's collision velocity scaling:
u = s(d) u_op, s = exp(k (d − 0.02)), k = −ln(0.001)/0.02, d the exact distance; Servo halts in collision),
``pfield`` (:func:`pfield.shared_control.task_space_assistance`, arbitration :data:`ARBITRATION`, the target as the
goal).
Obstacles may move (``motion``: id → function t ↦ centre); their velocity is estimated from successive
positions with the node's filter (:mod:`pfield.node.obstacle_motion`) and the field is rebuilt each step with
the obstacles at their current pose (plans and the autonomy vector treat obstacles as static).
Collision check: the exact signed distance of the point to every obstacle is ≤ 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Obstacle, Sphere, pack_obstacles, signed_distances
from pfield.node.obstacle_motion import Held, updated_held
from pfield.shared_control.assistance import AssistanceScene, servo_scale, task_space_assistance
from pfield.spatial import Pose, Twist

MODES = ("none", "servo", "pfield")
SERVO_SCENE_THRESHOLD = 0.02  # m, moveit_servo default scene_collision_proximity_threshold
ARBITRATION = "linear_goal"
"""pfield's mode: the operator's target is the field's goal, so the field also takes over as it nears
(``linear_goal``: the goal share of Dragan & Srinivasa's confidence-based blending, :mod:`pfield.shared_control`)."""


@dataclass(frozen=True)
class Operator:
    """The simulated operator's parameters (SI units)."""

    gain: float = 1.0  # 1/s
    top_speed: float = 0.08  # m/s
    delay: float = 0.2  # s
    bias: float = 0.01  # m/s, magnitude of the constant drift
    noise: float = 0.01  # m/s, standard deviation per step


@dataclass(frozen=True, eq=False)
class TeleopRun:
    """One run: time series (T,) or (T, 3) and the outcome."""

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    operator: NDArray[np.float64]
    executed: NDArray[np.float64]
    alpha: NDArray[np.float64]
    clearance: NDArray[np.float64]
    collided: bool
    success: bool
    time_to_goal: float
    agreement: float


def _clearance(obstacles: Sequence[Obstacle], p: NDArray[np.float64]) -> float:
    if not obstacles:
        return math.inf
    distances, _ = signed_distances(pack_obstacles(list(obstacles)), p[None, :])
    return float(distances.min())


def simulate(obstacles: Sequence[Obstacle], start: NDArray[np.float64], goal: NDArray[np.float64], mode: str,
             seed: int, *, motion: Mapping[str, Callable[[float], NDArray[np.float64]]] | None = None,
             operator: Operator | None = None, config: FieldConfig | None = None, dt: float = 0.05,
             time_limit: float = 30.0, goal_tolerance: float = 0.02) -> TeleopRun:
    """Run the operator from ``start`` to ``goal`` (m, world) under ``mode``; see the module docstring."""
    op, config = operator or Operator(), config or FieldConfig(max_linear_velocity=0.08)
    rng = np.random.default_rng(seed)
    direction = rng.normal(size=3)
    bias = op.bias * direction / np.linalg.norm(direction)
    delay_steps = round(op.delay / dt)
    steps = round(time_limit / dt)
    goal_pose = Pose(goal)
    motion = motion or {}
    held: dict[str, Held] = {}
    p = np.array(start, dtype=float)
    history = [p.copy()]
    rows: list[tuple[float, NDArray[np.float64], NDArray[np.float64], float, float]] = []
    collided, success, reached = False, False, math.inf
    for k in range(steps):
        t = k * dt
        current = [o if o.id not in motion else replace(o, pose=Pose(motion[o.id](t))) for o in obstacles]
        for o in current:
            if o.id in motion:
                held[o.id] = updated_held(held.get(o.id), o, t, 1.0)
        seen = history[max(0, len(history) - 1 - delay_steps)]
        command = op.gain * (goal - seen) + bias + rng.normal(scale=op.noise, size=3)
        speed = np.linalg.norm(command)
        if speed > op.top_speed:
            command *= op.top_speed / speed
        clearance = _clearance(current, p)
        alpha = 0.0
        if mode == "none":
            executed = command
        elif mode == "servo":
            executed = servo_scale(clearance, SERVO_SCENE_THRESHOLD) * command
        else:
            field = PotentialField(config, goal_pose, current)
            scene = AssistanceScene(field=field, velocities={key: h.velocity for key, h in held.items()})
            answer = task_space_assistance(scene, Pose(p), Twist(command), ARBITRATION)
            executed, alpha = answer.blended_command.linear, answer.alpha
        rows.append((t, command, executed, alpha, clearance))
        collided = collided or clearance <= 0.0
        p = p + executed * dt
        history.append(p.copy())
        if np.linalg.norm(goal - p) <= goal_tolerance:
            success, reached = True, t + dt
            break
    return _outcome(rows, history, collided, success, reached)


ARM_START = (0.0, -0.3, 0.0, 0.6, 0.0, 0.9, 0.0)  # rad, the xArm7's joints at the start of arm_scene()
ARM_DISTANCE = 0.3  # m, arm_scene()'s start-to-goal distance along +y


def arm_scene(robot: Any) -> tuple[NDArray[np.float64], list[Obstacle], NDArray[np.float64]]:
    """The whole-body case of the teleop benchmark: (start joints, obstacles, goal) for the xArm7 ``robot``.

    The end effector goes :data:`ARM_DISTANCE` along +y past two static spheres: one on the straight line, one
    5 cm above and 2 cm beside it, far enough from the goal that the wrist reaches the goal with the field's
    safety distance (the field alone plans there)."""
    q0 = np.array(ARM_START)
    p0 = robot.forward_kinematics(q0).position
    obstacles = [Obstacle("s0", Sphere(0.04), Pose(p0 + np.array([0.0, 0.15, 0.0]))),
                 Obstacle("s1", Sphere(0.03), Pose(p0 + np.array([0.02, 0.20, 0.05])))]
    return q0, obstacles, p0 + np.array([0.0, ARM_DISTANCE, 0.0])


def simulate_arm(robot: Any, obstacles: Sequence[Obstacle], q0: NDArray[np.float64], goal: NDArray[np.float64],
                 mode: str, seed: int, *, operator: Operator | None = None, config: FieldConfig | None = None,
                 dt: float = 0.05, time_limit: float = 30.0, goal_tolerance: float = 0.02,
                 checker: Any = None) -> TeleopRun:
    """The same operator driving a whole robot's end effector (static obstacles).

    The operator's end-effector twist (linear part; angular 0) becomes joint velocities by damped least
    squares (λ = 0.01, :func:`pfield.robot.ik.differential_ik`) for ``none`` and ``servo``; ``servo`` scales them
    by MoveIt Servo's law at the exact scene (0.02 m) and self (0.01 m) distances; ``pfield`` executes
    :func:`pfield.shared_control.whole_body_assistance`'s ``joint_velocities``. Joints are integrated and clipped
    to their limits. Collisions and clearances: exact URDF-geometry distances (coal,
    :class:`pfield.robot.collision.CollisionChecker`); a self-collision counts too.
    """
    from pfield.robot.collision import CollisionChecker
    from pfield.robot.ik import differential_ik
    from pfield.shared_control.assistance import whole_body_assistance

    op, config = operator or Operator(), config or FieldConfig(max_linear_velocity=0.08)
    checker = checker or CollisionChecker(robot, obstacles)
    rng = np.random.default_rng(seed)
    direction = rng.normal(size=3)
    bias = op.bias * direction / np.linalg.norm(direction)
    delay_steps, steps = round(op.delay / dt), round(time_limit / dt)
    scene = AssistanceScene(field=PotentialField(config, Pose(goal, robot.forward_kinematics(q0).orientation),
                                                 list(obstacles)))
    q = np.array(q0, dtype=float)
    history = [robot.forward_kinematics(q).position]
    rows: list[tuple[float, NDArray[np.float64], NDArray[np.float64], float, float]] = []
    collided, success, reached = False, False, math.inf
    for k in range(steps):
        seen = history[max(0, len(history) - 1 - delay_steps)]
        command = op.gain * (goal - seen) + bias + rng.normal(scale=op.noise, size=3)
        speed = np.linalg.norm(command)
        if speed > op.top_speed:
            command *= op.top_speed / speed
        scene_distance, _, self_distance, _ = checker.distances(q)
        alpha = 0.0
        jac = robot.jacobian(q)
        twist = np.concatenate([command, np.zeros(3)])
        if mode == "pfield":
            answer = whole_body_assistance(scene, robot, q, Twist(command), ARBITRATION)
            qd, alpha = answer.joint_velocities, answer.alpha
        else:
            qd = differential_ik(robot, q, twist)  # damped least squares, λ² = 1e-4 (solve_ik's)
            if mode == "servo":
                qd = qd * min(servo_scale(scene_distance, SERVO_SCENE_THRESHOLD), servo_scale(self_distance, 0.01))
        executed = (jac @ qd)[:3]
        rows.append((k * dt, command, executed, alpha, min(scene_distance, self_distance)))
        collided = collided or scene_distance <= 0.0 or self_distance <= 0.0
        q = np.clip(q + qd * dt, robot.lower_limits, robot.upper_limits)
        position = robot.forward_kinematics(q).position
        history.append(position)
        if np.linalg.norm(goal - position) <= goal_tolerance:
            success, reached = True, (k + 1) * dt
            break
    return _outcome(rows, history, collided, success, reached)


def _outcome(rows: list[tuple[float, NDArray[np.float64], NDArray[np.float64], float, float]],
             history: list[NDArray[np.float64]], collided: bool, success: bool, reached: float) -> TeleopRun:
    times = np.array([r[0] for r in rows])
    ops, exe = np.array([r[1] for r in rows]), np.array([r[2] for r in rows])
    norms = np.linalg.norm(ops, axis=1) * np.linalg.norm(exe, axis=1)
    moving = norms > 1e-12
    agreement = float(np.mean(np.sum(ops * exe, axis=1)[moving] / norms[moving])) if moving.any() else 1.0
    return TeleopRun(times, np.array(history[:-1]), ops, exe, np.array([r[3] for r in rows]),
                     np.array([r[4] for r in rows]), collided, success, reached, agreement)
