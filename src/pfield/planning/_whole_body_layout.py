"""The packed structures of the whole-body kernels, each described once by a (name, shape) spec.

* :data:`PARAMS` — the parameter vector (:func:`pfield.planning.whole_body.kernel_parameters` packs it);
* :data:`STEP_OUT` — one step's result row ``ws.out``, read through the ``OUT_*`` offsets in compiled code
  and through :class:`StepResult` in Python — never by slot number;
* :class:`RobotArrays` / :class:`Scene` with :data:`ROBOT_FLOATS`, :data:`ROBOT_INTS`, :data:`SCENE_FLOATS`
  — the robot and the scene as flat buffers for the low-overhead entry of :mod:`._whole_body_flat`;
* :class:`Workspace` with :data:`WORKSPACE` — the scratch arrays of a step, carved from one buffer.

The compiled views (:func:`robot_views`, :func:`scene_views`, :func:`workspace_views`) and the
reference-count-free copies (:func:`unowned_robot`, :func:`unowned_scene`, :func:`unowned_workspace`) are
generated from these specs (:func:`pfield._layout.compile_views`, :func:`pfield._layout.compile_unowned`),
and tests check that every named tuple has exactly its layout's entries.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from pfield._layout import Layout, compile_allocation, compile_unowned, compile_views
from pfield.field._unowned import unowned, unowned_int, unowned_packed
from pfield.geometry._packed import PackedObstacles

PARAMS = Layout("whole-body parameters", [(name, ()) for name in (
    "attractive_gain", "rotational_attractive_gain", "attractive_threshold", "max_linear_velocity",
    "max_angular_velocity", "influence_distance", "safety_distance", "damper_gain", "repulsive_gain",
    "max_repulsive_force", "dt", "goal_tolerance", "rotation_tolerance", "stagnation_steps", "stagnation_progress",
    "joint_influence", "joint_safety", "rotation_weight", "damping", "null_space_gain")])
"""The kernel's parameter vector, packed by :func:`pfield.planning.whole_body.kernel_parameters`."""
K_ATT, K_ROT, GAMMA = PARAMS.index("attractive_gain"), PARAMS.index("rotational_attractive_gain"), \
    PARAMS.index("attractive_threshold")
V_MAX, W_MAX = PARAMS.index("max_linear_velocity"), PARAMS.index("max_angular_velocity")
INFLUENCE, SAFETY, XI = PARAMS.index("influence_distance"), PARAMS.index("safety_distance"), PARAMS.index("damper_gain")
ETA, F_CAP = PARAMS.index("repulsive_gain"), PARAMS.index("max_repulsive_force")
DT, TOL, ROT_TOL = PARAMS.index("dt"), PARAMS.index("goal_tolerance"), PARAMS.index("rotation_tolerance")
STAG_STEPS, STAG_PROGRESS = PARAMS.index("stagnation_steps"), PARAMS.index("stagnation_progress")
JOINT_INFLUENCE, JOINT_SAFETY = PARAMS.index("joint_influence"), PARAMS.index("joint_safety")
ROT_WEIGHT, DAMPING, NULL_GAIN = PARAMS.index("rotation_weight"), PARAMS.index("damping"), \
    PARAMS.index("null_space_gain")
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
"""The result row of :func:`joint_velocity_step` (``ws.out``). Read it through these offsets in compiled
code and through :class:`StepResult` in Python, never by number."""
OUT_TWIST, OUT_POSITION, OUT_ORIENTATION = STEP_OUT.span("twist"), STEP_OUT.span("position"), \
    STEP_OUT.span("orientation")
OUT_CLEARANCE, OUT_SELF_CLEARANCE = STEP_OUT.index("clearance"), STEP_OUT.index("self_clearance")
OUT_POSITION_ERROR, OUT_ROTATION_ERROR = STEP_OUT.index("position_error"), STEP_OUT.index("rotation_error")
OUT_NEAREST_CAPSULE, OUT_NEAREST_OBSTACLE = STEP_OUT.index("nearest_capsule"), STEP_OUT.index("nearest_obstacle")
OUT_NEAREST_DISTANCE, OUT_NEAREST_SELF_PAIR = STEP_OUT.index("nearest_distance"), STEP_OUT.index("nearest_self_pair")
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
    """Kinematics (see :mod:`pfield.robot._kinematics`), the link model and limits, packed for the kernel.

    ``cap_*`` are the links' bounding capsules (index l; ``self_r`` the radii of the ungrown covering
    capsules, for the ``self_pairs`` link pairs), and ``link_start``, ``prim_*`` the fitted primitives of
    each link (:class:`pfield.robot.geometry.RobotGeometry`): link l owns ``link_start[l]:link_start[l + 1]``.
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


ROBOT_FLOATS = Layout("robot floats", [
    ("place_rot", ("n", 3, 3)), ("place_pos", ("n", 3)), ("axes", ("n", 3)), ("ee_rot", (3, 3)), ("ee_pos", (3,)),
    ("cap_a", ("caps", 3)), ("cap_b", ("caps", 3)), ("cap_r", ("caps",)), ("lower", ("n",)), ("upper", ("n",)),
    ("max_velocity", ("n",)), ("max_acceleration", ("n",)), ("prim_a", ("prims", 3)), ("prim_b", ("prims", 3)),
    ("prim_r", ("prims",)), ("self_r", ("caps",))])
ROBOT_INTS = Layout("robot ints", [("parents", ("n",)), ("kinds", ("n",)), ("support", ("n", "n")),
                                   ("cap_joint", ("caps",)), ("self_pairs", ("pairs", 2)), ("link_start", ("starts",)),
                                   ("prim_joint", ("prims",))], dtype=np.int64)
"""The float and int arrays of :class:`RobotArrays` as two flat buffers (``ee_joint`` is passed as is);
``prims`` is the number of fitted primitives and ``starts`` = caps + 1 (the bounds of each link's
primitives)."""


class Scene(NamedTuple):
    """Obstacles, their bounding spheres (centre, radius) for culling far link–obstacle pairs, and offsets.

    The fitted model over-approximates the links, so a valid start can have links closer than
    ``safety_distance`` (or overlapping). ``obstacle_offsets[c, i]`` and ``self_offsets[k]`` (≤ 0, m) are
    subtracted from those pairs' distances: such a pair may not get any closer than it starts, and only that counts as a
    collision (:func:`pfield.planning.whole_body.make_scene`).
    """

    packed: PackedObstacles
    centres: NDArray[np.float64]  # (M, 3)
    bounds: NDArray[np.float64]  # (M,)
    obstacle_offsets: NDArray[np.float64]  # (L, M)
    self_offsets: NDArray[np.float64]  # (P,)


SCENE_FLOATS = Layout("scene floats", [("centres", ("obstacles", 3)), ("bounds", ("obstacles",)),
                                       ("obstacle_offsets", ("caps", "obstacles")), ("self_offsets", ("pairs",))])


class Workspace(NamedTuple):
    """Scratch arrays of one step (fields = :data:`WORKSPACE`'s entries)."""

    rotations: NDArray[np.float64]
    origins: NDArray[np.float64]
    jac: NDArray[np.float64]
    jlin: NDArray[np.float64]
    jlin2: NDArray[np.float64]
    rows: NDArray[np.float64]
    b: NDArray[np.float64]
    hinv: NDArray[np.float64]
    mu: NDArray[np.float64]
    curvature: NDArray[np.float64]
    h: NDArray[np.float64]
    rhs: NDArray[np.float64]
    x: NDArray[np.float64]
    free: NDArray[np.float64]
    seg_a: NDArray[np.float64]
    seg_b: NDArray[np.float64]
    limited: NDArray[np.float64]
    scratch: NDArray[np.float64]
    task: NDArray[np.float64]
    out: NDArray[np.float64]
    prim_seg_a: NDArray[np.float64]
    prim_seg_b: NDArray[np.float64]


WORKSPACE = Layout("whole-body workspace", [
    ("rotations", ("n", 3, 3)), ("origins", ("n", 3)), ("jac", (6, "n")), ("jlin", (3, "n")), ("jlin2", (3, "n")),
    ("rows", ("m", "n")), ("b", ("m",)), ("hinv", ("m", "n")), ("mu", ("m",)), ("curvature", ("m",)),
    ("h", ("n", "n")), ("rhs", ("n",)), ("x", ("n",)), ("free", ("n",)), ("seg_a", ("caps", 3)),
    ("seg_b", ("caps", 3)), ("limited", ("n",)), ("scratch", (2, 3)), ("task", (2, 6)), ("out", (OUT_SIZE,)),
    ("prim_seg_a", ("prims", 3)), ("prim_seg_b", ("prims", 3))])
"""One flat float buffer per step; ``m`` = the most QP rows (caps·obstacles + pairs + 2n), ``prims`` the
fitted primitives (their world segments)."""

robot_views = compile_views("robot_views", RobotArrays, [("floats", ROBOT_FLOATS), ("ints", ROBOT_INTS)],
                            ("n", "caps", "pairs", "prims", "starts"), ("ee_joint",))
scene_views = compile_views("scene_views", Scene, [("floats", SCENE_FLOATS)], ("caps", "obstacles", "pairs"),
                            ("packed",))
workspace_views = compile_views("workspace_views", Workspace, [("work", WORKSPACE)], ("n", "caps", "m", "prims"))


# the same named tuples with every array viewed without an owner, for the top of the compiled loops
_VIEWS = {"unowned": unowned, "unowned_int": unowned_int, "unowned_packed": unowned_packed}
unowned_robot = compile_unowned("unowned_robot", RobotArrays, {"unowned": [ROBOT_FLOATS], "unowned_int": [ROBOT_INTS]},
                                _VIEWS, passthrough=("ee_joint",))
unowned_scene = compile_unowned("unowned_scene", Scene, {"unowned": [SCENE_FLOATS]}, _VIEWS,
                                fields={"packed": "unowned_packed"})
unowned_workspace = compile_unowned("unowned_workspace", Workspace, {"unowned": [WORKSPACE]}, _VIEWS)

_allocate_workspace = compile_allocation("_allocate_workspace", Workspace, WORKSPACE, ("n", "caps", "m", "prims"))


@njit(cache=True)
def make_workspace(n: int, n_capsules: int, n_obstacles: int, n_pairs: int, n_prims: int) -> Workspace:
    """A fresh :class:`Workspace` for n joints, link capsules, obstacles, self pairs and fitted primitives."""
    return _allocate_workspace(n, n_capsules, n_capsules * n_obstacles + n_pairs + 2 * n, n_prims)
