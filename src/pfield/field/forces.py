"""Compiled force and limit laws of the 3D potential field (the functional core; numba, ``cache=True``).

Every kernel takes and returns plain floats (tuples for vectors), allocates nothing, and is meant to be
called from other compiled code: the whole-body planner and the assistance. The task-space field and its
planning loop run in the compiled core, whose ``src/core/field/forces.hpp`` holds the same laws in the same
operation order (the same bits) until these kernels move there too. All vectors are in the world frame, SI units.

Laws (see ``docs/field.md`` for the reasoning):

* attraction, quadratic within Γ and conical beyond (Choset et al. 2005, §4.1, eqs. 4.2–4.3):
  F = −k (p − g) for ‖p − g‖ ≤ Γ, F = −k Γ (p − g)/‖p − g‖ beyond — continuous in value and direction;
* rotational attraction τ = k_rot · log(q_g ⊗ q⁻¹), the world-frame rotation vector of the error
  (:func:`pfield._spatial_kernels.rotation_error`; Sola et al. 2018, "A micro Lie theory", eq. 26);
* Khatib repulsion magnitude m = η (1/d − 1/Q)/d² for 0 < d < Q (Khatib 1986, eq. 19), saturated smoothly
  as m / √(1 + (m/F_cap)²), equal to F_cap for d ≤ 0;
* velocity dampers (Faverjon & Tournassoud 1987; Haviland & Corke 2021, NEO, eq. 20): the approach speed
  toward an obstacle is at most ξ v_max (d − d_s)/(Q − d_s), capped in one of two ways — this module
  is their one home, and :func:`damper_speed` / :func:`stepped_damper_speed` say why there are two;
* soft saturation v ← v_max · tanh(‖v‖/v_max) · v/‖v‖ (the twist's rate limits ‖v − v_prev‖ ≤ a_max · dt live in
  the core alone, ``src/core/field/forces.hpp``: no numba kernel uses them any more).
"""

from __future__ import annotations

import math

from numba import njit

__all__ = [
    "attraction",
    "damper_speed",
    "deflect",
    "khatib_magnitude",
    "project_damper",
    "soft_saturate",
    "stepped_damper_speed",
]

_TINY = 1e-12


@njit(cache=True)
def attraction(ex: float, ey: float, ez: float, gain: float, threshold: float) -> tuple[float, float, float]:
    """Attractive force (N) for the goal error e = g − p (m): k e within Γ = ``threshold``, k Γ e/‖e‖ beyond.

    Both branches give k Γ ê at ‖e‖ = Γ, so the force is continuous in value and direction.
    """
    distance = math.sqrt(ex * ex + ey * ey + ez * ez)
    scale = gain if distance <= threshold else gain * threshold / distance
    return scale * ex, scale * ey, scale * ez


@njit(cache=True)
def khatib_magnitude(distance: float, gain: float, influence: float, cap: float) -> float:
    """Saturated Khatib repulsion magnitude (N) at signed distance ``distance`` (m).

    m = η (1/d − 1/Q)/d² for 0 < d < Q, 0 for d ≥ Q; returned as m / √(1 + (m/F_cap)²), which is smooth,
    increasing in m, below F_cap, equal to m (1 − ½ (m/F_cap)² + …) for m ≪ F_cap, tends to F_cap as d → 0
    and is F_cap for d ≤ 0 (inside the obstacle). The algebraic form costs a square root where tanh would
    cost a libm call; both are smooth saturations.
    """
    if distance >= influence:
        return 0.0
    if distance <= 0.0:
        return cap
    raw = gain * (1.0 / distance - 1.0 / influence) / (distance * distance)
    ratio = raw / cap
    return raw / math.sqrt(1.0 + ratio * ratio)


@njit(cache=True)
def soft_saturate(x: float, y: float, z: float, limit: float) -> tuple[float, float, float]:
    """v ← limit · tanh(‖v‖/limit) · v/‖v‖: the same direction, a norm always below ``limit``."""
    norm = math.sqrt(x * x + y * y + z * z)
    if norm < _TINY:
        return x, y, z
    scale = limit * math.tanh(norm / limit) / norm
    return scale * x, scale * y, scale * z


@njit(cache=True)
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
    margin = distance - safety
    speed = gain * margin / (influence - safety)
    if margin > 0.0:
        speed = min(speed, math.sqrt(max_acceleration * margin))
    return max(speed, -max_speed)


@njit(cache=True, inline="always")
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
    margin = distance - safety
    if margin <= 0.0:
        return max(0.5 * margin / dt, -max_speed)
    return min(max_speed * margin / (influence - safety), 0.5 * margin / dt)


@njit(cache=True)
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
    normal_speed = vx * nx + vy * ny + vz * nz
    excess = -normal_speed - allowed
    if excess <= 0.0:
        return vx, vy, vz, False
    px, py, pz = vx - normal_speed * nx, vy - normal_speed * ny, vz - normal_speed * nz
    tx, ty, tz = ny * cz - nz * cy, nz * cx - nx * cz, nx * cy - ny * cx
    speed_sq = vx * vx + vy * vy + vz * vz
    t_sq = tx * tx + ty * ty + tz * tz
    against = px * tx + py * ty + pz * tz
    if against < 0.0 and t_sq > _TINY:
        share = 1.0 if 2.0 * excess * excess >= 0.5 * speed_sq else 2.0 * excess / math.sqrt(speed_sq)
        drop = share * against / t_sq
        px, py, pz = px - drop * tx, py - drop * ty, pz - drop * tz
    weight = circulation * excess
    wx, wy, wz = px + weight * tx, py + weight * ty, pz + weight * tz
    w_norm = math.sqrt(wx * wx + wy * wy + wz * wz)
    tangential = math.sqrt(max(speed_sq - allowed * allowed, 0.0))
    ox, oy, oz = -allowed * nx, -allowed * ny, -allowed * nz
    if w_norm > _TINY:
        scale = tangential / w_norm
        ox, oy, oz = ox + scale * wx, oy + scale * wy, oz + scale * wz
    return ox, oy, oz, True


@njit(cache=True)
def project_damper(
    vx: float, vy: float, vz: float, nx: float, ny: float, nz: float, allowed: float
) -> tuple[float, float, float, bool]:
    """The nearest twist with approach speed −n·v ≤ ``allowed`` (projection onto the damper's half-space).

    Used after :func:`deflect` when several dampers bind: alternating projections onto the half-spaces
    converge to their intersection (von Neumann / Bregman), and a projection never adds speed along
    the tangent plane. Returns (v', changed).
    """
    excess = -(vx * nx + vy * ny + vz * nz) - allowed
    if excess <= 0.0:
        return vx, vy, vz, False
    return vx + excess * nx, vy + excess * ny, vz + excess * nz, True


