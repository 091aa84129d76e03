"""Simulation scenarios of the 2D controller: the seed's two grid cases, a corridor and a doorway.

The seed's simulation (document 004, "Simulation (Python program)") puts a 5×5 grid of point obstacles at
{−4, −2, 0, 2, 4}², starts the robot at (−6, 0) and sets the goal at (3, 3): with kr_dist 0, kr_height 2,
kr_slope 1 the hills between the points add up and the robot *cannot go through*; with kr_dist −1,
kr_height 3, kr_slope 1, ka 3 they are narrower and it *can go through*. Those two know the obstacle points
exactly (``sensor: points``); the corridor and the doorway see walls through a simulated laser.
A scenario file is YAML with the fields of :class:`Scenario` (``params`` and ``config`` as mappings).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import yaml

from pfield._validation import as_vector, integer, positive
from pfield.errors import InvalidInput, ResourceNotFound
from pfield.mobile.config import ControllerConfig
from pfield.mobile.params import VectorFieldParams
from pfield.mobile.world import World2D

__all__ = ["BUILTIN_SCENARIOS", "Scenario", "load_scenario", "seed_params"]


MAX_STEPS = 1_000_000
"""Steps (duration x rate) a scenario may take at most."""
MAX_LASER_BEAMS = 100_000
"""Beams a simulated laser may have at most."""


@dataclass(frozen=True)
class Scenario:
    """One simulation set-up (world frame, SI units).

    ``sensor``: ``points`` (the controller knows ``world.points`` exactly, as in the seed) or ``laser`` (a
    simulated scan of ``laser_beams`` beams over 360° up to ``laser_range`` m, ray-cast against the world).
    ``expected`` is the documented outcome (``goal_reached`` or ``stuck``); ``extent`` the plot window
    (xmin, xmax, ymin, ymax).
    """

    name: str
    description: str
    world: World2D
    start: tuple[float, float, float]
    goal: tuple[float, float]
    params: VectorFieldParams
    config: ControllerConfig = field(default_factory=ControllerConfig)
    sensor: Literal["points", "laser"] = "points"
    laser_beams: int = 360
    laser_range: float = 5.0
    robot_radius: float = 0.2
    rate: float = 20.0
    duration: float = 60.0
    expected: str = "goal_reached"
    extent: tuple[float, float, float, float] = (-7.5, 5.5, -5.5, 5.5)

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", tuple(float(v) for v in as_vector("start", self.start, 3)))
        object.__setattr__(self, "goal", tuple(float(v) for v in as_vector("goal", self.goal, 2)))
        object.__setattr__(self, "extent", tuple(float(v) for v in as_vector("extent", self.extent, 4)))
        if self.sensor not in ("points", "laser"):
            raise InvalidInput("sensor", self.sensor, "must be 'points' or 'laser'")
        if self.expected not in ("goal_reached", "stuck"):
            raise InvalidInput("expected", self.expected, "must be 'goal_reached' or 'stuck' (pfield sim2d exits 1 "
                                                          "when the run ends otherwise)")
        beams = integer("laser_beams", self.laser_beams)
        if not 1 <= beams <= MAX_LASER_BEAMS:
            raise InvalidInput("laser_beams", self.laser_beams, f"must be in [1, {MAX_LASER_BEAMS}]")
        object.__setattr__(self, "laser_beams", beams)
        for name in ("laser_range", "robot_radius", "rate", "duration"):  # stored as numbers (YAML reads 1e9 as text)
            object.__setattr__(self, name, positive(name, getattr(self, name)))
        if self.duration * self.rate > MAX_STEPS:  # a run must end: at 45 µs a step, a million take under a minute
            raise InvalidInput("duration", self.duration, f"at rate {self.rate:g} Hz that is "
                               f"{self.duration * self.rate:.3g} steps, above {MAX_STEPS:g}; simulate less time")

    def with_drive(self, drive: str) -> Scenario:
        """The same scenario with ``config.drive`` replaced (``holonomic`` or ``diff_drive``)."""
        return dataclasses.replace(self, config=dataclasses.replace(self.config, drive=drive))  # type: ignore[arg-type]


_GRID = [(x, y) for x in range(-4, 5, 2) for y in range(-4, 5, 2)]
_LASER_FIELD = VectorFieldParams(ka=1.0, kr_dist=0.35, kr_height=1.0, kr_slope=8.0, min_spd_norm=0.1,
                                 max_spd_norm=1.0, goal_tolerance=0.1, attraction="linear")


def seed_params(ka: float, kr_dist: float, kr_height: float, kr_slope: float) -> VectorFieldParams:
    """A parameter set of the seed's plots and simulations (power law, speeds clamped to [0.1, 1] m/s)."""
    return VectorFieldParams(ka=ka, kr_dist=kr_dist, kr_height=kr_height, kr_slope=kr_slope, min_spd_norm=0.1,
                             max_spd_norm=1.0, goal_tolerance=0.1)


def _rect(x0: float, y0: float, x1: float, y1: float) -> list[tuple[float, float]]:
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def _builtin() -> dict[str, Scenario]:
    grid = World2D.build(points=_GRID)
    corridor = World2D.build(polygons=[
        _rect(-1.2, -1.2, 7.2, -1.0), _rect(7.0, -1.2, 7.2, 7.2), _rect(-1.2, -1.2, -1.0, 1.2),
        [(-1.2, 1.0), (5.0, 1.0), (5.0, 7.2), (4.8, 7.2), (4.8, 1.2), (-1.2, 1.2)]])
    doorway = World2D.build(polygons=[_rect(-0.1, -4.0, 0.1, -0.6), _rect(-0.1, 0.6, 0.1, 4.0)],
                            circles=[[2.0, -1.5, 0.4]])
    return {
        "grid_blocked": Scenario(
            "grid_blocked", "seed: 5×5 point grid, cannot go through (kr_dist 0, kr_height 2, kr_slope 1)",
            grid, (-6.0, 0.0, 0.0), (3.0, 3.0),
            seed_params(3.0, 0.0, 2.0, 1.0),
            expected="stuck"),
        "grid_pass": Scenario(
            "grid_pass", "seed: 5×5 point grid, can go through (kr_dist -1, kr_height 3, kr_slope 1, ka 3)",
            grid, (-6.0, 0.0, 0.0), (3.0, 3.0),
            seed_params(3.0, -1.0, 3.0, 1.0)),
        "corridor": Scenario(
            "corridor", "L-shaped corridor 2 m wide seen by a 360-beam laser", corridor, (0.0, 0.0, 0.0),
            (6.0, 6.0), _LASER_FIELD, sensor="laser", extent=(-1.5, 7.5, -1.5, 7.5)),
        "doorway": Scenario(
            "doorway", "a 1.2 m doorway in a wall, a round obstacle behind it, seen by a laser", doorway,
            (-3.0, -2.0, 0.0), (3.0, 1.5), _LASER_FIELD, sensor="laser", extent=(-4.0, 4.0, -4.0, 4.0)),
    }


BUILTIN_SCENARIOS: dict[str, Scenario] = _builtin()


def _from_mapping(data: dict[str, Any], source: str) -> Scenario:
    known = {f.name for f in dataclasses.fields(Scenario)} | {"points", "circles", "polygons"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise InvalidInput(f"{source}: {unknown[0]}", data[unknown[0]], f"unknown field; known: {sorted(known)}")
    world = World2D.build(data.pop("points", ()), data.pop("circles", ()), data.pop("polygons", ()))
    params = VectorFieldParams(**data.pop("params", {}))
    config = ControllerConfig(**data.pop("config", {}))
    try:
        return Scenario(world=world, params=params, config=config, **data)
    except TypeError as exc:
        raise InvalidInput(source, sorted(data), f"incomplete scenario: {exc}") from exc


def load_scenario(name_or_path: str | Path) -> Scenario:
    """A built-in scenario by name, or one read from a YAML file."""
    if str(name_or_path) in BUILTIN_SCENARIOS:
        return BUILTIN_SCENARIOS[str(name_or_path)]
    path = Path(name_or_path)
    if not path.is_file():
        raise ResourceNotFound(f"no built-in scenario or file {str(name_or_path)!r}; built-in: "
                               f"{', '.join(BUILTIN_SCENARIOS)}")
    data = yaml.safe_load(path.read_text())
    if not isinstance(data, dict):
        raise InvalidInput(str(path), type(data).__name__, "a scenario file holds a mapping")
    data.setdefault("name", path.stem)
    data.setdefault("description", f"scenario from {path.name}")
    return _from_mapping(data, str(path))


