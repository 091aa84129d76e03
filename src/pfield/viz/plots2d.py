"""Plots of the mobile base's 2D vector field (matplotlib, headless PNG), computed by the controller's code.

* Radial profiles of the seed (document 004, "Visualization (Python program)"): the potential V and the
  speed along a line, unclamped (−∇V) and clamped (the command of :mod:`pfield.mobile.clamping`), for
  repulsive only (Ka 0, Kr_dist 0, Kr_height 2, Kr_slope 1), attractive only (Ka 3), both (goal at 0,
  obstacle at 2 m) and the coincident attractive and repulsive point (the robot settles at ln 2 ≈ 0.693 m).
* Field plots: V as an image, the clamped command as arrows, obstacles, goal and a trajectory.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from pfield.mobile import VectorFieldParams, field_components, velocity
from pfield.mobile.scenarios import seed_params

__all__ = ["SEED_PROFILES", "ProfileCase", "plot_field", "plot_profile", "save_field_plot", "save_seed_plots"]

_log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ProfileCase:
    """A 1D cut through the field along +x: ``x`` from ``x_range[0]`` to ``x_range[1]`` (m), y = 0."""

    name: str
    title: str
    params: VectorFieldParams
    goal: tuple[float, float] | None
    obstacles: tuple[tuple[float, float], ...]
    x_range: tuple[float, float] = (0.0, 5.0)


SEED_PROFILES = (
    ProfileCase("repulsive", "Repulsive only: f(x) = 2·exp(1·(0 − x))",
                seed_params(0.0, 0.0, 2.0, 1.0),
                None, ((0.0, 0.0),)),
    ProfileCase("attractive", "Attractive only: f(x) = x³",
                seed_params(3.0, 0.0, 0.0, 1.0),
                (0.0, 0.0), (), (0.0, 2.0)),
    ProfileCase("both", "Attractive (x = 0) + repulsive (x = 2)",
                seed_params(3.0, 0.0, 2.0, 1.0),
                (0.0, 0.0), ((2.0, 0.0),), (-1.0, 4.0)),
    ProfileCase("coincident", "Coincident attractive and repulsive point (p_r = p_a)",
                seed_params(3.0, 0.0, 2.0, 1.0),
                (0.0, 0.0), ((0.0, 0.0),), (0.0, 3.0)),
)


def _params_label(params: VectorFieldParams) -> str:
    return (f"Ka {params.ka:g} ({params.attraction}), Kr_dist {params.kr_dist:g}, Kr_height {params.kr_height:g}, "
            f"Kr_slope {params.kr_slope:g}, spd ∈ [{params.min_spd_norm:g}, {params.max_spd_norm:g}]")


def plot_profile(case: ProfileCase, samples: int = 600) -> Figure:
    """Potential (left) and speed along +x, unclamped and clamped (right), for one :class:`ProfileCase`."""
    x = np.linspace(case.x_range[0], case.x_range[1], samples)
    points = np.column_stack([x, np.zeros_like(x)])
    parts = field_components(points, case.goal, case.obstacles, case.params)
    command = velocity(points, case.goal, case.obstacles, case.params)
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    ax_v, ax_s = fig.subplots(1, 2)
    ax_v.plot(x, parts.potential, color="tab:purple")
    ax_v.set(xlabel="x = position along the cut (m)", ylabel="V", title="potential V (unclamped)")
    ax_s.plot(x, parts.attraction[:, 0] + parts.repulsion[:, 0], color="0.6", label="−∂V/∂x (unclamped)")
    ax_s.plot(x, command[:, 0], color="tab:blue", lw=2, label="clamped command v_x")
    ax_s.axhline(0.0, color="k", lw=0.6)
    limit = 3.0 * case.params.max_spd_norm
    ax_s.set(xlabel="x (m)", ylabel="speed along +x (m/s)", title="speed", ylim=(-limit, limit))
    if case.name == "coincident":
        ax_s.axvline(math.log(2.0), color="tab:red", ls="--", label="rest point ln 2 ≈ 0.693 m")
    ax_s.legend(loc="best", fontsize=8)
    for ax in (ax_v, ax_s):
        ax.grid(alpha=0.3)
    fig.suptitle(f"{case.title}\n{_params_label(case.params)}", fontsize=10)
    return fig


def plot_field(ax: Axes, params: VectorFieldParams, goal: ArrayLike | None, obstacles: ArrayLike | None,
               extent: tuple[float, float, float, float], resolution: int = 200, arrows: int = 25,
               trajectory: NDArray[np.float64] | None = None, weights: ArrayLike | None = None) -> None:
    """Draw V (image, log scale), the clamped command (arrows), obstacles, goal and an optional trajectory."""
    xmin, xmax, ymin, ymax = extent
    gx, gy = np.meshgrid(np.linspace(xmin, xmax, resolution), np.linspace(ymin, ymax, resolution))
    value = field_components(np.column_stack([gx.ravel(), gy.ravel()]), goal, obstacles, params,
                             weights).potential.reshape(gx.shape)
    image = ax.imshow(np.log1p(value - value.min()), extent=extent, origin="lower", cmap="viridis",
                      interpolation="bilinear")
    ax.figure.colorbar(image, ax=ax, fraction=0.046, pad=0.02, label="log(1 + V − min V)")
    qx, qy = np.meshgrid(np.linspace(xmin, xmax, arrows), np.linspace(ymin, ymax, arrows))
    command = velocity(np.column_stack([qx.ravel(), qy.ravel()]), goal, obstacles, params, weights)
    ax.quiver(qx.ravel(), qy.ravel(), command[:, 0], command[:, 1], color="white", alpha=0.8,
              scale=arrows * 1.6 * params.max_spd_norm, width=0.0025)
    if obstacles is not None and np.size(obstacles):
        obs = np.asarray(obstacles, dtype=float).reshape(-1, 2)
        ax.plot(obs[:, 0], obs[:, 1], "o", color="tab:red", ms=5, mec="k", label="repulsive points")
    if goal is not None:
        ax.plot(*np.asarray(goal, dtype=float), "*", color="gold", ms=16, mec="k", label="goal")
    if trajectory is not None and len(trajectory):
        ax.plot(trajectory[:, 0], trajectory[:, 1], "-", color="tab:orange", lw=2, label="trajectory")
        ax.plot(*trajectory[0, :2], "s", color="tab:orange", mec="k", ms=7)
    ax.set(xlim=(xmin, xmax), ylim=(ymin, ymax), xlabel="x (m)", ylabel="y (m)", aspect="equal")
    ax.legend(loc="upper left", fontsize=7, framealpha=0.8)


def save_field_plot(path: Path, title: str, params: VectorFieldParams, goal: ArrayLike | None,
                    obstacles: ArrayLike | None, extent: tuple[float, float, float, float],
                    trajectory: NDArray[np.float64] | None = None) -> Path:
    """One 2D field plot to ``path`` (PNG)."""
    fig = Figure(figsize=(7.5, 6.5), layout="constrained")
    ax = fig.subplots()
    plot_field(ax, params, goal, obstacles, extent, trajectory=trajectory)
    ax.set_title(f"{title}\n{_params_label(params)}", fontsize=9)
    fig.savefig(path, dpi=110)
    return path


def save_seed_plots(out_dir: Path) -> list[Path]:
    """The seed's radial profiles and the two grid-scenario field plots (with trajectories) as PNGs."""
    from pfield.mobile.scenarios import BUILTIN_SCENARIOS
    from pfield.mobile.sim import simulate

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for case in SEED_PROFILES:
        fig = plot_profile(case)
        path = out_dir / f"profile_{case.name}.png"
        fig.savefig(path, dpi=110)
        written.append(path)
    for name in ("grid_blocked", "grid_pass"):
        scenario = BUILTIN_SCENARIOS[name]
        result = simulate(scenario)
        title = f"{scenario.description}: {result.outcome}"
        written.append(save_field_plot(out_dir / f"field_{name}.png", title, scenario.params, scenario.goal,
                                       scenario.world.points, scenario.extent, result.poses))
    _log.info("wrote %d plots to %s", len(written), out_dir)
    return written
