"""Reading a robot's SRDF (MoveIt's semantic description): its disabled collision pairs and named group states.

XML only (no pinocchio): :class:`~pfield.robot.description.RobotDescription` checks an SRDF with it before a model
is built, and :meth:`RobotModel.from_urdf <pfield.robot.RobotModel.from_urdf>` reads the pairs and states.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pfield._files import read_text
from pfield.errors import InvalidInput

__all__ = ["SRDF_MAX_BYTES", "check_srdf_links", "read_disabled_pairs", "read_group_states", "read_srdf"]

SRDF_MAX_BYTES = 16 * 1024 * 1024
"""An SRDF larger than this is refused before it is parsed (real ones are below 1 MiB)."""

_LOG = logging.getLogger(__name__)


def read_srdf(srdf_path: str | Path) -> ET.Element:
    """The root element of an SRDF file (parsed once per file version: a description's check, the disabled pairs
    and the group states of one build, and a batch's description per problem read it; not to be modified);
    refuses (naming ``srdf``) a file that is not XML, whose root is not ``<robot>``, or that has ``<link>``
    elements (a URDF given as the SRDF)."""
    path = Path(srdf_path).expanduser()
    try:
        found = path.stat()
    except OSError:
        found = None  # read_text names what is wrong with it
    stamp = (found.st_mtime_ns, found.st_size) if found is not None else (0, -1)
    try:
        return _parsed(str(path.resolve()), stamp)
    except InvalidInput as exc:  # named as the caller gave it
        raise InvalidInput(exc.field, str(path), exc.reason) from None


@lru_cache(maxsize=16)
def _parsed(path: str, stamp: tuple[int, int]) -> ET.Element:
    del stamp  # part of the cache key only: an edited file is read again
    try:
        root = ET.fromstring(read_text("srdf", path, SRDF_MAX_BYTES))
    except ET.ParseError as exc:
        raise InvalidInput("srdf", path, f"not valid XML: {exc}") from exc
    if root.tag != "robot":
        raise InvalidInput("srdf", path, f"not an SRDF: the root element is <{root.tag}>, not <robot>")
    if root.find("link") is not None:
        raise InvalidInput("srdf", path, "not an SRDF: it has <link> elements (a URDF?); give the robot's "
                                         "semantic description (MoveIt's .srdf)")
    return root


def check_srdf_links(disabled: set[frozenset[str]], links: Iterable[str], srdf_path: str | Path,
                     joints: Iterable[str] | None = None) -> None:
    """Refuse (naming ``srdf``) an SRDF that describes another robot: none of its disabled pairs' links is a link of
    the URDF (links ``links``), or none of the joints its group states set is a movable joint of the URDF
    (``joints``, when given; an SRDF without disabled pairs, such as a group-states-only one, is told apart by
    these). Some unknown links (a URDF edited since) are logged, as MoveIt does, once per SRDF and set of links (a
    batch checks one description per problem)."""
    names = set(links)
    named = set().union(*disabled) if disabled else set()
    unknown = sorted(named - names)
    if named and len(unknown) == len(named):
        more = ", …" if len(unknown) > _NAMED else ""
        raise InvalidInput("srdf", str(srdf_path), f"it describes another robot: none of the links it names "
                                                    f"({', '.join(unknown[:_NAMED])}{more}) is a link of the URDF")
    if joints is not None:
        stated = sorted({str(joint.get("name")) for state in read_srdf(srdf_path).iter("group_state")
                         for joint in state.iter("joint") if joint.get("name")})
        if stated and not set(stated) & set(joints):
            more = ", …" if len(stated) > _NAMED else ""
            raise InvalidInput("srdf", str(srdf_path), f"it describes another robot: none of the joints its group "
                                                        f"states set ({', '.join(stated[:_NAMED])}{more}) is a joint "
                                                        "of the URDF")
    key = (str(Path(srdf_path).expanduser().resolve()), tuple(unknown))
    if unknown and key not in _WARNED:
        _WARNED.add(key)
        _LOG.warning("SRDF %s names links the URDF does not have (their pairs are ignored): %s", srdf_path,
                     ", ".join(unknown))


_NAMED = 4  # links an error quotes
_WARNED: set[tuple[str, tuple[str, ...]]] = set()  # (SRDF, its unknown links) already logged


def read_disabled_pairs(srdf_path: str | Path) -> set[frozenset[str]]:
    """Link pairs of the SRDF's ``<disable_collisions link1=… link2=…/>`` elements (:func:`read_srdf`)."""
    path = Path(srdf_path).expanduser()
    root = read_srdf(path)
    pairs = set()
    for element in root.iter("disable_collisions"):
        first, second = element.get("link1"), element.get("link2")
        if first and second:
            pairs.add(frozenset((first, second)))
    _LOG.debug("SRDF %s disables %d link pairs", path, len(pairs))
    return pairs


def read_group_states(srdf_path: str | Path, joint_names: tuple[str, ...]) -> dict[str, NDArray[np.float64]]:
    """The SRDF's ``<group_state name=… group=…><joint name=… value=…/>`` elements as joint vectors.

    Joints the model does not have (locked fingers) are ignored; a state that does not set every model joint
    is skipped (it describes another group), as is one whose values are not numbers.
    """
    path = Path(srdf_path).expanduser()
    root = read_srdf(path)
    states: dict[str, NDArray[np.float64]] = {}
    for element in root.iter("group_state"):
        values: dict[str, float] = {}
        try:
            for joint in element.iter("joint"):
                values[joint.get("name", "")] = float(joint.get("value", "nan").split()[0])
        except ValueError:
            _LOG.debug("SRDF %s: group state %r has a non-numeric value", path, element.get("name"))
            continue
        name = element.get("name")
        if name and all(j in values for j in joint_names):
            states[name] = np.array([values[j] for j in joint_names])
        else:
            _LOG.debug("SRDF %s: group state %r does not set every joint; skipped", path, name)
    return states
