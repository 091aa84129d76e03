"""A robot description: the one way to name a robot, everywhere (Python API, ``serve``, ``ros2 node``, ``view``,
``plan``, ``batch``; DESIGN §8).

A :class:`RobotDescription` is either a built-in name (:mod:`pfield.robot.catalog`: ``panda``, ``xarm7``) or a
URDF file with its end-effector link, optionally its SRDF (disabled collision pairs, named states), the
package roots of its ``package://`` URIs (``NAME=DIR``; mesh paths relative to the URDF resolve against the
URDF's folder, :func:`pfield.robot._loader.resolve_mesh_uri`) and joints locked at fixed values. It is a
frozen value of strings and numbers: hashable (a batch worker keeps one built robot per description) and
picklable (it travels to worker processes and Ray actors, which call :meth:`~RobotDescription.build` once).

Everything that can be checked without pinocchio is checked when it is made, through
:mod:`pfield._validation`, and each error names the field: ``robot`` (neither a built-in name nor a URDF
file, or a file with no ``<link>``), ``srdf`` (no such file, not an SRDF, or another robot's:
:mod:`pfield.robot.srdf`), ``end_effector`` (missing for a URDF, or not one of its links: the links are
listed), ``package_paths`` (not ``NAME=DIR``, or ``DIR`` is not a directory), ``locked_joints[NAME]`` (not a
finite number, or no such movable joint: the joints are listed). The command line maps these fields to its
flags (``--robot``, ``--srdf``, ``--end-effector``, ``--package-path``, ``--locked-joint``). The robot and its
files are checked first, then the package roots and the locked joints.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pfield._files import relative_to_cwd
from pfield._validation import finite, text
from pfield.errors import InvalidInput
from pfield.geometry.resources import package_path_map
from pfield.robot.catalog import BUILTIN_ROBOTS, builtin_spec, did_you_mean, example_robot_data_root
from pfield.robot.srdf import check_srdf_links, read_disabled_pairs

if TYPE_CHECKING:
    from pfield.robot.model import RobotModel

__all__ = ["RobotDescription", "UrdfOutline", "urdf_outline"]

_URDF_MAX_BYTES = 64 * 1024 * 1024
"""A URDF larger than this is refused before it is parsed (real ones are below 1 MiB; meshes are separate files)."""


@dataclass(frozen=True)
class UrdfOutline:
    """What a URDF file says without pinocchio: its robot name, links (document order), root link and movable
    (non-fixed) joints in document order."""

    name: str
    links: tuple[str, ...]
    root: str
    joints: tuple[str, ...]


@lru_cache(maxsize=64)
def _outline(path: str, stamp: tuple[int, int], field: str) -> UrdfOutline:
    del stamp  # part of the cache key only: a file changed on disk is read again
    try:
        data = Path(path).read_bytes()
        root = ET.fromstring(data)
    except OSError as exc:
        raise InvalidInput(field, path, f"cannot read the URDF: {exc.strerror or exc}") from None
    except ET.ParseError as exc:
        raise InvalidInput(field, path, f"the URDF is not valid XML: {exc}") from None
    if root.tag != "robot":
        raise InvalidInput(field, path, f"not a URDF: the root element is <{root.tag}>, not <robot>")
    links = tuple(str(link.get("name")) for link in root.findall("link") if link.get("name"))
    if not links:
        raise InvalidInput(field, path, "not a URDF: it has no <link> elements (an SRDF?); give the robot's URDF")
    joints = root.findall("joint")
    children = {joint.find("child").get("link") for joint in joints if joint.find("child") is not None}  # type: ignore[union-attr]
    roots = [link for link in links if link not in children]
    movable = tuple(str(joint.get("name")) for joint in joints if joint.get("type") not in ("fixed", None))
    return UrdfOutline(str(root.get("name") or Path(path).stem), links, roots[0] if roots else "", movable)


def urdf_outline(path: str | Path, field: str = "robot") -> UrdfOutline:
    """The :class:`UrdfOutline` of the URDF at ``path`` (read once per file version); errors name ``field``."""
    file = Path(path)
    try:
        stat = file.stat()
    except OSError:
        raise InvalidInput(field, str(path), "no such URDF file") from None
    if stat.st_size > _URDF_MAX_BYTES:
        raise InvalidInput(field, str(path), f"the URDF has {stat.st_size} bytes, above {_URDF_MAX_BYTES}")
    try:
        return _outline(str(file.resolve()), (stat.st_mtime_ns, stat.st_size), field)
    except InvalidInput as exc:  # named as the caller gave it, not as resolved (a symbolic link, "..")
        raise InvalidInput(exc.field, str(path), exc.reason) from None


def _locked(values: Any) -> tuple[tuple[str, float], ...]:
    items = values.items() if isinstance(values, Mapping) else values
    try:
        pairs = [(name, value) for name, value in items]
    except (TypeError, ValueError):
        raise InvalidInput("locked_joints", values, "expected a mapping of joint names to positions "
                                                    "(rad or m)") from None
    locked: dict[str, float] = {}
    for name, value in pairs:
        key = text("locked_joints", name)
        locked[key] = finite(f"locked_joints[{key!r}]", value)
    return tuple(sorted(locked.items()))


@dataclass(frozen=True)
class RobotDescription:
    """A robot to build: a built-in name or a URDF file, with its SRDF, end effector, package roots and locked
    joints (see the module text for what is checked when it is made).

    ``robot`` is a built-in name (case-insensitive; kept in lower case) or the path of a URDF file (kept
    absolute, so the value means the same in any working directory). ``locked_joints`` maps joint names to
    positions (rad for revolute, m for prismatic joints): the joint becomes part of a fixed placement, as a
    gripper's fingers. ``package_paths`` resolves ``package://NAME/...`` URIs (``NAME=DIR`` strings, pairs or a
    mapping); with a built-in robot they serve the obstacles' meshes only (built-ins read example-robot-data).
    ``srdf`` and ``end_effector`` belong to a URDF robot: a built-in has its own (``catalog``).

    Example::

        RobotDescription("ur5.urdf", srdf="ur5.srdf", end_effector="tool0", package_paths={"meshes": "meshes"})
    """

    robot: str = "panda"
    locked_joints: tuple[tuple[str, float], ...] = ()
    srdf: str | None = None
    end_effector: str | None = None
    package_paths: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        robot = text("robot", self.robot).strip()
        key = robot.lower()
        # the robot and its files first (a user running from another folder hears about the URDF before its
        # package roots), then the package roots and the locked joints
        if key in BUILTIN_ROBOTS:
            object.__setattr__(self, "robot", key)
            for name in ("srdf", "end_effector"):
                if getattr(self, name) is not None:
                    raise InvalidInput(name, getattr(self, name), f"the built-in robot {key!r} has its own {name} "
                                       f"({self._builtin_value(name)}); to choose another, give its URDF file")
        else:
            path = Path(robot).expanduser()
            if not path.is_file():
                names = ", ".join(sorted(BUILTIN_ROBOTS))
                what = f"no such URDF file{relative_to_cwd(path)}" if path.suffix or "/" in robot else \
                    f"neither a built-in robot ({names}) nor a URDF file{did_you_mean(robot)}"
                raise InvalidInput("robot", robot, f"{what}: give a built-in name, or the path of a URDF file "
                                                   "with its end-effector link")
            object.__setattr__(self, "robot", str(path.resolve()))
            outline = urdf_outline(path)
            if self.srdf is not None:
                srdf = Path(text("srdf", str(self.srdf))).expanduser()
                if not srdf.is_file():
                    raise InvalidInput("srdf", str(self.srdf), f"no such SRDF file{relative_to_cwd(srdf)}")
                # an SRDF, and this robot's
                check_srdf_links(read_disabled_pairs(srdf), outline.links, str(self.srdf), outline.joints)
                object.__setattr__(self, "srdf", str(srdf.resolve()))
            if self.end_effector is None or not text("end_effector", self.end_effector).strip():
                raise InvalidInput("end_effector", self.end_effector,
                                   f"a URDF robot needs its end-effector link (the link whose pose is planned); "
                                   f"links of {path.name}: {', '.join(outline.links)}")
            if self.end_effector not in outline.links:
                raise InvalidInput("end_effector", self.end_effector,
                                   f"no such link in {path.name}; links: {', '.join(outline.links)}")
        packages = package_path_map(self.package_paths)
        object.__setattr__(self, "package_paths", tuple(sorted((k, str(v)) for k, v in packages.items())))
        object.__setattr__(self, "locked_joints", _locked(self.locked_joints))
        joints = self.urdf_joints
        for name, value in self.locked_joints:
            if name not in joints:
                raise InvalidInput(f"locked_joints[{name!r}]", value,
                                   f"no such movable joint in the URDF; joints: {', '.join(joints)}")

    def _builtin_value(self, name: str) -> str:
        spec = builtin_spec(self.robot)
        return spec.end_effector if name == "end_effector" else spec.srdf.rsplit("/", 1)[-1]

    # ---- what the files say ---------------------------------------------------------------------------
    @property
    def is_builtin(self) -> bool:
        return self.robot in BUILTIN_ROBOTS

    @property
    def urdf_path(self) -> Path:
        """The URDF file (a built-in's inside example-robot-data)."""
        if self.is_builtin:
            return example_robot_data_root() / builtin_spec(self.robot).urdf
        return Path(self.robot)

    @property
    def outline(self) -> UrdfOutline:
        return urdf_outline(self.urdf_path)

    @property
    def urdf_joints(self) -> tuple[str, ...]:
        """The URDF's movable joints, in document order, before any is locked."""
        return self.outline.joints

    @property
    def locked(self) -> dict[str, float]:
        """Every joint this description locks: a built-in's catalog locks, then ``locked_joints``."""
        base = dict(builtin_spec(self.robot).locked_joints) if self.is_builtin else {}
        return base | dict(self.locked_joints)

    @property
    def end_effector_link(self) -> str:
        """The end-effector link (a built-in's from the catalog)."""
        return builtin_spec(self.robot).end_effector if self.is_builtin else str(self.end_effector)

    @property
    def base_link(self) -> str:
        """The URDF's root link (MoveIt problems may give poses in its frame)."""
        return self.outline.root

    @property
    def short_names(self) -> tuple[str, ...]:
        """Names a problem set may use for this robot (scene folders such as ``box_ur5``): the built-in name, or
        the URDF's file stem and robot name."""
        if self.is_builtin:
            return (self.robot,)
        return tuple(dict.fromkeys((Path(self.robot).stem, self.outline.name)))

    @property
    def package_path_map(self) -> dict[str, Path]:
        return {name: Path(folder) for name, folder in self.package_paths}

    def with_locked(self, joints: Mapping[str, float]) -> RobotDescription:
        """This description with ``joints`` also locked (their values replace any given before)."""
        return replace(self, locked_joints=tuple((dict(self.locked_joints) | dict(joints)).items()))

    def build(self) -> RobotModel:
        """The :class:`~pfield.robot.RobotModel` (pinocchio reads the files now; meshes through the package
        roots and, for relative paths, the URDF's folder)."""
        from pfield.robot.model import RobotModel

        if self.is_builtin:
            return RobotModel.builtin(self.robot, locked_joints=dict(self.locked_joints))
        return RobotModel.from_urdf(self.robot, end_effector=str(self.end_effector),
                                    package_paths=dict(self.package_path_map), srdf=self.srdf,
                                    locked_joints=dict(self.locked_joints))

    def __str__(self) -> str:
        if self.is_builtin:
            return self.robot
        return f"{Path(self.robot).name} (end effector {self.end_effector})"
