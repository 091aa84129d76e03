"""The MuJoCo model of a pfield robot among pfield obstacles, built with ``mujoco.MjSpec`` (no MJCF text).

The robot is the one pfield plans with, read from its :class:`~pfield.robot.RobotModel`, not from a second
description:

* **Bodies and joints**: one body per joint of the (reduced) pinocchio model, placed by the joint placement,
  with a hinge or slide joint along its axis and the URDF's position limits. Locked joints (the Panda's fingers at
  the problem's opening) were merged into their parent body by pinocchio, so the fingers sit where the problem
  puts them.
* **Inertias**: each body's mass, centre of mass and rotational inertia are pinocchio's (the URDF's ``<inertial>``
  elements, those of locked links added in); geoms carry no mass (``inertiafromgeom="false"``).
* **Collision geometry**: the URDF's ``<collision>`` elements as pinocchio loaded them — the same objects
  :class:`~pfield.robot.collision.CollisionChecker` measures — placed on their bodies: boxes, spheres, cylinders,
  capsules and ellipsoids as MuJoCo primitives, meshes from the same files with the same scale. MuJoCo collides a
  mesh through its convex hull, and so does pfield's exact check (coal on each link mesh's hull): a link contact in
  MuJoCo is a contact of the checked geometry.
* **Obstacles**: every pfield shape as a static world geom: Sphere → sphere (radius), Box → box (half extents),
  Cylinder → cylinder (radius, half height), Capsule → capsule (radius, half shaft length), Ellipsoid → ellipsoid
  (semi-axes), Mesh → see below.
* **Servos**: one position actuator per joint (:mod:`pfield.sim.gains`), and the URDF's effort limits.
* **Self contacts**: adjacent bodies (parent and child, the base and the first link) and the SRDF's disabled link
  pairs are excluded, as in pfield's self-collision check.

Obstacle meshes: pfield's exact check and the field use the mesh itself (coal's BVH, exact signed distance), so a
convex hull would be conservative — a robot inside a bowl would touch the hull and not the bowl. A convex mesh
(trimesh's ``is_convex``) becomes one mesh geom (its hull is itself); a non-convex mesh becomes a shell of one thin
convex prism per triangle, :data:`SHELL_THICKNESS` deep, extruded inwards along the face normal for a closed mesh
(and both ways for an open one). A link can only reach the inside by crossing the surface, which the prisms cover,
so MuJoCo's contacts are those of the mesh itself, up to the shell thickness.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from pfield.errors import InvalidInput
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, Sphere
from pfield.geometry.mesh import read_mesh_file
from pfield.robot import RobotModel
from pfield.robot.geometry import adjacent_joints
from pfield.sim.gains import DEFAULT_ARMATURE, ServoGains, default_gains, menagerie_gains

if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
    os.environ.setdefault("MUJOCO_GL", "egl")  # headless offscreen rendering (read when mujoco is imported)
try:
    import mujoco
except ModuleNotFoundError as exc:  # the optional extra: say how to get it
    raise ModuleNotFoundError("pfield.sim needs MuJoCo: pip install 'pfield[sim]' (or: pip install mujoco)",
                              name="mujoco") from exc

__all__ = ["DEFAULT_TIMESTEP", "GEOM_OBSTACLE", "GEOM_ROBOT", "SHELL_THICKNESS", "SimModel", "build_model"]

DEFAULT_TIMESTEP = 0.001
"""s: the simulation step (1 kHz), integrator ``implicitfast``. Not Menagerie's 500 Hz: at 2 ms a joint whose
force limit clips its servo (the Panda's wrist: kp 2000, kv 200, ±12 N·m, armature 0.1) could chatter for ever at
every step — the implicit integrator takes the actuator's −kv as the force's velocity derivative even while the
limit clips the force — after a reference step of 4–30 mrad: 6 of 60 random steps on the Panda held ±0.111 rad/s
at 0.4 mrad (the tests' arm did after a servo session); at 1 ms none of them, for twice the CPU time."""
SHELL_THICKNESS = 1e-3
"""m: depth of the per-triangle prisms of a non-convex obstacle mesh (module docstring)."""
GEOM_ROBOT, GEOM_OBSTACLE, GEOM_OTHER = 0, 1, 2
_ROBOT_RGBA = (0.85, 0.85, 0.88, 1.0)
_OBSTACLE_RGBA = (0.85, 0.45, 0.2, 0.6)


@dataclass(frozen=True, eq=False)
class SimModel:
    """A compiled MuJoCo model of a robot among obstacles, and what its ids mean.

    Attributes:
        model: the ``mujoco.MjModel``; joint ``j`` of the robot (tree order) is MuJoCo joint ``j``, qpos/qvel index
            ``j`` and actuator ``j``.
        body_links: (nbody,) the robot link each body stands for ("world" for the base and obstacles).
        geom_kind: (ngeom,) :data:`GEOM_ROBOT`, :data:`GEOM_OBSTACLE` or 2 (visual only).
        geom_obstacle: (ngeom,) index into ``obstacle_ids`` of an obstacle geom, −1 otherwise.
        obstacle_ids: the obstacles' ids, in the order given.
        gains: the servo gains used.
    """

    model: mujoco.MjModel
    body_links: tuple[str, ...]
    geom_kind: NDArray[np.int64]
    geom_obstacle: NDArray[np.int64]
    obstacle_ids: tuple[str, ...]
    gains: ServoGains


def _quat_wxyz(rotation: NDArray[np.float64]) -> NDArray[np.float64]:
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=np.float64).reshape(9))
    return quat


def _link_of_joint(model: pin.Model, joint: int) -> str:
    for frame in model.frames:
        if frame.type == pin.FrameType.BODY and frame.parentJoint == joint:
            return str(frame.name)
    return str(model.names[joint])


def _add_robot_geom(spec: mujoco.MjSpec, body: mujoco.MjsBody, obj: pin.GeometryObject) -> None:
    shape, name = obj.geometry, f"robot:{obj.name}"
    geom = body.add_geom(name=name, pos=obj.placement.translation, quat=_quat_wxyz(obj.placement.rotation),
                         rgba=_ROBOT_RGBA, group=1)
    if isinstance(shape, coal.Box):
        geom.type, geom.size = mujoco.mjtGeom.mjGEOM_BOX, np.asarray(shape.halfSide)
    elif isinstance(shape, coal.Sphere):
        geom.type, geom.size = mujoco.mjtGeom.mjGEOM_SPHERE, [shape.radius, 0, 0]
    elif isinstance(shape, coal.Cylinder):
        geom.type, geom.size = mujoco.mjtGeom.mjGEOM_CYLINDER, [shape.radius, shape.halfLength, 0]
    elif isinstance(shape, coal.Capsule):
        geom.type, geom.size = mujoco.mjtGeom.mjGEOM_CAPSULE, [shape.radius, shape.halfLength, 0]
    elif isinstance(shape, coal.Ellipsoid):
        geom.type, geom.size = mujoco.mjtGeom.mjGEOM_ELLIPSOID, np.asarray(shape.radii)
    elif isinstance(shape, coal.BVHModelBase) and obj.meshPath:
        vertices, _faces, _ = read_mesh_file(Path(obj.meshPath))
        spec.add_mesh(name=name, uservert=(vertices * np.asarray(obj.meshScale)).reshape(-1).tolist())
        geom.type, geom.meshname = mujoco.mjtGeom.mjGEOM_MESH, name
    else:
        raise InvalidInput("robot collision geometry", obj.name,
                           f"{type(shape).__name__} is not supported in the simulator (box, sphere, cylinder, "
                           "capsule, ellipsoid or mesh)")


def _add_robot(spec: mujoco.MjSpec, robot: RobotModel, gains: ServoGains, gravity_compensation: bool) -> list[str]:
    model, kin = robot.pinocchio_model, robot.kinematics
    bodies: list[mujoco.MjsBody] = [spec.worldbody]
    links = ["world"]
    for j in range(robot.n_joints):
        parent = bodies[int(kin.parents[j]) + 1]
        body = parent.add_body(name=_link_of_joint(model, j + 1), pos=kin.place_pos[j],
                               quat=_quat_wxyz(kin.place_rot[j]))
        inertia = model.inertias[j + 1]
        body.mass = max(float(inertia.mass), 1e-6)  # MuJoCo refuses a massless moving body
        body.ipos = np.asarray(inertia.lever)
        matrix = np.asarray(inertia.inertia)
        body.fullinertia = [matrix[0, 0], matrix[1, 1], matrix[2, 2], matrix[0, 1], matrix[0, 2], matrix[1, 2]]
        body.explicitinertial = True
        body.gravcomp = 1.0 if gravity_compensation else 0.0
        hinge = int(kin.kinds[j]) == 0
        lower, upper = robot.lower_limits[j], robot.upper_limits[j]
        limited = bool(np.isfinite(lower) and np.isfinite(upper))
        kind = mujoco.mjtJoint.mjJNT_HINGE if hinge else mujoco.mjtJoint.mjJNT_SLIDE
        body.add_joint(name=robot.joint_names[j], type=kind,
                       axis=kin.axes[j], range=[lower, upper] if limited else [0, 0],
                       limited=mujoco.mjtLimited.mjLIMITED_TRUE if limited else mujoco.mjtLimited.mjLIMITED_FALSE,
                       armature=gains.armature[j], damping=gains.damping[j])
        bodies.append(body)
        links.append(body.name)
    for obj in robot.collision_model.geometryObjects:
        _add_robot_geom(spec, bodies[int(obj.parentJoint)], obj)
    _exclude_pairs(spec, robot, links)
    return links


def _exclude_pairs(spec: mujoco.MjSpec, robot: RobotModel, links: list[str]) -> None:
    """Adjacent bodies (the base included, which MuJoCo's parent filter skips) and the SRDF's disabled pairs."""
    parents, model = robot.kinematics.parents, robot.pinocchio_model
    pairs = {(a, b) for a in range(-1, robot.n_joints) for b in range(a + 1, robot.n_joints)
             if adjacent_joints(parents, a, b)}
    for pair in robot.disabled_pairs or ():
        names = sorted(pair)
        if len(names) == 2 and all(model.existFrame(name) for name in names):
            a, b = (int(model.frames[model.getFrameId(name)].parentJoint) - 1 for name in names)
            if a != b:
                pairs.add((min(a, b), max(a, b)))
    for a, b in sorted(pairs):
        spec.add_exclude(bodyname1=links[a + 1], bodyname2=links[b + 1])


def _shell_prisms(vertices: NDArray[np.float64], faces: NDArray[np.int64],
                  closed: bool) -> list[NDArray[np.float64]]:
    """One (6, 3) prism per triangle: the triangle and its copy moved :data:`SHELL_THICKNESS` along −normal (a
    closed, outward-oriented mesh) or ±half of it (an open mesh)."""
    corners = vertices[faces]  # (F, 3, 3)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    inner, outer = (SHELL_THICKNESS, 0.0) if closed else (SHELL_THICKNESS / 2, SHELL_THICKNESS / 2)
    return [np.vstack([tri + outer * n, tri - inner * n]) for tri, n in zip(corners, normals, strict=True)]


def _add_obstacle(spec: mujoco.MjSpec, obstacle: Obstacle) -> list[str]:
    """The obstacle's geoms (one, or one per triangle of a non-convex mesh); their names."""
    shape, name = obstacle.shape, f"obstacle:{obstacle.id}"
    place = {"pos": np.asarray(obstacle.pose.position), "quat": _quat_wxyz(obstacle.pose.rotation),
             "rgba": _OBSTACLE_RGBA, "group": 2}
    primitives = {Sphere: (mujoco.mjtGeom.mjGEOM_SPHERE, lambda s: [s.radius, 0, 0]),
                  Box: (mujoco.mjtGeom.mjGEOM_BOX, lambda s: [s.length / 2, s.width / 2, s.height / 2]),
                  Cylinder: (mujoco.mjtGeom.mjGEOM_CYLINDER, lambda s: [s.radius, s.height / 2, 0]),
                  Capsule: (mujoco.mjtGeom.mjGEOM_CAPSULE, lambda s: [s.radius, s.height / 2, 0]),
                  Ellipsoid: (mujoco.mjtGeom.mjGEOM_ELLIPSOID, lambda s: [s.semi_x, s.semi_y, s.semi_z])}
    if type(shape) in primitives:
        kind, size = primitives[type(shape)]
        spec.worldbody.add_geom(name=name, type=kind, size=size(shape), **place)
        return [name]
    if not isinstance(shape, Mesh):
        raise TypeError(f"no MuJoCo geom for obstacle shape {type(shape).__name__}")
    import trimesh

    vertices, faces = np.asarray(shape.data.vertices), np.asarray(shape.data.faces)
    if trimesh.Trimesh(vertices, faces, process=False).is_convex:
        pieces = [vertices]
    else:
        pieces = _shell_prisms(vertices, faces, bool(shape.watertight))
    names = [f"{name}:{k}" if len(pieces) > 1 else name for k in range(len(pieces))]
    for mesh_name, piece in zip(names, pieces, strict=True):
        spec.add_mesh(name=mesh_name, uservert=piece.reshape(-1).tolist())
        spec.worldbody.add_geom(name=mesh_name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mesh_name, **place)
    return names


def _joint_inertia_diagonal(robot: RobotModel, armature: float) -> NDArray[np.float64]:
    model = robot.pinocchio_model
    matrix = pin.crba(model, model.createData(), robot.pinocchio_configuration(robot.mid_configuration))
    return np.diag(np.asarray(matrix))[: robot.n_joints] + armature


def servo_gains(robot: RobotModel) -> ServoGains:
    """Menagerie's gains for this robot, else the documented rule (:mod:`pfield.sim.gains`).

    Menagerie's apply when the joint names are its model's and the URDF's effort limits (where given) are its force
    ranges: a UR10 shares the UR5e's joint names, not its motors.
    """
    effort = np.asarray(robot.pinocchio_model.effortLimit)[: robot.n_joints]
    gains = menagerie_gains(robot.joint_names)
    given = effort > 0
    if gains is not None and np.allclose(effort[given], gains.force_limit[given], rtol=0.01):
        return gains
    return default_gains(_joint_inertia_diagonal(robot, DEFAULT_ARMATURE), effort)


def build_model(robot: RobotModel, obstacles: Sequence[Obstacle] = (), *, gains: ServoGains | None = None,
                timestep: float = DEFAULT_TIMESTEP, gravity_compensation: bool = True) -> SimModel:
    """Compile the MuJoCo model of ``robot`` among ``obstacles`` (module docstring).

    ``gains`` default to :func:`servo_gains`; ``gravity_compensation`` cancels gravity on the robot's bodies
    (``gravcomp``, as the Panda's and the UR's own controllers do) while gravity stays on (9.81 m/s², −z).
    """
    if not isinstance(robot, RobotModel):
        raise InvalidInput("robot", robot, "expected a pfield RobotModel")
    obstacles = list(obstacles)
    for i, obstacle in enumerate(obstacles):
        if not isinstance(obstacle, Obstacle):
            raise InvalidInput(f"obstacles[{i}]", obstacle, "expected a pfield Obstacle")
    ids = [o.id for o in obstacles]
    if len(set(ids)) != len(ids):
        raise InvalidInput("obstacles", ids, "obstacle ids must be unique")
    gains = servo_gains(robot) if gains is None else gains
    if len(gains.kp) != robot.n_joints:
        raise InvalidInput("gains", gains.source, f"has {len(gains.kp)} joints, the robot {robot.n_joints}")
    spec = mujoco.MjSpec()
    spec.modelname = robot.name
    spec.compiler.degree = False  # joint ranges in rad
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.gravity = [0.0, 0.0, -9.81]
    spec.worldbody.add_light(pos=[0, 0, 3], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    # a floor to look at (no contacts: problems bring their own tables)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.05], contype=0,
                            conaffinity=0, rgba=[0.3, 0.35, 0.4, 1])
    links = _add_robot(spec, robot, gains, gravity_compensation)
    owners = {geom: i for i, obstacle in enumerate(obstacles) for geom in _add_obstacle(spec, obstacle)}
    for j, name in enumerate(robot.joint_names):
        actuator = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.gaintype, actuator.biastype = mujoco.mjtGain.mjGAIN_FIXED, mujoco.mjtBias.mjBIAS_AFFINE
        actuator.gainprm[0] = gains.kp[j]
        actuator.biasprm[:3] = [0.0, -gains.kp[j], -gains.kv[j]]
        if np.isfinite(gains.force_limit[j]):
            actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            actuator.forcerange = [-gains.force_limit[j], gains.force_limit[j]]
    model = spec.compile()
    return SimModel(model, tuple(links) + ("world",) * (model.nbody - len(links)), *_classify(model, owners),
                    tuple(ids), gains)


def _classify(model: mujoco.MjModel, owners: dict[str, int]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Each geom's kind, and the obstacle index of an obstacle geom (``owners``: geom name → index)."""
    kind = np.full(model.ngeom, GEOM_OTHER, dtype=np.int64)
    owner = np.full(model.ngeom, -1, dtype=np.int64)
    for g in range(model.ngeom):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
        if name in owners:
            kind[g], owner[g] = GEOM_OBSTACLE, owners[name]
        elif name.startswith("robot:"):
            kind[g] = GEOM_ROBOT
    return kind, owner
