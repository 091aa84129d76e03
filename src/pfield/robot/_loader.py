"""Loading a URDF (+ optional SRDF) into pinocchio models, with ``package://`` URIs resolved first.

Mesh URIs in the URDF are resolved with the same :class:`~pfield.geometry.ResourceResolver` as obstacle
meshes and rewritten to absolute paths before pinocchio sees the text, so meshes come only from the places
the caller allowed (no network).
"""

from __future__ import annotations

import logging
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pfield._validation import finite
from pfield.errors import InvalidInput, ResourceNotAllowed, ResourceNotFound
from pfield.geometry.resources import PackagePaths, ResourceResolver, package_path_map

__all__ = ["LoadedRobot", "load_urdf", "resolve_mesh_uri", "write_angle"]

_LOG = logging.getLogger(__name__)
_ONE_DOF_JOINTS = ("JointModelR", "JointModelP", "JointModelRevoluteUnaligned", "JointModelPrismaticUnaligned",
                   "JointModelRUB")


@dataclass(frozen=True)
class LoadedRobot:
    """Pinocchio kinematic + collision models after locking the requested joints, and the resolver their
    mesh URIs were read through (its package paths travel with the model: the viewer reads the same files)."""

    model: pin.Model
    collision_model: pin.GeometryModel
    urdf_path: Path
    robot_name: str
    resolver: ResourceResolver


def _read_text(field: str, path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ResourceNotFound(f"{field}: cannot read {str(path)!r}: {exc}") from exc


def resolve_mesh_uri(uri: str, urdf_dir: Path, resolver: ResourceResolver) -> Path:
    """The file a URDF's mesh URI names: ``package://`` URIs through the resolver's package paths (then the
    ament index); ``file://`` URIs and paths (relative ones are relative to the URDF's folder ``urdf_dir``)
    inside its allowed roots. The one rule for the robot's meshes (the loader's and the viewer's)."""
    if not uri.startswith(("package://", "file://", "/")):
        uri = str(urdf_dir / uri)
    return resolver.resolve(uri)


_LINK = re.compile(r"""<link\b[^>]*?\bname\s*=\s*(["'])(.*?)\1""")
_MESH_FILENAME = re.compile(r"""(<mesh\b[^>]*?\bfilename\s*=\s*)(["'])(.+?)\2""")


def _resolve_uris(text: str, urdf_path: Path, resolver: ResourceResolver) -> str:
    """Replace every ``<mesh filename="…">`` URI by the absolute file ``resolver`` maps it to
    (:func:`resolve_mesh_uri`); an error names the link whose mesh it is."""

    def absolute(match: re.Match[str]) -> str:
        try:
            return f'{match.group(1)}"{resolve_mesh_uri(match.group(3), urdf_path.parent, resolver)}"'
        except (ResourceNotFound, ResourceNotAllowed) as exc:
            links = _LINK.findall(text, 0, match.start())
            owner = f"link {links[-1][1]!r}" if links else "a mesh"
            raise type(exc)(f"{owner} of {urdf_path}: {exc}") from None

    # only <mesh filename=…> names a mesh: other elements' filename attributes (a Gazebo <plugin filename=
    # "libgazebo_ros_control.so">) are no files of the robot's geometry and are left as they are
    return _MESH_FILENAME.sub(absolute, text)


def _check_supported(model: pin.Model, field: str, urdf: Path) -> None:
    for joint_id in range(1, model.njoints):
        joint = model.joints[joint_id]
        short, name = joint.shortname(), model.names[joint_id]
        if joint.nv != 1 or not short.startswith(_ONE_DOF_JOINTS):
            raise InvalidInput(field, str(urdf),
                               f"joint {name!r} is a {short}, not supported (only revolute, continuous and "
                               f"prismatic joints move): lock it (locked_joints={{{name!r}: value}}, on the command "
                               f"line --locked-joint {name}=VALUE)")


def load_urdf(urdf_path: str | Path, package_paths: PackagePaths | None = None,
              locked_joints: dict[str, float] | None = None,
              resolver: ResourceResolver | None = None) -> LoadedRobot:
    """Build pinocchio's kinematic and collision models from a URDF, locking ``locked_joints``.

    Mesh URIs are resolved by ``resolver`` (the obstacles' :class:`~pfield.geometry.ResourceResolver`), by
    default one with ``package_paths`` and the URDF's folder and the package roots as allowed roots.
    Raises :class:`ResourceNotFound` for an unreadable URDF or mesh, :class:`ResourceNotAllowed` for a mesh
    outside the allowed places, and :class:`InvalidInput` for a malformed URDF, an unknown locked joint or
    an unsupported joint type.
    """
    path = Path(urdf_path).expanduser().resolve()
    text = _read_text("urdf", path)
    roots = package_path_map(package_paths)  # a mapping, (NAME, DIR) pairs or "NAME=DIR" strings, as everywhere
    if resolver is None:
        resolver = ResourceResolver(package_paths=roots, allowed_roots=[path.parent, *roots.values()],
                                    use_ament=True)
    resolved = _resolve_uris(text, path, resolver)
    try:
        model = pin.buildModelFromXML(resolved)
        geometry = pin.buildGeomFromUrdfString(model, resolved, pin.COLLISION)
    except (RuntimeError, ValueError) as exc:
        raise InvalidInput("urdf", str(urdf_path), f"pinocchio could not parse it: {exc}") from exc
    model, geometry = _lock(model, geometry, locked_joints or {})
    _check_supported(model, "urdf", Path(urdf_path))
    try:
        robot_name = ET.fromstring(text).get("name", path.stem)
    except ET.ParseError:
        robot_name = path.stem
    return LoadedRobot(model, geometry, path, robot_name, resolver)


def _lock(model: pin.Model, geometry: pin.GeometryModel,
          locked: dict[str, float]) -> tuple[pin.Model, pin.GeometryModel]:
    if not locked:
        return model, geometry
    q_ref = pin.neutral(model)
    ids = []
    for name, value in locked.items():
        if not model.existJointName(name):
            raise InvalidInput(f"locked_joints[{name!r}]", value, f"no such joint; joints: {list(model.names)[1:]}")
        joint_id = model.getJointId(name)
        ids.append(joint_id)
        joint, angle = model.joints[joint_id], finite(f"locked_joints[{name!r}]", value)
        if joint.nv != 1:  # planar, floating, spherical: held at their neutral configuration
            if angle != 0.0:
                raise InvalidInput(f"locked_joints[{name!r}]", value,
                                   f"a joint of {joint.nv} degrees of freedom ({joint.shortname()}) is locked at its "
                                   "neutral configuration only: give 0")
        else:
            write_angle(q_ref, joint.idx_q, joint.nq == 2, angle)
    reduced, reduced_geometry = pin.buildReducedModel(model, geometry, ids, q_ref)
    return reduced, reduced_geometry


def write_angle(config: np.ndarray, start: int, continuous: bool, angle: float) -> None:
    """A 1-DoF joint's value (rad or m) into pinocchio's configuration vector ``config`` at its slot ``start``
    (``idx_q``): a continuous joint holds two slots, (cos θ, sin θ), not θ."""
    if continuous:
        config[start:start + 2] = (math.cos(angle), math.sin(angle))
    else:
        config[start] = angle


def joint_axis(model: pin.Model, joint_id: int) -> tuple[np.ndarray, int]:
    """Unit axis (joint frame) and kind (0 revolute, 1 prismatic) of a 1-DoF pinocchio joint."""
    joint = model.joints[joint_id]
    data = joint.createData()
    joint.calc(data, pin.neutral(model)[joint.idx_q: joint.idx_q + joint.nq])
    subspace = np.array(data.S, dtype=np.float64).reshape(6, -1)[:, 0]
    linear, angular = subspace[:3], subspace[3:]
    if np.linalg.norm(angular) > 0.5:
        return angular / np.linalg.norm(angular), 0
    return linear / np.linalg.norm(linear), 1
