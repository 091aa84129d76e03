"""pfield's own scene files: obstacles, start, goal, field parameters and planning settings in one YAML.

Scene file (YAML mapping; the schema is documented in docs/field.md, "Scene files")::

    obstacles:        # potential_fields_interfaces/msg/Obstacle entries, the seed's fields
      - {frame_id: ball, type: Sphere, group: Static, radius: 0.1,
         pose: {position: {x: 0.4, y: 0.0, z: 0.1}, orientation: {w: 1.0}}}
    start: {position: {x: 0.227, y: 0.0, z: 0.294}, orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}}
    goal:  {position: {x: 0.5, y: 0.2, z: 0.4}, orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}}
    params: {attractive_gain: 3.0, influence_distance: 0.1}   # FieldConfig fields (ROS parameter names)
    delta_time: 0.02
    goal_tolerance: 0.01
    max_iterations: 25000

Every key is optional (the seed's example fills what is missing; without ``obstacles`` there are none);
an unknown key at any level is refused naming the known ones. Numbers are numbers, as in ROS messages: an
int serves where a float is expected, a string or a boolean (``delta_time: "0.02"``) is refused;
``max_iterations`` is an int. Obstacles without a ``group`` are ``Static``. Relative mesh paths are relative
to the scene file's folder; absolute paths, ``file://`` and ``package://`` URIs (through the ament index)
work too. The file is read within the bounds of :func:`pfield.interfaces.load_yaml_file` (a regular
file of at most 8 MiB, 100 levels deep, 250 000 nodes with aliases expanded).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pfield._validation import integer, number
from pfield.errors import InvalidInput

__all__ = ["SCENE_KEYS", "load_scene"]


SCENE_KEYS = ("obstacles", "start", "goal", "params", "delta_time", "goal_tolerance", "max_iterations")
"""The top-level keys of a scene file."""


def _mapping(data: Any, name: str) -> dict[str, Any]:
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise InvalidInput(name, data, "expected a mapping")
    return data


_MOVEIT_KEYS = frozenset({"group_name", "goal_constraints", "start_state", "world", "robot_state",
                           "fixed_frame_transforms"})
"""Keys of a MoveIt PlanningScene or MotionPlanRequest message, none of which a pfield scene has."""


def load_scene(path: Path | None, mesh_directory: Path) -> dict[str, Any]:
    """Obstacles, start, goal, FieldConfig and planning arguments of a scene file (None: the seed scene).

    ``mesh_directory`` receives the seed scene's mesh. Raises ``InvalidInput`` naming the key for an unknown
    key (listing the known ones), a bad value or an unreadable file; relative mesh paths are resolved
    against the scene file's folder.
    """
    from pfield.field import FieldConfig
    from pfield.geometry import Mesh, ResourceResolver
    from pfield.interfaces import geometry_msgs as gm
    from pfield.interfaces import load_yaml_file, message_from_data
    from pfield.interfaces.convert import obstacle_from_msg, pose_from_msg
    from pfield.interfaces.potential_fields_interfaces import Obstacle as ObstacleMsg
    from pfield.planning.scenes import SEED_GOAL, SEED_PLAN, SEED_START, seed_obstacles

    scene: dict[str, Any] = {"start": SEED_START, "goal": SEED_GOAL, "config": FieldConfig(), **SEED_PLAN}
    if path is None:
        return scene | {"obstacles": seed_obstacles(mesh_directory)}
    data = _mapping(load_yaml_file(path, "scene"), "scene")
    moveit = sorted(str(key) for key in data if key in _MOVEIT_KEYS)
    if moveit:
        raise InvalidInput("scene", str(path), f"a MoveIt file, not a pfield scene (it has {', '.join(moveit)}): "
                                               "pfield batch reads MoveIt problems from the folder that holds their "
                                               "sceneNNNN.yaml/requestNNNN.yaml pairs; give that folder")
    for key in data:
        if key not in SCENE_KEYS:
            raise InvalidInput(str(key), data[key], f"unknown scene key in {path}; known: {', '.join(SCENE_KEYS)}")
    resolver = ResourceResolver(base_directory=path.resolve().parent)

    def make_mesh(resource: str, sx: float, sy: float, sz: float) -> Mesh:
        return Mesh(resource, sx, sy, sz, resolver=resolver)

    entries = data.get("obstacles") or []
    if not isinstance(entries, list):
        raise InvalidInput("obstacles", entries, "expected a list of Obstacle messages")
    scene["obstacles"] = [
        obstacle_from_msg(_obstacle_message(message_from_data, ObstacleMsg, entry, f"obstacles[{i}]"),
                          make_mesh, f"obstacles[{i}]")
        for i, entry in enumerate(entries)
    ]
    for key in ("start", "goal"):
        if key in data:
            scene[key] = pose_from_msg(_prefixed(key, message_from_data, gm.Pose, data[key]), key)
    params = {str(name): number(f"params.{name}", value)
              for name, value in _mapping(data.get("params"), "params").items()}
    scene["config"] = _prefixed("params", FieldConfig().replace, **params)
    for key, name, check in (("delta_time", "dt", number), ("goal_tolerance", "goal_tolerance", number),
                             ("max_iterations", "max_iterations", integer)):
        if key in data:
            scene[name] = check(key, data[key])
    return scene


def _prefixed(prefix: str, call: Any, *args: Any, **kwargs: Any) -> Any:
    """``call(...)``, with the field of an ``InvalidInput`` it raises placed under ``prefix``."""
    from pfield.interfaces.convert import prefixed

    try:
        return call(*args, **kwargs)
    except InvalidInput as exc:
        raise prefixed(exc, prefix) from None


def _obstacle_message(parse: Any, model: Any, entry: Any, where: str) -> Any:
    return _prefixed(where, parse, model, {"group": "Static"} | _mapping(entry, where))
