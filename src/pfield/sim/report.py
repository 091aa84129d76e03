"""Value types of the simulator: a joint state, the contact tally, the report of an executed trajectory."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pfield.spatial import Pose

__all__ = ["ContactTally", "ExecutionReport", "JointState"]


@dataclass(frozen=True, eq=False)
class JointState:
    """The robot's joints after a step (what ``/joint_states`` would carry).

    Attributes:
        time: s of simulated time since the last reset.
        positions: (n,) rad or m, tree order; velocities: (n,) rad/s or m/s; efforts: (n,) N·m or N, the
            actuator forces (the servo's output, after its force limit).
    """

    time: float
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    efforts: NDArray[np.float64]


@dataclass(frozen=True)
class ContactTally:
    """Contacts counted since the last reset (a MuJoCo contact has penetration depth ≥ 0: geom margins are 0).

    Attributes:
        obstacle_steps: simulation steps with at least one robot–obstacle contact.
        obstacle_pairs: the distinct ``"link/obstacle id"`` pairs that touched, sorted.
        obstacle_penetration: m, the deepest robot–obstacle penetration (0 without contact).
        self_steps, self_pairs, self_penetration: the same for robot–robot contacts (adjacent bodies and the SRDF's
            disabled pairs excluded).
    """

    obstacle_steps: int = 0
    obstacle_pairs: tuple[str, ...] = ()
    obstacle_penetration: float = 0.0
    self_steps: int = 0
    self_pairs: tuple[str, ...] = ()
    self_penetration: float = 0.0


@dataclass(frozen=True, eq=False)
class ExecutionReport:
    """What happened when a planned trajectory was played through the simulated servos.

    Attributes:
        duration: s, the trajectory's length; simulated_time: s, including the settling time after it.
        wall_time: s of real time the simulation took (this machine).
        steps: simulation steps.
        max_tracking_error: rad (or m), max over time and joints of |q − q_ref| while the trajectory played;
            max_tracking_joint: the joint where it occurred.
        final_tracking_error: rad, max over joints of |q − q_final| at the end of the settling time.
        final_position_error: m, |p_ee(q_end) − p_goal| (pfield's forward kinematics of the simulated joints).
        final_rotation_error: rad, geodesic angle between the end effector's and the goal's orientations.
        contacts: the :class:`ContactTally` of the run.
        base_overlaps: ``"link/obstacle"`` pairs of the fixed base's geometry that overlap an obstacle (the base is
            welded to the world, so MuJoCo never reports these as contacts; they are checked once).
        final_positions: (n,) the joints at the end; final_pose: the end effector's pose there (world frame, pfield's
            forward kinematics; joints a hair beyond a limit are read at the limit).
    """

    duration: float
    simulated_time: float
    wall_time: float
    steps: int
    max_tracking_error: float
    max_tracking_joint: str
    final_tracking_error: float
    final_position_error: float
    final_rotation_error: float
    contacts: ContactTally
    base_overlaps: tuple[str, ...]
    final_positions: NDArray[np.float64]
    final_pose: Pose

    @property
    def obstacle_contacts(self) -> int:
        """Steps with a robot–obstacle contact plus overlaps of the base (0 for a collision-free execution)."""
        return self.contacts.obstacle_steps + len(self.base_overlaps)
