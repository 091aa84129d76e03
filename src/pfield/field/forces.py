"""The force and limit laws of the 3D potential field, one call at a time (the compiled core's laws).

The laws live in ``src/core/field/forces.hpp``, which the field, the whole-body planner and the assistance
evaluate inside their loops; these functions call the same code from Python (``pfield._core.field``), so a law
evaluated here gives the bits the planners compute. Floats in, floats or tuples out; vectors in the world frame,
SI units.

Laws (see ``docs/field.md`` for the reasoning):

* attraction, quadratic within Γ and conical beyond (Choset et al. 2005, §4.1, eqs. 4.2–4.3):
  F = −k (p − g) for ‖p − g‖ ≤ Γ, F = −k Γ (p − g)/‖p − g‖ beyond — continuous in value and direction;
* Khatib repulsion magnitude m = η (1/d − 1/Q)/d² for 0 < d < Q (Khatib 1986, eq. 19), saturated smoothly
  as m / √(1 + (m/F_cap)²), equal to F_cap for d ≤ 0;
* velocity dampers (Faverjon & Tournassoud 1987; Haviland & Corke 2021, NEO, eq. 20): the approach speed
  toward an obstacle is at most ξ v_max (d − d_s)/(Q − d_s), capped in one of two ways —
  :func:`damper_speed` / :func:`stepped_damper_speed` say why there are two;
* soft saturation v ← v_max · tanh(‖v‖/v_max) · v/‖v‖ (the twist's rate limits ‖v − v_prev‖ ≤ a_max · dt are
  ``pfield._core.field.rate_limit`` and ``braking_rate_limit``).

A division by zero (parameters out of their ranges, e.g. ``influence == safety``) gives inf or NaN, as in the
core's loops; :class:`~pfield.field.FieldConfig` validates the parameters the planners use.
"""

from __future__ import annotations

from pfield._core import field as _laws

__all__ = [
    "attraction",
    "damper_speed",
    "deflect",
    "khatib_magnitude",
    "project_damper",
    "soft_saturate",
    "stepped_damper_speed",
]


def attraction(ex: float, ey: float, ez: float, gain: float, threshold: float) -> tuple[float, float, float]:
    """Attractive force (N) for the goal error e = g − p (m): k e within Γ = ``threshold``, k Γ e/‖e‖ beyond.

    Both branches give k Γ ê at ‖e‖ = Γ, so the force is continuous in value and direction.
    """
    return _laws.attraction(ex, ey, ez, gain, threshold)  # type: ignore[no-any-return]


def khatib_magnitude(distance: float, gain: float, influence: float, cap: float) -> float:
    """Saturated Khatib repulsion magnitude (N) at signed distance ``distance`` (m).

    m = η (1/d − 1/Q)/d² for 0 < d < Q, 0 for d ≥ Q; returned as m / √(1 + (m/F_cap)²), which is smooth,
    increasing in m, below F_cap, equal to m (1 − ½ (m/F_cap)² + …) for m ≪ F_cap, tends to F_cap as d → 0
    and is F_cap for d ≤ 0 (inside the obstacle). The algebraic form costs a square root where tanh would
    cost a libm call; both are smooth saturations.
    """
    return _laws.khatib_magnitude(distance, gain, influence, cap)  # type: ignore[no-any-return]


def soft_saturate(x: float, y: float, z: float, limit: float) -> tuple[float, float, float]:
    """v ← limit · tanh(‖v‖/limit) · v/‖v‖: the same direction, a norm always below ``limit`` (v itself when
    ‖v‖ < 1e-12)."""
    return _laws.soft_saturate(x, y, z, limit)  # type: ignore[no-any-return]


def damper_speed(
    distance: float, influence: float, safety: float, gain: float, max_speed: float, max_acceleration: float
) -> float:
    """Largest allowed approach speed (m/s) toward an obstacle at ``distance`` (task space).

    s = ξ (d − d_s)/(Q − d_s) with ξ = ``gain`` (m/s), capped by √(a_max (d − d_s)): the speed from which
    half the acceleration limit stops within the margin, leaving the other half for a second obstacle
    or for turning, so a rate-limited twist can still stop before d_s. Negative below d_s (the twist must
    move away), never below −``max_speed``. Only meaningful for d < Q. The acceleration cap is what a
    rate-limited twist needs (the core's braking rate limit can only brake at a_max); for velocities that are
    not rate-limited near obstacles see :func:`stepped_damper_speed`.
    """
    return _laws.damper_speed(distance, influence, safety, gain, max_speed,  # type: ignore[no-any-return]
                              max_acceleration)


def stepped_damper_speed(distance: float, influence: float, safety: float, max_speed: float, dt: float) -> float:
    """Largest allowed approach speed (m/s or rad/s) at ``distance`` for a step of ``dt`` s (whole body).

    s = min(v (d − d_s)/(Q − d_s), (d − d_s)/(2 dt)) with v = ``max_speed`` (ξ v_max for link points, the
    joint's velocity limit for joint-limit dampers); below d_s the required retreat
    max((d − d_s)/(2 dt), −v). Why not :func:`damper_speed`: the whole-body QP's rows constrain joint
    velocities that are applied for one step and whose rate limit is *dropped* when it would break a
    damper (safety first), so no braking distance is needed; what must hold is the discrete step — a link
    moving at s for dt covers at most half of its margin, so d_s is approached geometrically and never
    crossed by a step. The twist of the task-space field keeps its rate limit, so it needs the braking cap.
    Only meaningful for d < Q.
    """
    return _laws.stepped_damper_speed(distance, influence, safety, max_speed, dt)  # type: ignore[no-any-return]


def deflect(
    vx: float, vy: float, vz: float,
    nx: float, ny: float, nz: float,
    cx: float, cy: float, cz: float,
    allowed: float, circulation: float,
) -> tuple[float, float, float, bool]:
    """Enforce the damper n·v ≥ −``allowed`` and turn the removed approach speed into tangential motion.

    With a = −n·v the approach speed and e = a − s its excess, the twist becomes −s n + t τ: the normal
    part is exactly the allowed approach, t = √(‖v‖² − s²) keeps the speed, and τ is the direction of
    P_n v − λ min(0, P_n v·t̂) t̂ + κ e t with t = n × c: the projection of v on the tangent plane (the
    short way around) plus a circulation about the obstacle's fixed axis c that decides head-on cases
    consistently. The part of P_n v that pulls against the circulation is dropped in proportion
    λ = min(1, 2e/‖v‖) to how hard the approach is blocked, so a point pressed onto a wide face keeps
    sliding to its edge instead of settling where the pull back balances the circulation. At e = 0
    the result equals v, so the map is continuous. Returns (v', active).
    """
    return _laws.deflect(vx, vy, vz, nx, ny, nz, cx, cy, cz, allowed, circulation)  # type: ignore[no-any-return]


def project_damper(
    vx: float, vy: float, vz: float, nx: float, ny: float, nz: float, allowed: float
) -> tuple[float, float, float, bool]:
    """The nearest twist with approach speed −n·v ≤ ``allowed`` (projection onto the damper's half-space).

    Used after :func:`deflect` when several dampers bind: alternating projections onto the half-spaces
    converge to their intersection (von Neumann / Bregman), and a projection never adds speed along
    the tangent plane. Returns (v', changed).
    """
    return _laws.project_damper(vx, vy, vz, nx, ny, nz, allowed)  # type: ignore[no-any-return]
