"""Demo section: a scripted session with the standalone node, as a user would drive it with the CLI.

Starts ``/pfield_manager`` (xArm7) behind the HTTP server on a free 127.0.0.1 port, publishes the seed's
six obstacles (the mesh one from a small package written into the output folder), calls the seed's
``plan_path`` (task_space and whole_body) and ``compute_autonomy_vector`` (both methods), shows the
answers, then stops the node. The requests are the seed's YAML texts, parsed by ROS's rules.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import httpx
from rich.console import Console
from rich.table import Table

TITLE = "Standalone node session (the example CLI requests over HTTP)"

_GOAL_POSITION = (0.5, 0.2, 0.4)
_ORIENTATION = "orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}"
_GOAL = f"goal: {{position: {{x: 0.5, y: 0.2, z: 0.4}}, {_ORIENTATION}}}"
_OBSTACLES = [
    "{frame_id: 'ball', type: 'Sphere', group: 'Static', pose: {position: {x: 0.4, y: 0.0, z: 0.1}, "
    "orientation: {w: 1.0}}, radius: 0.1}",
    "{frame_id: 'table', type: 'Box', group: 'Static', pose: {position: {x: 0.66, y: 0.0, z: 0.3}, "
    "orientation: {w: 1.0}}, length: 0.15, width: 0.7, height: 0.6}",
    "{frame_id: 'pitcher', type: 'Cylinder', group: 'Static', pose: {position: {x: 0.51, y: 0.0, z: 0.15}, "
    "orientation: {w: 1.0}}, radius: 0.09, height: 0.3}",
    "{frame_id: 'ellipsoid_obs', type: 'Ellipsoid', group: 'Static', pose: {position: {x: 0.5, y: 0.1, z: 0.2}, "
    "orientation: {w: 1.0}}, semi_x: 0.08, semi_y: 0.05, semi_z: 0.12}",
    "{frame_id: 'capsule_obs', type: 'Capsule', group: 'Static', pose: {position: {x: 0.45, y: 0.0, z: 0.2}, "
    "orientation: {w: 1.0}}, radius: 0.05, height: 0.2}",
    "{frame_id: 'mesh_obs', type: 'Mesh', group: 'Static', pose: {position: {x: 0.5, y: 0.0, z: 0.1}, "
    "orientation: {w: 1.0}}, mesh_resource: 'package://my_robot_description/meshes/obstacle.dae', "
    "scale_x: 1.0, scale_y: 1.0, scale_z: 1.0}",
]
_PLANS = {
    "task_space": "{start: {position: {x: 0.227, y: 0.0, z: 0.294}, " + _ORIENTATION + "}, " + _GOAL +
                  ", delta_time: 0.02, goal_tolerance: 0.01, max_iterations: 25000, planning_method: 'task_space'}",
    "whole_body": "{" + _GOAL + ", starting_joint_angles: [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], "
                  "delta_time: 0.02, goal_tolerance: 0.01, max_iterations: 25000, planning_method: 'whole_body'}",
}
_QUERY = "query_pose: {header: {frame_id: 'world'}, pose: {position: {x: 0.3, y: 0.1, z: 0.35}, " + _ORIENTATION + "}}"
# A whole-body query pose is only a cross-check of the joint angles: the node logs a warning when it is more
# than 1 cm / 0.05 rad from FK(joint_angles). The demo sends the arm's actual pose at these joint angles
# (FK of (0, 0, 0, 0, 0, -1.5708, 0) is (0.227, 0.0, 0.2935) with the tool forward), so nothing is flagged.
_WHOLE_BODY_QUERY = ("query_pose: {header: {frame_id: 'world'}, pose: {position: {x: 0.227, y: 0.0, z: 0.2935}, "
                     + _ORIENTATION + "}}")
_AUTONOMY = {
    "task_space": "{" + _QUERY + ", delta_time: 0.02, planning_method: 'task_space'}",
    "whole_body": "{" + _WHOLE_BODY_QUERY + ", joint_angles: [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], "
                  "prev_joint_velocities: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], delta_time: 0.02, "
                  "planning_method: 'whole_body'}",
}


def _write_mesh_package(out_dir: Path) -> Path:
    """A tiny ``my_robot_description`` package with an 8 cm cube as ``meshes/obstacle.dae``."""
    import trimesh

    package = out_dir / "my_robot_description"
    (package / "meshes").mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=(0.08, 0.08, 0.08)).export(package / "meshes" / "obstacle.dae")
    return package


def _post(client: httpx.Client, path: str, model: Any, text: str) -> dict[str, Any]:
    from pfield.interfaces import message_from_yaml

    answer = client.post(path, content=message_from_yaml(model, text).model_dump_json(),
                         headers={"content-type": "application/json"})
    if answer.status_code >= 400:
        try:
            reason = answer.json().get("error")
        except ValueError:
            reason = answer.text
        raise RuntimeError(f"{path}: {reason}")
    return dict(answer.json())


def _plan_row(method: str, response: dict[str, Any], seconds: float) -> list[str]:
    poses = response["end_effector_path"]["poses"]
    end = poses[-1]["pose"]["position"]
    error = math.dist((end["x"], end["y"], end["z"]), _GOAL_POSITION)
    return [method, str(response["success"]), str(len(poses)), f"{error * 1000:.2f}", f"{seconds:.2f}",
            str(len(response["joint_trajectory"]["joint_names"])), response["error_message"] or "-"]


def run(out_dir: Path, console: Console) -> None:
    from pfield.interfaces import potential_fields_interfaces as pfi
    from pfield.node import Bus, make_resolver
    from pfield.node.manager import ManagerNode
    from pfield.robot import RobotModel
    from pfield.transport.http import ServerThread, create_app

    package = _write_mesh_package(out_dir)
    node = ManagerNode(Bus(), RobotModel.builtin("xarm7"),
                       resolver=make_resolver({"my_robot_description": package}, []), csv_dir=out_dir / "plans")
    with ServerThread(create_app([node])) as server, httpx.Client(base_url=server.url, timeout=None) as client:
        console.print(f"node /pfield_manager serving on {server.url}")
        for text in _OBSTACLES:
            _post(client, "/topic/pfield/obstacles", pfi.ObstacleArray,
                  "{header: {frame_id: 'world'}, obstacles: [" + text + "]}")
        console.print(f"published {len(_OBSTACLES)} obstacles: {', '.join(o.id for o in node.obstacles())}")
        paths: dict[str, list[list[float]]] = {}
        failures = _show_plans(client, console, paths) + _show_autonomy(client, console)
        markers = client.get("/topic/pfield/markers").json()["markers"]
    console.print(f"node stopped; plans saved as CSV in {out_dir / 'plans'}")
    if paths:
        console.print(f"paths drawn in {_plot_paths(out_dir / 'node_session_paths.png', paths, markers)}")
    if failures:
        raise RuntimeError("; ".join(failures))


def _show_plans(client: httpx.Client, console: Console, paths: dict[str, list[list[float]]]) -> list[str]:
    from pfield.interfaces import potential_fields_interfaces as pfi

    failures = []
    plans = Table("method", "success", "steps", "end error mm", "time s", "joints", "error_message",
                  title="pfield service call /pfield/plan_path")
    for method, text in _PLANS.items():
        start = time.perf_counter()
        try:
            response = _post(client, "/srv/pfield/plan_path", pfi.PlanPath_Request, text)
        except RuntimeError as exc:
            failures.append(str(exc))
            plans.add_row(method, "error", "", "", "", "", str(exc))
            continue
        plans.add_row(*_plan_row(method, response, time.perf_counter() - start))
        paths[method] = [[p["pose"]["position"][k] for k in "xyz"] for p in response["end_effector_path"]["poses"]]
        if not response["success"]:
            failures.append(f"{method} plan: {response['error_message']}")
    console.print(plans)
    return failures


def _show_autonomy(client: httpx.Client, console: Console) -> list[str]:
    from pfield.interfaces import potential_fields_interfaces as pfi

    failures = []
    vectors = Table("method", "linear (m/s)", "angular (rad/s)", title="/pfield/compute_autonomy_vector")
    for method, text in _AUTONOMY.items():
        try:
            twist = _post(client, "/srv/pfield/compute_autonomy_vector", pfi.ComputeAutonomyVector_Request,
                          text)["autonomy_vector"]["twist"]
        except RuntimeError as exc:
            failures.append(str(exc))
            vectors.add_row(method, "error", str(exc))
            continue
        vectors.add_row(method, *(", ".join(f"{twist[part][k]:+.4f}" for k in "xyz") for part in ("linear", "angular")))
    console.print(vectors)
    return failures


def _plot_paths(target: Path, paths: dict[str, list[list[float]]], markers: list[dict[str, Any]]) -> Path:
    """Top (x–y) and side (x–z) views of the planned paths over the obstacles' marker extents (axis-aligned,
    as all seed obstacles are)."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Ellipse, Rectangle

    figure, axes = plt.subplots(1, 2, figsize=(12, 5.5))
    # the first plan as a wide translucent band, the next ones thin and dashed on it: where they coincide, both show
    styles = [{"color": "tab:blue", "linestyle": "-", "linewidth": 6.0, "alpha": 0.35},
              {"color": "tab:orange", "linestyle": "--", "linewidth": 1.6, "marker": ".", "markevery": 12}]
    palette = plt.get_cmap("tab10")
    colours = [palette(k) for k in range(10)]
    names = sorted({str(m.get("text")) for m in markers if m["ns"] == "obstacles" and m.get("text")})
    for axis, (i, j), label in zip(axes, ((0, 1), (0, 2)), ("top view (x–y)", "side view (x–z)"), strict=True):
        for marker in markers:
            if marker["ns"] not in ("obstacles", "influence") or marker["type"] == 10:  # mesh: its sphere shows
                continue
            centre = [marker["pose"]["position"][k] for k in "xyz"]
            size = [marker["scale"][k] for k in "xyz"]
            alpha = 0.5 if marker["ns"] == "obstacles" else 0.12
            boxy = marker["type"] == 1 or (marker["type"] == 3 and j == 2)  # CUBE; CYLINDER seen from the side
            patch = (Rectangle((centre[i] - size[i] / 2, centre[j] - size[j] / 2), size[i], size[j]) if boxy
                     else Ellipse((centre[i], centre[j]), size[i], size[j]))
            name = str(marker.get("text") or "")
            colour = colours[names.index(name) % len(colours)] if name in names else "grey"
            patch.set(color=colour, alpha=alpha * 0.8)
            if marker["ns"] == "obstacles" and axis is axes[1]:  # each obstacle named once, in the legend
                patch.set_label(name)
            axis.add_patch(patch)
        for (method, points), style in zip(paths.items(), styles * len(paths), strict=False):
            xs, ys = [p[i] for p in points], [p[j] for p in points]
            axis.plot(xs, ys, label=method, **style)
            axis.plot(xs[0], ys[0], "ko", markersize=4)
        axis.plot(_GOAL_POSITION[i], _GOAL_POSITION[j], "*", color="gold", markeredgecolor="k", markersize=15,
                  label="goal")
        axis.set_title(label)
        axis.set_aspect("equal")
        axis.set_xlabel("xyz"[i] + " (m)")
        axis.set_ylabel("xyz"[j] + " (m)")
    axes[0].legend(loc="lower left", fontsize=8)
    axes[1].legend(loc="upper left", fontsize=7, ncols=2, title="obstacles", title_fontsize=8)
    figure.suptitle("Example plans through the node (obstacles as marker extents, influence zones light)")
    figure.savefig(target, dpi=110, bbox_inches="tight")
    plt.close(figure)
    return target
