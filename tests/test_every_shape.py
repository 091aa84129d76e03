"""Every obstacle shape through every consumer of shapes.

A new obstacle kind (a point cloud is next, DESIGN §8) joins the ``Shape`` union of :mod:`pfield.geometry`. The
first test then fails until the kind has an example here and a code in the core's ``Kind``, and each of the others
until its consumer handles it: the core's signed distances by each of its paths (which the exact check's coal
geometry must agree with), the link capsules' distance, the bounding radius the planners cull with, the covering
proxy of the plan certificate (which must contain the obstacle), the ROS message, MuJoCo, the pictures, the viewer
and the RViz markers. Each consumer refuses a shape it does not know by name rather than taking it for another (the
core's switches over ``Kind`` do not build with a kind missing, and the core refuses a code that is no kind).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, get_args

import coal
import numpy as np
import pytest

from pfield._core.geometry import Kind
from pfield.geometry import (
    SHAPE_TYPES,
    Box,
    Capsule,
    Cylinder,
    Ellipsoid,
    Mesh,
    Obstacle,
    ResourceResolver,
    Shape,
    Sphere,
    distances,
    nearest_distances,
    pack_obstacles,
    signed_distances,
)
from pfield.geometry.packed import SHAPE_CODES, bounding_radius
from pfield.spatial import Pose

MESHES = Path(__file__).parent / "data" / "meshes"
RESOLVER = ResourceResolver(allowed_roots=[MESHES])
EXAMPLES: dict[type, Callable[[], Any]] = {
    Sphere: lambda: Sphere(0.12),
    Box: lambda: Box(0.3, 0.2, 0.1),
    Cylinder: lambda: Cylinder(0.08, 0.3),
    Ellipsoid: lambda: Ellipsoid(0.15, 0.1, 0.06),
    Capsule: lambda: Capsule(0.05, 0.2),
    Mesh: lambda: Mesh(str(MESHES / "unit_cube.stl"), 0.2, 0.3, 0.1, resolver=RESOLVER),
}
"""One example of each shape type: sizes of a few to tens of centimetres, as a scene has them."""
POSE = Pose((0.45, -0.1, 0.3), (0.1, 0.2, 0.3, 0.9273618495495703))


def test_every_shape_type_has_an_example() -> None:
    assert set(EXAMPLES) == set(get_args(Shape))
    assert SHAPE_TYPES == tuple(kind.__name__ for kind in get_args(Shape))


def test_every_shape_type_has_the_cores_code() -> None:
    """The codes of packed sets are the core's ``Kind`` (their one definition), one for each shape type."""
    assert SHAPE_CODES == {kind.name: int(kind) for kind in Kind}
    assert sorted(SHAPE_CODES) == sorted(SHAPE_TYPES)
    assert sorted(SHAPE_CODES.values()) == list(range(len(Kind)))


@pytest.mark.parametrize("code", [-1, len(Kind), 99])
def test_the_core_refuses_a_code_that_is_no_shape(code: int) -> None:
    """A hand-built set whose kinds hold a code outside ``Kind`` is refused by name, not measured as a sphere."""
    packed = pack_obstacles([Obstacle("ball", Sphere(0.1), POSE)])
    packed.kinds[0] = code
    expected = f"kinds: obstacle 0 has code {code}, which is no shape"
    for query in (signed_distances, distances, nearest_distances):
        with pytest.raises(ValueError, match=expected):
            query(packed, np.zeros((1, 3)))
    with pytest.raises(ValueError, match=f"kind {code} has no bounding radius"):
        bounding_radius(packed, 0)


@pytest.fixture(params=list(EXAMPLES), ids=lambda kind: kind.__name__)
def obstacle(request: pytest.FixtureRequest) -> Obstacle:
    return Obstacle(f"the_{request.param.__name__.lower()}", EXAMPLES[request.param](), POSE)


def _around(obstacle: Obstacle, count: int = 60) -> np.ndarray:
    """World points outside the obstacle, 1–25 cm beyond its bounding sphere, in every direction."""
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    reach = obstacle.bounding_radius() + rng.uniform(0.01, 0.25, size=(count, 1))
    return obstacle.pose.position + reach * directions


def _inside(obstacle: Obstacle, count: int = 400) -> np.ndarray:
    """World points in the cube about the obstacle's bounding sphere (some of them inside the obstacle)."""
    rng = np.random.default_rng(11)
    return obstacle.pose.position + rng.uniform(-1.0, 1.0, size=(count, 3)) * obstacle.bounding_radius()


def test_the_core_signed_distance_is_the_exact_checks_distance(obstacle: Obstacle) -> None:
    """The field's signed distance (the compiled core) and the certificate's (coal) measure the same shape."""
    from pfield.robot.collision import _transform, coal_geometry

    points = _around(obstacle)
    core, normals = signed_distances(pack_obstacles([obstacle]), points)
    geometry, placement = coal_geometry(obstacle), _transform(obstacle)
    probe, request = coal.Sphere(1e-6), coal.DistanceRequest()
    for point, distance, normal in zip(points, core[:, 0], normals[:, 0], strict=True):
        result = coal.DistanceResult()
        exact = coal.distance(geometry, placement, probe, coal.Transform3s(np.eye(3), point), request, result)
        assert distance == pytest.approx(exact + 1e-6, abs=2e-6)
        assert np.linalg.norm(normal) == pytest.approx(1.0)
    assert np.all(core > 0.0)


def test_every_path_of_the_core_gives_the_same_distances(obstacle: Obstacle) -> None:
    """The core's three dispatches of a point's distance (with the normal, without it, the nearest over the set)
    agree to the bit, with and without a cutoff; the bounding radius the planners cull with is the shape's own and
    bounds the distance from below."""
    packed = pack_obstacles([obstacle])
    points = np.vstack([_around(obstacle), _inside(obstacle)])
    for cutoff in (np.inf, 0.05):
        with_normals, _ = signed_distances(packed, points, cutoff)
        np.testing.assert_array_equal(distances(packed, points, cutoff), with_normals)
    exact, _ = signed_distances(packed, points)
    np.testing.assert_array_equal(nearest_distances(packed, points), exact[:, 0])
    radius = bounding_radius(packed, 0)
    assert radius == pytest.approx(obstacle.bounding_radius(), rel=1e-12)
    assert np.all(exact[:, 0] >= np.linalg.norm(points - obstacle.pose.position, axis=1) - radius - 1e-12)


def test_a_link_capsules_distance_is_the_least_along_its_axis(obstacle: Obstacle) -> None:
    """The planners' segment–obstacle distance (each kind's own minimiser) is the signed distance's minimum along
    the segment: never above a dense sampling's, never below it by more than half a step (d is 1-Lipschitz)."""
    from pfield._core import robot_distance
    from pfield.planning._whole_body_core import core_obstacles
    from pfield.planning.whole_body import make_scene

    obstacles = core_obstacles(make_scene(pack_obstacles([obstacle])))
    rng = np.random.default_rng(5)
    samples = np.linspace(0.0, 1.0, 2001)
    centre, reach = np.asarray(obstacle.pose.position), 2.0 * obstacle.bounding_radius()
    for _ in range(20):
        a, b = centre + rng.uniform(-reach, reach, 3), centre + rng.uniform(-reach, reach, 3)
        found = robot_distance.segment_obstacle_distance(obstacles, 0, a, b)
        dense, _ = signed_distances(pack_obstacles([obstacle]), a + samples[:, None] * (b - a))
        assert dense[:, 0].min() - np.linalg.norm(b - a) / 4000 - 1e-9 <= found.distance <= dense[:, 0].min() + 1e-6


def test_the_covering_proxy_contains_the_obstacle(obstacle: Obstacle) -> None:
    """The certificate's covering capsules measure against a proxy: never farther than the obstacle itself."""
    from pfield.robot.collision import _covering_proxy

    proxy = _covering_proxy(obstacle)
    points = np.vstack([_around(obstacle), _inside(obstacle)])
    own, _ = signed_distances(pack_obstacles([obstacle]), points)
    bound, _ = signed_distances(pack_obstacles([proxy]), points)
    assert np.all(bound[:, 0] <= own[:, 0] + 1e-9)
    assert np.any(own[:, 0] < 0.0)  # some sampled points were inside: the containment was tested there too


def test_the_message_round_trip_gives_the_obstacle_back(obstacle: Obstacle) -> None:
    from pfield.interfaces.convert import obstacle_from_msg, obstacle_to_msg

    message = obstacle_to_msg(obstacle)
    assert message.type == type(obstacle.shape).__name__
    back = obstacle_from_msg(message, lambda uri, x, y, z: Mesh(uri, x, y, z, resolver=RESOLVER))
    assert back.shape == obstacle.shape and back.id == obstacle.id
    np.testing.assert_allclose(back.pose.position, obstacle.pose.position)


def test_mujoco_gets_a_geom_where_the_obstacle_is(obstacle: Obstacle) -> None:
    import mujoco

    from pfield.robot import RobotModel
    from pfield.sim.model import build_model

    sim = build_model(RobotModel.builtin("panda"), [obstacle])
    geoms = np.flatnonzero(sim.geom_obstacle == 0)
    assert len(geoms) >= 1 and sim.obstacle_ids == (obstacle.id,)
    data = mujoco.MjData(sim.model)
    mujoco.mj_forward(sim.model, data)
    # every geom of the obstacle lies within its bounding sphere (MuJoCo's own bounding radius about the geom)
    for g in geoms:
        reach = np.linalg.norm(data.geom_xpos[g] - obstacle.pose.position) + sim.model.geom_rbound[g]
        assert reach <= obstacle.bounding_radius() * (1 + 1e-6) + 1e-9 or sim.model.geom_type[g] == \
            mujoco.mjtGeom.mjGEOM_MESH


def test_the_pictures_draw_it_within_its_bounds(obstacle: Obstacle) -> None:
    from matplotlib.figure import Figure

    from pfield.viz.plots import draw_obstacles, obstacle_bounds

    ax = Figure().add_subplot(projection="3d")
    handles = draw_obstacles(ax, [obstacle])
    assert [h.get_label() for h in handles] == [f"{obstacle.id} ({type(obstacle.shape).__name__})"]
    lower, upper = obstacle_bounds([obstacle])
    radius = obstacle.bounding_radius()
    assert np.all(lower >= obstacle.pose.position - radius - 1e-9)
    assert np.all(upper <= obstacle.pose.position + radius + 1e-9)
    assert np.all(upper - lower > 0.1 * radius)  # not flat on any axis


def test_the_viewer_mesh_reaches_the_bounding_sphere(obstacle: Obstacle) -> None:
    from pfield.viz._viewer_shapes import influence_mesh, shape_mesh

    vertices, faces = shape_mesh(obstacle.shape)
    reach = np.linalg.norm(vertices, axis=1).max()
    assert len(faces) > 0 and reach == pytest.approx(obstacle.bounding_radius(), rel=0.05)
    # the influence zone: the shape grown by 10 cm reaches at least as far as the grown bounding sphere (the
    # offset surface's farthest point), a box's or cylinder's grown by extents to its corners, at most sqrt(3) times
    grown, _ = influence_mesh(obstacle.shape, 0.1)
    grown_reach = np.linalg.norm(grown, axis=1).max()
    assert 0.95 * (obstacle.bounding_radius() + 0.1) <= grown_reach <= np.sqrt(3.0) * (obstacle.bounding_radius() + 0.1)


def test_rviz_gets_the_obstacle_and_its_influence_zone(obstacle: Obstacle) -> None:
    from pfield.node._markers import state_markers

    markers = state_markers("world", None, [obstacle], 0.1).markers
    shown = [m for m in markers if m.ns in ("obstacles", "influence") and m.id == 0]
    assert sorted(m.ns for m in shown) == ["influence", "obstacles"]
    for marker in shown:
        assert (marker.pose.position.x, marker.pose.position.y, marker.pose.position.z) == \
            pytest.approx(tuple(obstacle.pose.position))
