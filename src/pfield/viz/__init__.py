"""Visualisation: matplotlib plots (headless PNG/GIF) and viewers.

The public plotting functions: :func:`plot_path_3d` / :func:`save_path_plot` (a task-space plan among its
obstacles), :func:`plot_arm_plan` / :func:`save_arm_plot` (a whole-body plan: link capsules to scale),
:func:`draw_obstacles`, :func:`draw_arm` and :func:`draw_frames` for your own 3D axes. Costmap pictures are
in :mod:`pfield.viz.costmap_plots`, the 2D field plots in :mod:`pfield.viz.plots2d`.
"""

from pfield.viz.arm import draw_arm, plot_arm_plan, save_arm_plot
from pfield.viz.plots import draw_frames, draw_obstacles, plot_path_3d, save_path_plot

__all__ = ["draw_arm", "draw_frames", "draw_obstacles", "plot_arm_plan", "plot_path_3d", "save_arm_plot",
           "save_path_plot"]
