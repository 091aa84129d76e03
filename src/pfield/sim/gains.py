"""Joint servo gains of the simulated robot: MuJoCo Menagerie's where Menagerie models the robot, else a rule.

A joint's position actuator is MuJoCo's ``general`` actuator with an affine bias (what Menagerie's arms use):

    τ = kp·u − kp·q − kv·q̇,    |τ| ≤ force_limit

for the control ``u``. Commanding ``u = q_ref + (kv/kp)·q̇_ref`` makes it the PD law with velocity feed-forward
τ = kp·(q_ref − q) + kv·(q̇_ref − q̇) (:mod:`pfield.sim.simulation`).

Values taken from MuJoCo Menagerie (google-deepmind/mujoco_menagerie; the ``mujoco-menagerie`` wheel carries only
a registry and downloads each model from GitHub on first use, so the values are copied here as facts, with their
source, and nothing is fetched at run time):

* ``franka_emika_panda/panda.xml``: joints 1–2 kp 4500, kv 450; joints 3–4 kp 3500, kv 350; joints 5–7 kp 2000,
  kv 200; force range ±87 N·m (joints 1–4), ±12 N·m (5–7); joint armature 0.1 kg·m², damping 1 N·m·s/rad.
* ``universal_robots_ur5e/ur5e.xml``: shoulder pan/lift and elbow ("size3") kp 2000, kv 400, ±150 N·m; the three
  wrist joints ("size1") kp 500, kv 100, ±28 N·m; armature 0.1 kg·m², no joint damping.

They apply to a robot with that model's joint names whose URDF effort limits (where given) equal those force
ranges (:func:`pfield.sim.model.servo_gains`). Any other robot (:func:`default_gains`): a critically damped servo of
natural frequency ω = 60 rad/s on each joint's own inertia at the middle of its range, kp = m_jj·ω², kv = 2·m_jj·ω
(m_jj the diagonal of the joint-space mass matrix with the armature; the Panda's Menagerie gains give ω = 39–137
rad/s there, over-damped with kv/kp = 0.1 s), armature 0.1, damping 1, force range the URDF's effort limit (none
where the URDF gives 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._validation import nonnegative, positive
from pfield.errors import InvalidInput

__all__ = ["DEFAULT_ARMATURE", "DEFAULT_DAMPING", "DEFAULT_NATURAL_FREQUENCY", "MENAGERIE_GAINS", "ServoGains",
           "menagerie_gains"]

DEFAULT_NATURAL_FREQUENCY = 60.0
"""rad/s: ω of :func:`default_gains` (kp = m·ω², kv = 2·m·ω, critically damped)."""
DEFAULT_ARMATURE = 0.1
"""kg·m² (or kg): rotor inertia added to every joint without Menagerie values (Menagerie's arms use 0.1)."""
DEFAULT_DAMPING = 1.0
"""N·m·s/rad: joint viscous damping without Menagerie values (the Panda's)."""


@dataclass(frozen=True, eq=False)
class ServoGains:
    """Per-joint position servo gains, in the robot's joint order.

    Attributes:
        kp: (n,) N·m/rad (N/m for a prismatic joint), > 0.
        kv: (n,) N·m·s/rad, ≥ 0.
        force_limit: (n,) N·m; ``inf`` for an unlimited actuator.
        armature: (n,) kg·m² reflected rotor inertia; damping: (n,) N·m·s/rad passive joint damping.
        source: where the values come from (a Menagerie file or "default rule").
    """

    kp: NDArray[np.float64]
    kv: NDArray[np.float64]
    force_limit: NDArray[np.float64]
    armature: NDArray[np.float64]
    damping: NDArray[np.float64]
    source: str

    def __post_init__(self) -> None:
        count = np.size(self.kp)
        for name in ("kp", "kv", "force_limit", "armature", "damping"):
            array = np.array(getattr(self, name), dtype=np.float64).reshape(-1)
            if array.shape != (count,):
                raise InvalidInput(name, getattr(self, name), f"expected {count} values (one per joint)")
            for j, value in enumerate(array):
                if name == "kp":
                    positive(f"{name}[{j}]", value)
                elif not (name == "force_limit" and value == np.inf):  # inf: an unlimited actuator
                    nonnegative(f"{name}[{j}]", value)
            array.setflags(write=False)
            object.__setattr__(self, name, array)


def _menagerie(kp: list[float], kv: list[float], force: list[float], damping: float, source: str) -> ServoGains:
    n = len(kp)
    return ServoGains(np.array(kp), np.array(kv), np.array(force), np.full(n, 0.1), np.full(n, damping), source)


MENAGERIE_GAINS: dict[tuple[str, ...], ServoGains] = {
    tuple(f"panda_joint{i}" for i in range(1, 8)): _menagerie(
        [4500, 4500, 3500, 3500, 2000, 2000, 2000], [450, 450, 350, 350, 200, 200, 200],
        [87, 87, 87, 87, 12, 12, 12], 1.0, "mujoco_menagerie franka_emika_panda/panda.xml"),
    ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
     "wrist_3_joint"): _menagerie(
        [2000, 2000, 2000, 500, 500, 500], [400, 400, 400, 100, 100, 100], [150, 150, 150, 28, 28, 28], 0.0,
        "mujoco_menagerie universal_robots_ur5e/ur5e.xml"),
}
"""Menagerie's servo gains by the robot's joint names (tree order); see the module docstring."""


def menagerie_gains(joint_names: tuple[str, ...]) -> ServoGains | None:
    """Menagerie's gains for a robot with these joints (tree order), or None when Menagerie has none."""
    return MENAGERIE_GAINS.get(tuple(joint_names))


def default_gains(joint_inertia: ArrayLike, effort_limits: ArrayLike) -> ServoGains:
    """The documented rule for a robot Menagerie does not model (module docstring): ``joint_inertia`` (n,) is the
    diagonal of the joint-space mass matrix (kg·m², armature included), ``effort_limits`` (n,) the URDF's."""
    inertia = np.asarray(joint_inertia, dtype=np.float64)
    effort = np.asarray(effort_limits, dtype=np.float64)
    omega = DEFAULT_NATURAL_FREQUENCY
    return ServoGains(inertia * omega**2, 2.0 * inertia * omega, np.where(effort > 0, effort, np.inf),
                      np.full(len(inertia), DEFAULT_ARMATURE), np.full(len(inertia), DEFAULT_DAMPING),
                      f"default rule (ω = {omega:g} rad/s, critically damped)")
