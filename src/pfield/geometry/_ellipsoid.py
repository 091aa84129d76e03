"""Exact point–ellipsoid distance (compiled).

The closest point ``x`` on the ellipsoid ``Σ (x_i/e_i)² = 1`` to a point ``y`` satisfies
``x_i = e_i² y_i / (t + e_i²)`` for the Lagrange parameter ``t``, the root of

    F(t) = Σ (e_i y_i / (t + e_i²))² − 1 = 0.

We follow D. Eberly, "Distance from a Point to an Ellipse, an Ellipsoid, or a Hyperellipsoid"
(Geometric Tools, 2013-2020): reflect ``y`` into the first octant, order the axes
``e0 ≥ e1 ≥ e2``, treat points on coordinate planes separately (where the closest point may leave
the plane, for inside points near the smallest axis), and solve the scaled equation
``F(s) = Σ (r_i z_i / (s + r_i))² − 1`` with ``r_i = (e_i/e2)²``, ``z_i = y_i/e_i`` on the bracket
``[z2 − 1, ‖r∘z‖ − 1]`` (or ``[z2 − 1, 0]`` inside), written in ``u = s + 1`` so that roots near
the pole keep their relative precision. ``F`` is convex and decreasing there; we use
Halley's method (cubic convergence, ~3 steps) kept inside the shrinking bracket, falling back to
bisection (geometric while the bracket spans orders of magnitude, since u > 0) whenever a step
leaves it, so the solve is as robust as Eberly's bisection but faster.
Works for points inside and outside, on the axes and at the centre.
"""

from __future__ import annotations

import math

from numba import njit

_MAX_ITERATIONS = 128
_REL_TOL = 1e-15
_HALLEY_TOL = 1e-9
_NOISE = 1e-15
_FLAT = 1e-100


@njit(cache=True)
def _root(r0: float, r1: float, z0: float, z1: float, z2: float, g: float) -> float:
    """Root u = s + 1 > 0 of Σ (n_i / (u + c_i))² − 1, n = (r0 z0, r1 z1, z2), c = (r0 − 1, r1 − 1, 0).

    Solving for u instead of s keeps full relative precision when the root is near the pole
    s = −1 (points near the centre of a sphere-like ellipsoid); set z1 = 0 for the 2D problem.
    """
    n0, n1 = r0 * z0, r1 * z1
    c0, c1 = r0 - 1.0, r1 - 1.0
    lo = z2
    hi = 1.0 if g < 0.0 else math.sqrt(n0 * n0 + n1 * n1 + z2 * z2)
    u = hi
    for _ in range(_MAX_ITERATIONS):
        i0, i1, i2 = 1.0 / (u + c0), 1.0 / (u + c1), 1.0 / u
        a0, a1, a2 = n0 * i0, n1 * i1, z2 * i2
        f = a0 * a0 + a1 * a1 + a2 * a2 - 1.0
        if abs(f) <= _NOISE:  # F is at its rounding-noise floor: u is the root to machine precision
            return u
        if f > 0.0:
            lo = u
        else:
            hi = u
        b0, b1, b2 = a0 * a0 * i0, a1 * a1 * i1, a2 * a2 * i2
        df = -2.0 * (b0 + b1 + b2)
        ddf = 6.0 * (b0 * i0 + b1 * i1 + b2 * i2)
        nxt = u - 2.0 * f * df / (2.0 * df * df - f * ddf)  # Halley's step
        if lo < nxt < hi:
            if abs(nxt - u) <= _HALLEY_TOL * u:  # cubic convergence: the error after this step is ~tol³
                return nxt
        else:
            # Bisect; geometrically while the bracket spans orders of magnitude (roots near u = z2 ≪ 1).
            nxt = math.sqrt(lo * hi) if hi > 4.0 * lo else 0.5 * (lo + hi)
        if hi - lo <= _REL_TOL * hi:
            return nxt
        u = nxt
    return u


@njit(cache=True)
def _closest_ellipse(e0: float, e1: float, y0: float, y1: float) -> tuple[float, float]:
    """Closest point on the ellipse (e0 ≥ e1) to (y0, y1) ≥ 0 (Eberly, Listing 2)."""
    if y1 > 0.0:
        if y0 > 0.0:
            z0, z1 = y0 / e0, y1 / e1
            g = z0 * z0 + z1 * z1 - 1.0
            if g == 0.0:
                return y0, y1
            r0 = (e0 / e1) ** 2
            u = _root(r0, 1.0, z0, 0.0, z1, g)
            return r0 * y0 / (u + (r0 - 1.0)), y1 / u
        return 0.0, e1
    denom0 = e0 * e0 - e1 * e1
    numer0 = e0 * y0
    if numer0 < denom0:
        xde0 = numer0 / denom0
        return e0 * xde0, e1 * math.sqrt(1.0 - xde0 * xde0)
    return e0, 0.0


@njit(cache=True)
def _closest_sorted(e0: float, e1: float, e2: float, y0: float, y1: float, y2: float) -> tuple[float, float, float]:
    """Closest point on the ellipsoid (e0 ≥ e1 ≥ e2) to y ≥ 0 componentwise (Eberly, Listing 5)."""
    if y2 > 0.0:
        if y1 > 0.0:
            if y0 > 0.0:
                z0, z1, z2 = y0 / e0, y1 / e1, y2 / e2
                g = z0 * z0 + z1 * z1 + z2 * z2 - 1.0
                if g == 0.0:
                    return y0, y1, y2
                r0, r1 = (e0 / e2) ** 2, (e1 / e2) ** 2
                u = _root(r0, r1, z0, z1, z2, g)
                return r0 * y0 / (u + (r0 - 1.0)), r1 * y1 / (u + (r1 - 1.0)), y2 / u
            x1, x2 = _closest_ellipse(e1, e2, y1, y2)
            return 0.0, x1, x2
        if y0 > 0.0:
            x0, x2 = _closest_ellipse(e0, e2, y0, y2)
            return x0, 0.0, x2
        return 0.0, 0.0, e2
    denom0, denom1 = e0 * e0 - e2 * e2, e1 * e1 - e2 * e2
    numer0, numer1 = e0 * y0, e1 * y1
    if numer0 < denom0 and numer1 < denom1:
        xde0, xde1 = numer0 / denom0, numer1 / denom1
        discr = 1.0 - xde0 * xde0 - xde1 * xde1
        if discr > 0.0:
            return e0 * xde0, e1 * xde1, e2 * math.sqrt(discr)
    x0, x1 = _closest_ellipse(e0, e1, y0, y1)
    return x0, x1, 0.0


@njit(cache=True, inline="always")  # inlined: no separate compile per literal axis index (0, 1, 2, int)
def _pick(k: int, a: float, b: float, c: float) -> float:
    if k == 0:
        return a
    if k == 1:
        return b
    return c


@njit(cache=True)
def _descending_order(a: float, b: float, c: float) -> tuple[int, int, int]:
    """Axis indices sorted by decreasing semi-axis; equal axes keep x, y, z order."""
    i0, i1, i2 = 0, 1, 2
    if _pick(i1, a, b, c) > _pick(i0, a, b, c):
        i0, i1 = i1, i0
    if _pick(i2, a, b, c) > _pick(i1, a, b, c):
        i1, i2 = i2, i1
        if _pick(i1, a, b, c) > _pick(i0, a, b, c):
            i0, i1 = i1, i0
    return i0, i1, i2


@njit(cache=True)
def ellipsoid_signed_distance(
    qx: float, qy: float, qz: float, a: float, b: float, c: float
) -> tuple[float, float, float, float]:
    """Signed distance and outward unit normal (local frame) of ``q`` to the ellipsoid with semi-axes a, b, c.

    ``d = ±‖q − x‖`` (negative inside); the normal is the surface normal at the closest point x,
    ∝ (x/a², y/b², z/c²), which equals ∇d inside and outside and is defined on the surface.
    Ties (points on a symmetry plane whose closest points are mirror images) take the +side.
    """
    sx = 1.0 if qx >= 0.0 else -1.0
    sy = 1.0 if qy >= 0.0 else -1.0
    sz = 1.0 if qz >= 0.0 else -1.0
    # Coordinates below 1e-100 of their semi-axis are treated as on the plane: the root solve
    # would otherwise run through denormals (the error is < 1e-100 m).
    ya = abs(qx) if abs(qx) > _FLAT * a else 0.0
    yb = abs(qy) if abs(qy) > _FLAT * b else 0.0
    yc = abs(qz) if abs(qz) > _FLAT * c else 0.0
    i0, i1, i2 = _descending_order(a, b, c)
    x0, x1, x2 = _closest_sorted(
        _pick(i0, a, b, c), _pick(i1, a, b, c), _pick(i2, a, b, c),
        _pick(i0, ya, yb, yc), _pick(i1, ya, yb, yc), _pick(i2, ya, yb, yc),
    )
    xa = x0 if i0 == 0 else (x1 if i1 == 0 else x2)
    xb = x0 if i0 == 1 else (x1 if i1 == 1 else x2)
    xc = x0 if i0 == 2 else (x1 if i1 == 2 else x2)
    dist = math.sqrt((ya - xa) ** 2 + (yb - xb) ** 2 + (yc - xc) ** 2)
    if (ya / a) ** 2 + (yb / b) ** 2 + (yc / c) ** 2 < 1.0:
        dist = -dist
    nx, ny, nz = sx * xa / (a * a), sy * xb / (b * b), sz * xc / (c * c)
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    return dist, nx / norm, ny / norm, nz / norm
