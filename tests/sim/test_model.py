"""The MuJoCo model is the robot pfield plans with: its URDF inertias, its collision geometry, Menagerie's servos,
and every obstacle shape as the geom of the right type and size."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections import defaultdict

import numpy as np
import pytest
import trimesh

from pfield.errors import InvalidInput
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, Sphere
from pfield.robot import RobotModel
from pfield.sim import build_model, menagerie_gains
from pfield.sim.gains import DEFAULT_NATURAL_FREQUENCY, ServoGains
from pfield.sim.model import GEOM_OBSTACLE, GEOM_ROBOT, SHELL_THICKNESS, mujoco
from pfield.spatial import Pose


def _urdf_inertials(robot: RobotModel) -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """link → (mass, centre of mass in the link frame, 3×3 inertia about it in the inertial frame), read from the
    URDF text (not through pinocchio)."""
    found = {}
    for link in ET.parse(robot.urdf_path).getroot().iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        mass = float(inertial.find("mass").get("value"))  # type: ignore[union-attr]
        origin = inertial.find("origin")
        xyz = np.array([float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()])
        i = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}  # type: ignore[union-attr]
        matrix = np.array([[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]],
                           [i["ixz"], i["iyz"], i["izz"]]])
        found[link.get("name")] = (mass, xyz, matrix)
    return found


def _body_of_link(robot: RobotModel) -> dict[str, int]:
    model = robot.pinocchio_model
    return {f.name: int(f.parentJoint) for f in model.frames if f.name in _urdf_inertials(robot)}


@pytest.mark.parametrize("name", ["panda", "xarm7"])
def test_body_masses_are_the_urdf_link_masses_locked_links_added(name: str) -> None:
    robot = RobotModel.builtin(name)
    model = build_model(robot).model
    urdf = _urdf_inertials(robot)
    expected: dict[int, float] = defaultdict(float)
    for link, body in _body_of_link(robot).items():
        expected[body] += urdf[link][0]
    for body in range(1, robot.n_joints + 1):
        assert model.body_mass[body] == pytest.approx(expected[body], rel=1e-9, abs=1e-9)
    if name == "panda":  # link7 carries the hand and both locked fingers
        assert model.body_mass[7] == pytest.approx(urdf["panda_link7"][0] + urdf["panda_hand"][0]
                                                   + urdf["panda_leftfinger"][0] + urdf["panda_rightfinger"][0])


def test_single_link_bodies_have_the_urdf_centre_of_mass_and_principal_inertias(panda: RobotModel) -> None:
    model = build_model(panda).model
    urdf = _urdf_inertials(panda)
    for body in range(1, 7):  # panda_link1..6: one URDF link each, whose frame is the joint frame
        _mass, com, inertia = urdf[f"panda_link{body}"]
        np.testing.assert_allclose(model.body_ipos[body], com, atol=1e-9)
        np.testing.assert_allclose(np.sort(model.body_inertia[body]), np.sort(np.linalg.eigvalsh(inertia)),
                                   rtol=1e-6, atol=1e-12)


def test_robot_geoms_are_the_collision_models_objects(panda: RobotModel) -> None:
    sim_model = build_model(panda)
    model = sim_model.model
    robot_geoms = np.flatnonzero(sim_model.geom_kind == GEOM_ROBOT)
    objects = panda.collision_model.geometryObjects
    assert len(robot_geoms) == len(objects)
    for g, obj in zip(robot_geoms, objects, strict=True):
        assert mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(g)) == f"robot:{obj.name}"
        assert model.geom_bodyid[g] == obj.parentJoint
    # the finger boxes keep their half extents (locked at 0.04 m, they sit on link7's body)
    finger = next(o for o in objects if o.name == "panda_leftfinger_0")
    g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "robot:panda_leftfinger_0")
    np.testing.assert_allclose(model.geom_size[g], np.asarray(finger.geometry.halfSide))
    np.testing.assert_allclose(model.geom_pos[g], finger.placement.translation, atol=1e-12)


def test_panda_servos_are_menageries_and_another_robot_gets_the_documented_rule(panda: RobotModel,
                                                                               xarm: RobotModel) -> None:
    model = build_model(panda).model
    np.testing.assert_array_equal(model.actuator_gainprm[:, 0], [4500, 4500, 3500, 3500, 2000, 2000, 2000])
    np.testing.assert_array_equal(model.actuator_biasprm[:, 2], [-450, -450, -350, -350, -200, -200, -200])
    np.testing.assert_array_equal(model.actuator_forcerange[:, 1], [87, 87, 87, 87, 12, 12, 12])
    assert menagerie_gains(xarm.joint_names) is None
    xarm_model = build_model(xarm)
    gains = xarm_model.gains
    ratio = np.asarray(gains.kv) ** 2 / (4 * np.asarray(gains.kp))  # critically damped: kv² = 4·kp·m, m = kv/(2ω)
    np.testing.assert_allclose(ratio, np.asarray(gains.kv) / (2 * DEFAULT_NATURAL_FREQUENCY))
    effort = np.asarray(xarm.pinocchio_model.effortLimit)[: xarm.n_joints]
    np.testing.assert_allclose(xarm_model.model.actuator_forcerange[:, 1], effort)


def test_gains_are_validated_per_joint() -> None:
    with pytest.raises(InvalidInput, match=r"kp\[1\]"):
        ServoGains(np.array([1.0, 0.0]), np.ones(2), np.ones(2), np.ones(2), np.ones(2), "test")
    with pytest.raises(InvalidInput, match=r"kv\[0\]"):
        ServoGains(np.ones(2), np.array([np.nan, 1.0]), np.ones(2), np.ones(2), np.ones(2), "test")
    with pytest.raises(InvalidInput, match="force_limit"):
        ServoGains(np.ones(2), np.ones(2), np.ones(3), np.ones(2), np.ones(2), "test")


def _geom(sim_model, name: str) -> int:  # type: ignore[no-untyped-def]
    return mujoco.mj_name2id(sim_model.model, mujoco.mjtObj.mjOBJ_GEOM, name)


def test_each_obstacle_shape_becomes_the_right_geom(panda: RobotModel) -> None:
    pose = Pose((0.5, -0.4, 0.3), (0.0, 0.0, np.sin(0.3), np.cos(0.3)))
    cube = trimesh.creation.box((0.2, 0.1, 0.3))
    obstacles = [Obstacle("s", Sphere(radius=0.11), pose), Obstacle("b", Box(length=0.2, width=0.3, height=0.4), pose),
                 Obstacle("c", Cylinder(radius=0.05, height=0.3), pose),
                 Obstacle("k", Capsule(radius=0.04, height=0.2), pose),
                 Obstacle("e", Ellipsoid(semi_x=0.1, semi_y=0.2, semi_z=0.3), pose),
                 Obstacle("m", Mesh.from_arrays(cube.vertices, cube.faces, "cube"), pose)]
    sim_model = build_model(panda, obstacles)
    model = sim_model.model
    expected = {"s": (mujoco.mjtGeom.mjGEOM_SPHERE, [0.11]), "b": (mujoco.mjtGeom.mjGEOM_BOX, [0.1, 0.15, 0.2]),
                "c": (mujoco.mjtGeom.mjGEOM_CYLINDER, [0.05, 0.15]), "k": (mujoco.mjtGeom.mjGEOM_CAPSULE, [0.04, 0.1]),
                "e": (mujoco.mjtGeom.mjGEOM_ELLIPSOID, [0.1, 0.2, 0.3])}
    quat = np.array([np.cos(0.3), 0.0, 0.0, np.sin(0.3)])  # MuJoCo's (w, x, y, z)
    for index, (name, (kind, size)) in enumerate(expected.items()):
        g = _geom(sim_model, f"obstacle:{name}")
        assert model.geom_type[g] == kind
        np.testing.assert_allclose(model.geom_size[g][: len(size)], size, rtol=1e-12)
        np.testing.assert_allclose(model.geom_pos[g], pose.position)
        np.testing.assert_allclose(model.geom_quat[g], quat, atol=1e-12)
        assert sim_model.geom_kind[g] == GEOM_OBSTACLE and sim_model.geom_obstacle[g] == index
    g = _geom(sim_model, "obstacle:m")  # a convex mesh: one geom, its vertices where the obstacle's are
    assert model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
    np.testing.assert_allclose(_world_vertices(sim_model, g), np.sort(
        np.round(pose.transform_points(obstacles[-1].shape.data.vertices), 5), axis=0), atol=2e-5)


def _world_vertices(sim_model, g: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    """A mesh geom's vertices in the world frame, sorted (MuJoCo stores them in the mesh's inertial frame)."""
    model = sim_model.model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mesh = model.geom_dataid[g]
    local = model.mesh_vert[model.mesh_vertadr[mesh]: model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
    world = data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T
    return np.sort(np.round(world, 5), axis=0)


def test_a_non_convex_mesh_becomes_one_thin_prism_per_triangle(panda: RobotModel) -> None:
    ring = trimesh.creation.annulus(r_min=0.1, r_max=0.15, height=0.05, sections=12)
    assert not ring.is_convex
    centre = Pose((0.5, 0.0, 0.2))
    probe = Obstacle("probe", Sphere(radius=0.05), centre)  # in the hole, clear of the inner wall
    mesh = Mesh.from_arrays(ring.vertices, ring.faces, "ring")
    sim_model = build_model(panda, [Obstacle("ring", mesh, centre), probe])
    model, data = sim_model.model, mujoco.MjData(sim_model.model)
    mujoco.mj_forward(model, data)
    pieces = np.flatnonzero(sim_model.geom_obstacle == 0)
    assert len(pieces) == len(mesh.data.faces)
    assert all(model.mesh_vertnum[model.geom_dataid[g]] == 6 for g in pieces)
    fromto = np.zeros(6)
    ball = _geom(sim_model, "obstacle:probe")
    gap = min(mujoco.mj_geomDistance(model, data, int(g), ball, 1.0, fromto) for g in pieces)
    inner = float(np.min(np.linalg.norm(mesh.data.vertices[:, :2], axis=1)))  # the inner wall's corners
    # the hole's wall is a 12-gon of circumradius 0.1 m: its nearest point lies at the inradius
    assert gap == pytest.approx(inner * np.cos(np.pi / 12) - 0.05, abs=SHELL_THICKNESS)
    # the ring's convex hull, as MuJoCo would collide the mesh itself, swallows the probe
    hull = ring.convex_hull
    hull_model = build_model(panda, [Obstacle("hull", Mesh.from_arrays(hull.vertices, hull.faces, "hull"), centre),
                                     probe])
    hull_data = mujoco.MjData(hull_model.model)
    mujoco.mj_forward(hull_model.model, hull_data)
    assert mujoco.mj_geomDistance(hull_model.model, hull_data, _geom(hull_model, "obstacle:hull"),
                                  _geom(hull_model, "obstacle:probe"), 1.0, fromto) < 0.0


def test_bad_input_is_refused_naming_the_field(panda: RobotModel) -> None:
    ball = Obstacle("ball", Sphere(radius=0.1), Pose((0.5, 0.0, 0.3)))
    with pytest.raises(InvalidInput, match="robot"):
        build_model("panda")  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"obstacles\[1\]"):
        build_model(panda, [ball, "box"])  # type: ignore[list-item]
    with pytest.raises(InvalidInput, match="unique"):
        build_model(panda, [ball, ball])
    with pytest.raises(InvalidInput, match="gains"):
        build_model(panda, gains=menagerie_gains(tuple(f"j{i}" for i in range(6))) or ServoGains(
            np.ones(6), np.ones(6), np.ones(6), np.ones(6), np.ones(6), "six joints"))


def test_obstacle_ids_may_contain_colons_and_pieces_map_to_their_obstacle(panda: RobotModel) -> None:
    ring = trimesh.creation.annulus(r_min=0.1, r_max=0.15, height=0.05, sections=8)
    obstacles = [Obstacle("shelf:1", Box(length=0.1, width=0.1, height=0.1), Pose((0.5, 0.3, 0.1))),
                 Obstacle("ring:a", Mesh.from_arrays(ring.vertices, ring.faces, "ring"), Pose((0.5, -0.3, 0.1)))]
    sim_model = build_model(panda, obstacles)
    assert sim_model.obstacle_ids == ("shelf:1", "ring:a")
    owners = sim_model.geom_obstacle[sim_model.geom_kind == GEOM_OBSTACLE]
    assert (owners == 0).sum() == 1 and (owners == 1).sum() == len(obstacles[1].shape.data.faces)


def test_menageries_gains_need_its_motors_too(panda: RobotModel) -> None:
    from pfield.sim.model import servo_gains

    assert servo_gains(panda).source.startswith("mujoco_menagerie")
    stronger = RobotModel.builtin("panda")
    stronger.pinocchio_model.effortLimit[:7] = 2 * np.asarray(stronger.pinocchio_model.effortLimit[:7])
    gains = servo_gains(stronger)
    assert gains.source.startswith("default rule")
    np.testing.assert_allclose(gains.force_limit, [174, 174, 174, 174, 24, 24, 24])
