"""A physics check in MuJoCo: the robot pfield plans with, its servos, the obstacles; trajectories executed.

* :class:`Simulation` — ``Simulation(robot, obstacles)``; ``execute(path) -> ExecutionReport``;
  ``step(positions, velocities, dt) -> JointState`` for a servo loop or an action server.
* :func:`build_model` — the compiled ``mujoco.MjModel`` and what its ids mean (:class:`SimModel`).
* :class:`ServoGains`, :func:`menagerie_gains` — the joint servos (MuJoCo Menagerie's gains where it models the robot).
* :func:`render_frame` — a PNG of the simulation (offscreen, EGL or OSMesa).

Needs the ``sim`` extra (``pip install 'pfield[sim]'``: ``mujoco``). docs/sim.md.
"""

from __future__ import annotations

from pfield.sim.gains import MENAGERIE_GAINS, ServoGains, menagerie_gains
from pfield.sim.model import SimModel, build_model
from pfield.sim.render import render_frame
from pfield.sim.report import ContactTally, ExecutionReport, JointState
from pfield.sim.simulation import Simulation

__all__ = ["MENAGERIE_GAINS", "ContactTally", "ExecutionReport", "JointState", "ServoGains", "SimModel", "Simulation",
           "build_model", "menagerie_gains", "render_frame"]
