"""What the client scripts of the ROS 2 tests share: the names of pfield's ROS interfaces and the run that
drives a node phase by phase and writes what it observed to ``$ROS2_TEST_OUT/results.json``."""

from __future__ import annotations

import json
import os
import time
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ros2_helpers.client import BlockingClient

OBSTACLES = "potential_fields_interfaces/msg/ObstacleArray"
PLAN = ("/pfield/plan_path", "potential_fields_interfaces/srv/PlanPath")
AUTONOMY = ("/pfield/compute_autonomy_vector", "potential_fields_interfaces/srv/ComputeAutonomyVector")
REMOVE = ("/pfield/remove_obstacles", "potential_fields_interfaces/srv/RemoveObstacles")
NODE = "/pfield_manager"

Phase = Callable[[BlockingClient, dict[str, Any]], None]
"""One step of a scenario: drives the node through the client and records what it saw in the results."""


def remaining(client: BlockingClient) -> list[str]:
    """The obstacle ids the node holds, in its order (a RemoveObstacles call that removes nothing)."""
    return client.call(*REMOVE, {"frame_ids": []})["remaining"]


def run_phases(phases: Sequence[Phase]) -> None:
    """Run ``phases`` in order with one client, then write the results: the seconds since the start after
    each phase under ``timeline``, and the traceback of an exception (which ends the run) under ``error``."""
    results: dict[str, Any] = {}
    start = time.perf_counter()
    client = BlockingClient()
    timeline = results["timeline"] = {}
    try:
        for phase in phases:
            phase(client, results)
            timeline[phase.__name__] = round(time.perf_counter() - start, 2)
    except Exception:
        results["error"] = traceback.format_exc()
    finally:
        client.close()
        Path(os.environ["ROS2_TEST_OUT"], "results.json").write_text(json.dumps(results, indent=1))
