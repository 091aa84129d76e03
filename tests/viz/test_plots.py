"""The pictures say what a roboticist expects: to scale, everything inside the axes, keys for every colour."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from matplotlib.patches import Rectangle
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from pfield import FieldConfig, PotentialField, RobotModel
from pfield.costmap import CostmapParams, build_costmap, find_valid_pose, load_map
from pfield.costmap._example import example_map_path
from pfield.errors import InvalidInput
from pfield.geometry import Box, Cylinder, Obstacle
from pfield.planning.scenes import SEED_GOAL, SEED_PLAN, SEED_START, seed_obstacles
from pfield.spatial import Pose
from pfield.viz import plot_arm_plan, plot_path_3d, save_arm_plot
from pfield.viz.arm import capsule_surface
from pfield.viz.costmap_plots import plot_find_valid_pose
from pfield.viz.plots import obstacle_bounds


def _inside_limits(ax, lower: np.ndarray, upper: np.ndarray) -> bool:
    limits = np.array([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()])
    return bool(np.all(limits[:, 0] <= lower + 1e-9) and np.all(limits[:, 1] >= upper - 1e-9))


def _box_aspect_is_true_scale(ax) -> bool:
    spans = np.array([np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim()), np.ptp(ax.get_zlim())])
    aspect = np.asarray(ax.get_box_aspect())
    return bool(np.allclose(aspect / aspect[0], spans / spans[0], rtol=1e-6))


@pytest.fixture(scope="module")
def seed_figure(tmp_path_factory: pytest.TempPathFactory):
    obstacles = seed_obstacles(tmp_path_factory.mktemp("meshes"))
    path = PotentialField(FieldConfig(), SEED_GOAL, obstacles).plan(SEED_START, **SEED_PLAN)
    return plot_path_3d(path, obstacles, SEED_GOAL), obstacles, path


def test_seed_obstacle_ids_are_in_the_legend_not_on_top_of_each_other(seed_figure) -> None:
    figure, obstacles, _ = seed_figure
    ax = figure.axes[0]
    assert [t.get_text() for t in ax.texts] == []  # no labels in the scene that could overlap
    labels = [t.get_text() for legend in figure.legends for t in legend.get_texts()]
    for obstacle in obstacles:
        assert f"{obstacle.id} ({obstacle.shape.type_name})" in labels


def test_path_plot_shows_orientation_triads_and_holds_every_obstacle(seed_figure) -> None:
    figure, obstacles, _ = seed_figure
    ax = figure.axes[0]
    triads = [c for c in ax.collections if isinstance(c, Line3DCollection)]
    assert len(triads) == 6  # x, y, z along the path and at the goal
    assert len(triads[0]._segments3d) >= 8  # one triad every few waypoints (3D segments before drawing)
    bounds = obstacle_bounds(obstacles)
    assert _inside_limits(ax, bounds[0], bounds[1])
    assert _box_aspect_is_true_scale(ax)


def test_capsule_surface_is_to_scale() -> None:
    a, b, radius = np.array([0.1, 0.2, 0.3]), np.array([0.4, -0.1, 0.5]), 0.07
    points = np.stack([np.ravel(c) for c in capsule_surface(a, b, radius)], axis=1)
    d = b - a
    t = np.clip((points - a) @ d / (d @ d), 0.0, 1.0)
    distance = np.linalg.norm(points - (a + t[:, None] * d), axis=1)
    np.testing.assert_allclose(distance, radius, atol=1e-12)
    assert t.min() == 0.0 and t.max() == 1.0


@pytest.fixture(scope="module")
def panda_plan():
    from pfield.demo.whole_body import PANDA_OBSTACLES, plan_panda_demo

    robot = RobotModel.builtin("panda")
    path, _ = plan_panda_demo(robot)
    return robot, path, PANDA_OBSTACLES


def test_arm_plot_shows_the_arm_at_key_moments_to_scale_with_path_and_clearance(panda_plan, tmp_path: Path) -> None:
    """Issue 33: five translucent snapshots merged into one blob; now one panel per key moment (the start, the
    closest approach, the end), the end-effector path large and the clearance over time."""
    from pfield.viz.arm import key_moments

    robot, path, obstacles = panda_plan
    figure = plot_arm_plan(path, robot, obstacles, snapshots=4)
    moments = key_moments(path, 4)
    assert moments[0] == 0 and moments[-1] == len(path) - 1 and int(np.argmin(path.clearances)) in moments
    assert len(figure.axes) == len(moments) + 2
    capsules = len(robot.geometry.capsules)
    cylinders_and_capsules = sum(1 for o in obstacles if not isinstance(o.shape, Box))
    table = obstacle_bounds([o for o in obstacles if o.id == "table"])
    for ax in figure.axes[:len(moments)]:  # one arm per panel, every capsule, the scene to scale
        assert capsules + cylinders_and_capsules <= len(ax.collections) < 2 * capsules + cylinders_and_capsules + 2
        assert _inside_limits(ax, table[0], table[1]) and _box_aspect_is_true_scale(ax)
    assert "clearance" in figure.axes[0].get_title()
    labels = [t.get_text() for t in figure.axes[len(moments)].get_legend().get_texts()]
    assert "table (Box)" in labels and "pitcher (Cylinder)" in labels
    clearance_line = figure.axes[-1].get_lines()[0]
    np.testing.assert_allclose(clearance_line.get_ydata(), 100 * np.asarray(path.clearances))
    assert save_arm_plot(path, robot, obstacles, tmp_path / "arm.png").stat().st_size > 0


def test_arm_plot_marks_the_goal_in_every_3d_panel(panda_plan) -> None:
    """The goal is a star in each snapshot and in the path panel (labelled "goal" there, in place of "end")."""
    from pfield.demo.whole_body import PANDA_GOAL

    robot, path, obstacles = panda_plan
    far = Pose(PANDA_GOAL.position + np.array([0.0, 0.0, 0.8]), PANDA_GOAL.orientation)  # above the scene's extent
    figure = plot_arm_plan(path, robot, obstacles, snapshots=3, goal=far)
    for ax in figure.axes[:4]:
        stars = [c for c in ax.collections if hasattr(c, "_offsets3d")
                 and np.allclose(np.asarray(c._offsets3d, dtype=float).ravel(), far.position)]
        assert len(stars) == 1 and _inside_limits(ax, far.position, far.position)
    labels = [t.get_text() for t in figure.axes[3].get_legend().get_texts()]
    assert "goal" in labels and "end" not in labels
    assert "end" in [t.get_text() for t in plot_arm_plan(path, robot, obstacles, snapshots=3).axes[3].get_legend()
                     .get_texts()]


def test_arm_plot_rejects_bad_input(panda_plan) -> None:
    robot, path, obstacles = panda_plan
    task_space = PotentialField(FieldConfig(), Pose((0.3, 0.0, 0.3))).plan(Pose((0.3, 0.0, 0.29)))
    with pytest.raises(InvalidInput, match="path"):
        plot_arm_plan(task_space, robot, obstacles)
    with pytest.raises(InvalidInput, match="snapshots"):
        plot_arm_plan(path, robot, obstacles, snapshots=0)
    with pytest.raises(InvalidInput, match="goal"):
        plot_arm_plan(path, robot, obstacles, goal=(0.3, 0.0, 0.3))


def test_costmap_plot_has_a_cost_key_and_marks_cells_outside_the_map(tmp_path: Path) -> None:
    import matplotlib.figure

    captured = {}
    original = matplotlib.figure.Figure.savefig

    def keep(self, *args, **kwargs):  # the figure plot_find_valid_pose builds
        captured["figure"] = self
        return original(self, *args, **kwargs)

    params = CostmapParams(robot_radius=0.25)
    costmap = build_costmap(load_map(example_map_path()), params)
    footprint = params.robot_footprint()
    request = Pose.planar(3.6, 2.8, 0.0)  # the unexplored corner, next to the map's edge
    result = find_valid_pose(costmap, footprint, request, dist_tolerance=0.5, angle_tolerance=math.pi / 4)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(matplotlib.figure.Figure, "savefig", keep)
        plot_find_valid_pose(costmap, footprint, request, result, tmp_path / "corner.png")
    figure = captured["figure"]
    ax, bar = figure.axes
    assert "inflation cost" in bar.get_ylabel()
    legend = [t.get_text() for legend in figure.legends for t in legend.get_texts()]
    assert legend == ["FREE (0)", "INSCRIBED (253)", "LETHAL (254)", "NO_INFORMATION (255)", "outside the map"]
    outside = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_hatch()]
    assert len(outside) == 1 and outside[0].get_zorder() < 0
    right_edge = costmap.origin_x + costmap.size_x * costmap.resolution
    assert ax.get_xlim()[1] > right_edge  # the zoomed view shows beyond the map, hatched not white


def test_obstacle_bounds_are_exact_for_boxes_and_cylinders() -> None:
    bounds = obstacle_bounds([Obstacle("t", Box(0.6, 1.2, 0.05), Pose((0.55, 0.0, 0.1))),
                              Obstacle("c", Cylinder(0.07, 0.28), Pose((0.5, 0.0, 0.265)))])
    np.testing.assert_allclose(bounds, [[0.25, -0.6, 0.075], [0.85, 0.6, 0.405]], atol=1e-12)
