"""Mobile base: the seed's 2D vector-field controller (field, clamping, scans, controller, simulation).

Functional API (DESIGN §3.5)::

    from pfield.mobile import VectorFieldParams, potential, gradient, velocity
    params = VectorFieldParams(ka=3.0, kr_dist=0.8, kr_height=1.0, kr_slope=30.0,
                               min_spd_norm=0.1, max_spd_norm=1.0, goal_tolerance=0.1, attraction="power")
    potential(points, goal, obstacles, params)   # (N, 2), (2,) or None, (M, 2) -> (N,)
    gradient(points, goal, obstacles, params)    # ∇V, unclamped -> (N, 2)
    velocity(points, goal, obstacles, params)    # the clamped command -> (N, 2)

The controller (:class:`BaseController` with :class:`ControllerConfig`), scan conversion
(:func:`scan_obstacles`) and the simulation (:mod:`pfield.mobile.sim`) build on these kernels.
"""

from pfield.mobile.config import ControllerConfig
from pfield.mobile.controller import BaseController, Command2D, ControllerState
from pfield.mobile.field2d import FieldComponents, field_components, gradient, potential, velocity
from pfield.mobile.params import VectorFieldParams
from pfield.mobile.scan import ObstaclePoints, point_obstacles, scan_obstacles, scan_ranges_obstacles

__all__ = [
    "BaseController",
    "Command2D",
    "ControllerConfig",
    "ControllerState",
    "FieldComponents",
    "ObstaclePoints",
    "VectorFieldParams",
    "field_components",
    "gradient",
    "point_obstacles",
    "potential",
    "scan_obstacles",
    "scan_ranges_obstacles",
    "velocity",
]
