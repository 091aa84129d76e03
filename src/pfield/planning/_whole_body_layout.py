"""What Python packs for the compiled whole-body core (``src/core/planning/whole_body``), and how it reads the result.

* :data:`PARAMS` — the parameter vector (:func:`pfield.planning.whole_body.kernel_parameters` packs it), which the
  core reads as its ``WholeBodyParams`` struct;
* :data:`STEP_OUT` — one step's result row, the core's ``StepResult`` struct field for field, read in Python
  through :class:`StepResult` or the ``OUT_*`` offsets — never by slot number;
* :class:`RobotArrays` / :class:`Scene` — the robot and its obstacles as the arrays the core's ``Robot``,
  ``Obstacles`` and ``Scene`` read in place.

The C++ structs are the layout's truth: tests hold ``PARAMS`` and ``STEP_OUT`` to the offsets the core exports
(tests/planning/test_core_whole_body.py) and the named tuples to their layouts (tests/planning/test_layouts.py).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from pfield._layout import Layout
from pfield.geometry.packed import PackedObstacles

PARAMS = Layout("whole-body parameters", [(name, ()) for name in (
    "attractive_gain", "rotational_attractive_gain", "attractive_threshold", "max_linear_velocity",
    "max_angular_velocity", "influence_distance", "safety_distance", "damper_gain", "repulsive_gain",
    "max_repulsive_force", "dt", "goal_tolerance", "rotation_tolerance", "stagnation_steps", "stagnation_progress",
    "joint_influence", "joint_safety", "rotation_weight", "damping", "null_space_gain")])
"""The kernel's parameter vector, packed by :func:`pfield.planning.whole_body.kernel_parameters`."""
# the slots Python reads or sets by name (tests, the fallback); the core reads the struct
INFLUENCE, XI = PARAMS.index("influence_distance"), PARAMS.index("damper_gain")
DT, TOL, ROT_TOL = PARAMS.index("dt"), PARAMS.index("goal_tolerance"), PARAMS.index("rotation_tolerance")
STAG_STEPS, STAG_PROGRESS = PARAMS.index("stagnation_steps"), PARAMS.index("stagnation_progress")
JOINT_SAFETY, DAMPING = PARAMS.index("joint_safety"), PARAMS.index("damping")
N_PARAMS = PARAMS.size()

STEP_OUT = Layout("whole-body step result", [
    ("twist", (6,)),  # end-effector twist J q̇ (m/s, rad/s), world frame
    ("position", (3,)),  # end-effector position (m)
    ("orientation", (4,)),  # end-effector quaternion (x, y, z, w)
    ("clearance", ()),  # smallest link–obstacle signed distance (m; exact below min(Q, 10 cm), else a lower bound)
    ("self_clearance", ()),  # smallest self pair distance less its start offset (m), inf without pairs
    ("position_error", ()),  # ‖goal − p‖ (m)
    ("rotation_error", ()),  # ‖log(q_goal ⊗ q⁻¹)‖ (rad)
    ("nearest_capsule", ()),  # capsule index of the closest link–obstacle pair (less its offset), −1 if none
    ("nearest_obstacle", ()),  # obstacle index of that pair, −1 if none
    ("nearest_distance", ()),  # that pair's distance less its offset (m; beyond Q a lower bound); < 0: contact
    ("nearest_self_pair", ()),  # index of the closest self pair, −1 if none
])
"""The result row of a whole-body step (the core's ``StepResult``; a stepper's row continues with q̇). Read it
through :class:`StepResult` or these offsets, never by number."""
OUT_TWIST, OUT_POSITION, OUT_ORIENTATION = STEP_OUT.span("twist"), STEP_OUT.span("position"), \
    STEP_OUT.span("orientation")
OUT_CLEARANCE = STEP_OUT.index("clearance")
OUT_SIZE = STEP_OUT.size()


class StepResult(NamedTuple):
    """Typed view of one :data:`STEP_OUT` row (fields = the layout's entries, in order; a test checks it)."""

    twist: NDArray[np.float64]
    position: NDArray[np.float64]
    orientation: NDArray[np.float64]
    clearance: float
    self_clearance: float
    position_error: float
    rotation_error: float
    nearest_capsule: float
    nearest_obstacle: float
    nearest_distance: float
    nearest_self_pair: float

    @classmethod
    def of(cls, row: NDArray[np.float64]) -> StepResult:
        """The view of ``row`` (OUT_SIZE,) — arrays are views into it, scalars floats."""
        return cls._make(STEP_OUT.read(row))


class RobotArrays(NamedTuple):
    """Kinematics (:class:`pfield.robot.model.KinematicArrays`), the link model and limits, packed for the core.

    ``cap_*`` are the links' bounding capsules (index l; ``self_r`` the radii of the ungrown covering
    capsules, for the ``self_pairs`` link pairs), and ``link_start``, ``prim_*`` the fitted primitives of
    each link (:class:`pfield.robot.geometry.RobotGeometry`): link l owns ``link_start[l]:link_start[l + 1]``.
    ``pair_tables``: the self pairs' tables (``pfield._core.robot.PairTables``, made from these arrays by
    :func:`pfield.planning._whole_body_core.pair_tables`), which the global search's state checks ask first, or None.
    """

    parents: NDArray[np.int64]
    place_rot: NDArray[np.float64]
    place_pos: NDArray[np.float64]
    axes: NDArray[np.float64]
    kinds: NDArray[np.int64]
    support: NDArray[np.int64]
    ee_joint: int
    ee_rot: NDArray[np.float64]
    ee_pos: NDArray[np.float64]
    cap_joint: NDArray[np.int64]
    cap_a: NDArray[np.float64]
    cap_b: NDArray[np.float64]
    cap_r: NDArray[np.float64]
    self_pairs: NDArray[np.int64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    max_velocity: NDArray[np.float64]
    max_acceleration: NDArray[np.float64]
    link_start: NDArray[np.int64]
    prim_joint: NDArray[np.int64]
    prim_a: NDArray[np.float64]
    prim_b: NDArray[np.float64]
    prim_r: NDArray[np.float64]
    self_r: NDArray[np.float64]
    pair_tables: object = None


class Scene(NamedTuple):
    """Obstacles, their bounding spheres (centre, radius) for culling far link–obstacle pairs, and offsets.

    The fitted model over-approximates the links, so a valid start can have links closer than
    ``safety_distance`` (or overlapping). ``obstacle_offsets[c, i]`` and ``self_offsets[k]`` (≤ 0, m) are
    subtracted from those pairs' distances: such a pair may not get any closer than it starts, and only that counts as a
    collision (:func:`pfield.planning.whole_body.make_scene`). ``fitted_self``: the self pairs' distances are those
    of the fitted primitives (exact below the need) instead of the links' covering capsules: the global search and
    its tracking (:mod:`pfield.planning.global_search`).
    """

    packed: PackedObstacles
    centres: NDArray[np.float64]  # (M, 3)
    bounds: NDArray[np.float64]  # (M,)
    obstacle_offsets: NDArray[np.float64]  # (L, M)
    self_offsets: NDArray[np.float64]  # (P,)
    fitted_self: bool = False  # self pairs on the fitted primitives, not the covering capsules (the global search)
