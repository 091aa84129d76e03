"""Helpers for the geometry tests: data paths, random poses and independent reference distances.

The references are written independently of the compiled kernels (clamping / projection formulas in
numpy, numerical minimisation for the ellipsoid) so that agreement is evidence, not tautology.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from pfield.spatial import Pose

DATA = Path(__file__).resolve().parents[1] / "data"
MESHES = DATA / "meshes"
PACKAGE = DATA / "my_robot_description"


def random_pose(rng: np.random.Generator, spread: float = 1.0) -> Pose:
    """A pose with a uniformly random rotation (normalised Gaussian quaternion) and position."""
    quaternion = rng.normal(size=4)
    return Pose(rng.uniform(-spread, spread, 3), quaternion / np.linalg.norm(quaternion))


def to_local(pose: Pose, points: NDArray[np.float64]) -> NDArray[np.float64]:
    return (points - pose.position) @ pose.rotation


def box_reference(q: NDArray[np.float64], half: NDArray[np.float64]) -> NDArray[np.float64]:
    """Outside: distance to the clamped point; inside: minus the distance to the nearest face."""
    clamped = np.clip(q, -half, half)
    outside = np.linalg.norm(q - clamped, axis=1)
    depth = np.min(half - np.abs(q), axis=1)
    return np.where(np.any(np.abs(q) > half, axis=1), outside, -depth)


def cylinder_reference(q: NDArray[np.float64], radius: float, half_height: float) -> NDArray[np.float64]:
    """The clamp construction in the (ρ, z) half-plane."""
    rho, z = np.hypot(q[:, 0], q[:, 1]), q[:, 2]
    closest_rho = np.minimum(rho, radius)
    closest_z = np.clip(z, -half_height, half_height)
    outside = np.hypot(rho - closest_rho, z - closest_z)
    inside = (rho <= radius) & (np.abs(z) <= half_height)
    depth = np.minimum(radius - rho, half_height - np.abs(z))
    return np.where(inside, -depth, outside)


def capsule_reference(q: NDArray[np.float64], radius: float, half_height: float) -> NDArray[np.float64]:
    """Distance to the axis segment, minus the radius."""
    a, b = np.array([0.0, 0.0, -half_height]), np.array([0.0, 0.0, half_height])
    t = np.clip((q - a) @ (b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return np.linalg.norm(q - (a + t[:, None] * (b - a)), axis=1) - radius


def ellipsoid_reference(q: NDArray[np.float64], semi: NDArray[np.float64]) -> float:
    """Signed distance by minimising ‖x(θ, φ) − q‖² over the surface parametrisation.

    A 96 × 48 grid of (θ, φ) picks the three best starts; Nelder–Mead refines each.
    """

    def surface(theta: NDArray[np.float64], phi: NDArray[np.float64]) -> NDArray[np.float64]:
        return semi * np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], axis=-1)

    theta, phi = np.meshgrid(np.linspace(0, 2 * np.pi, 96, endpoint=False), np.linspace(0, np.pi, 48))
    grid = np.sum((surface(theta, phi) - q) ** 2, axis=-1).ravel()
    starts = np.argsort(grid)[:3]
    best = min(
        (minimize(lambda u: float(np.sum((surface(u[0], u[1]) - q) ** 2)),
                  np.array([theta.ravel()[k], phi.ravel()[k]]), method="Nelder-Mead",
                  options={"xatol": 1e-12, "fatol": 1e-22, "maxiter": 2000}) for k in starts),
        key=lambda result: result.fun,
    )
    distance = float(np.sqrt(best.fun))
    return -distance if np.sum((q / semi) ** 2) < 1.0 else distance


def triangle_distance_reference(triangles: NDArray[np.float64], p: NDArray[np.float64]) -> float:
    """Unsigned point–mesh distance by projection onto each triangle's plane, else its three edges."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    height = np.einsum("ij,ij->i", p - a, normal)
    projected = p - height[:, None] * normal
    inside = np.ones(len(triangles), dtype=bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, projected - u), normal) >= 0.0
    best = np.where(inside, np.abs(height), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        t = np.clip(np.einsum("ij,ij->i", p - u, v - u) / np.einsum("ij,ij->i", v - u, v - u), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(p - (u + t[:, None] * (v - u)), axis=1))
    return float(best.min())


def winding_number(triangles: NDArray[np.float64], p: NDArray[np.float64]) -> float:
    """Generalised winding number (Van Oosterom & Strackee solid angles / 4π): 1 inside, 0 outside."""
    a, b, c = triangles[:, 0] - p, triangles[:, 1] - p, triangles[:, 2] - p
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    numerator = np.einsum("ij,ij->i", a, np.cross(b, c))
    denominator = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la
                   + np.einsum("ij,ij->i", c, a) * lb)
    return float(np.sum(2.0 * np.arctan2(numerator, denominator)) / (4.0 * np.pi))


def finite_difference_gradient(function, point: NDArray[np.float64], step: float = 1e-6) -> NDArray[np.float64]:  # type: ignore[no-untyped-def]
    """Central differences of a scalar function of a 3D point."""
    return np.array([(function(point + step * e) - function(point - step * e)) / (2 * step) for e in np.eye(3)])
