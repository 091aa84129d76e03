"""A picture of the simulation: MuJoCo's offscreen renderer (EGL, or OSMesa with ``MUJOCO_GL=osmesa``) into a PNG.

Without a display, :mod:`pfield.sim.model` sets ``MUJOCO_GL=egl`` before MuJoCo is imported (unless the caller set
it). Robot geometry is drawn light grey (the collision meshes the contacts are computed on), obstacles orange and
translucent; ``trail`` (N, 3) points, e.g. a plan's end-effector path, are drawn as small blue spheres.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._validation import as_points, as_vector, positive
from pfield.errors import InvalidInput
from pfield.sim.model import GEOM_OBSTACLE, GEOM_ROBOT, mujoco
from pfield.sim.simulation import Simulation

__all__ = ["PIXELS", "render_frame"]

PIXELS = (16, 4096)
"""The range of a picture's width and height (pixels)."""

_TRAIL_RGBA = np.array([0.15, 0.45, 0.95, 1.0], dtype=np.float32)


def _framing(sim: Simulation) -> tuple[NDArray[np.float64], float]:
    """(centre, distance) of a camera that frames the robot and the obstacles: the centre of the box around their
    geoms' bounding spheres, and the distance at which MuJoCo's 45° field of view holds the sphere around that box
    (its half diagonal / sin 22.5°, at least 0.5 m)."""
    model, data = sim.model, sim.data
    shown = np.isin(sim.sim_model.geom_kind, (GEOM_ROBOT, GEOM_OBSTACLE)) & (model.geom_rbound > 0.0)
    centres, radii = data.geom_xpos[shown], model.geom_rbound[shown][:, None]
    low, high = (centres - radii).min(axis=0), (centres + radii).max(axis=0)
    return 0.5 * (low + high), max(0.5, 0.5 * float(np.linalg.norm(high - low)) / math.sin(math.radians(22.5)))


def render_frame(sim: Simulation, output: str | Path, *, width: int = 800, height: int = 600,
                 lookat: ArrayLike | None = None, distance: float | None = None, azimuth: float = 135.0,
                 elevation: float = -25.0, trail: ArrayLike | None = None) -> Path:
    """Render the simulation's current state to the PNG ``output`` (its folder is created) and return its path.

    The free camera looks at ``lookat`` (m, world frame) from ``distance`` (m) at ``azimuth`` and ``elevation``
    (degrees, MuJoCo's convention); by default it frames the robot and the obstacles (the centre of the box around
    them, from where the view holds it), whatever the robot's size and where it stands. Raises
    :class:`~pfield.errors.InvalidInput` for bad sizes, and :class:`RuntimeError` from MuJoCo when no OpenGL backend
    works (install libegl1 or libosmesa6).
    """
    if not isinstance(sim, Simulation):
        raise InvalidInput("sim", sim, "expected a pfield.sim.Simulation")
    for name, value in (("width", width), ("height", height)):
        if not isinstance(value, int) or not PIXELS[0] <= value <= PIXELS[1]:
            raise InvalidInput(name, value, f"expected a whole number of pixels in [{PIXELS[0]}, {PIXELS[1]}]")
    points = None if trail is None else as_points("trail", trail)
    camera = mujoco.MjvCamera()
    centre, reach = _framing(sim)
    camera.lookat[:] = centre if lookat is None else as_vector("lookat", lookat, 3)
    camera.distance = reach if distance is None else positive("distance", distance)
    camera.azimuth, camera.elevation = float(azimuth), float(elevation)
    model = sim.model
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    with mujoco.Renderer(model, height, width) as renderer:
        renderer.update_scene(sim.data, camera=camera)
        scene = renderer.scene
        for point in ([] if points is None else points):
            if scene.ngeom >= scene.maxgeom:
                break
            mujoco.mjv_initGeom(scene.geoms[scene.ngeom], mujoco.mjtGeom.mjGEOM_SPHERE, np.array([0.006, 0, 0]),
                                np.asarray(point, dtype=np.float64), np.eye(3).reshape(-1), _TRAIL_RGBA)
            scene.ngeom += 1
        pixels = renderer.render()
    from PIL import Image

    target = Path(output)
    target.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(pixels).save(target)
    return target
