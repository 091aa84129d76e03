"""Control-loop calls the manager knows to be quick are answered on the HTTP server's event loop; the first of
a kind, one after a change of the scene and a slow one go to the calls thread (a real server on 127.0.0.1)."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from pfield.interfaces import message_from_yaml
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.geometry_msgs import PoseStamped
from pfield.node import manager as manager_module
from pfield.node._base import Bus
from pfield.node.manager import ManagerNode
from pfield.transport.http import ServerThread, create_app

BALL = "{frame_id: '%s', type: 'Sphere', group: 'Dynamic', pose: {position: {x: %s, y: 0.0, z: 0.3}}, radius: 0.05}"
ASSIST = {"query_pose": {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.3}}},
          "user_command": {"twist": {"linear": {"x": 0.02}}}}
AUTONOMY = {"planning_method": "whole_body", "joint_angles": [0, -0.3, 0, 0.6, 0, 0.9, 0], "delta_time": 0.01}


class ThreadNotingManager(ManagerNode):
    """The manager, noting the thread each control-loop call runs on."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.threads: list[str] = []

    def compute_autonomy_vector(self, request: Any) -> Any:
        self.threads.append(threading.current_thread().name)
        return super().compute_autonomy_vector(request)

    def compute_assistance(self, request: Any) -> Any:
        self.threads.append(threading.current_thread().name)
        return super().compute_assistance(request)


def publish_balls(node: ManagerNode, *xs: float) -> None:
    balls = ", ".join(BALL % (f"ball{i}", x) for i, x in enumerate(xs))
    node.on_obstacles(message_from_yaml(pfi.ObstacleArray, f"{{obstacles: [{balls}]}}"))


@pytest.fixture
def served(monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[ThreadNotingManager, httpx.Client]]:
    """A served manager with one ball and a goal; every call counts as quick (the bound raised to 10 s: which
    thread answers must not depend on this machine's speed), except where a test lowers it."""
    from pfield.robot import RobotModel

    monkeypatch.setattr(manager_module, "QUICK_CALL_SECONDS", 10.0)
    manager = ThreadNotingManager(Bus(), RobotModel.builtin("xarm7"))
    publish_balls(manager, 0.5)
    manager.on_goal(message_from_yaml(PoseStamped, "{pose: {position: {x: 0.8, y: 0.0, z: 0.3}}}"))
    with ServerThread(create_app([manager])) as server, httpx.Client(base_url=server.url) as client:
        yield manager, client


def call(client: httpx.Client, service: str, body: dict[str, Any]) -> dict[str, Any]:
    answer = client.post(f"/srv/pfield/{service}", json=body)
    assert answer.status_code == 200, answer.text
    return dict(answer.json())


def without_stamps(answer: dict[str, Any]) -> str:
    for value in answer.values():
        if isinstance(value, dict) and "header" in value:
            value["header"].pop("stamp")
    return json.dumps(answer, sort_keys=True)


def where(manager: ThreadNotingManager) -> list[str]:
    """``calls`` or ``loop`` for each call so far (then forgets them)."""
    names = ["calls" if name.startswith("pfield-calls") else "loop" if name == "pfield-http" else name
             for name in manager.threads]
    manager.threads.clear()
    return names


def test_repeated_calls_run_on_the_loop_with_the_same_answers(served: tuple[ThreadNotingManager, httpx.Client]
                                                             ) -> None:
    manager, client = served
    answers = [without_stamps(call(client, "compute_assistance", ASSIST)) for _ in range(3)]
    assert where(manager) == ["calls", "loop", "loop"]
    assert answers[0] == answers[1] == answers[2]
    vectors = [without_stamps(call(client, "compute_autonomy_vector", AUTONOMY)) for _ in range(2)]
    assert where(manager) == ["calls", "loop"]  # another kind of call: measured once on the thread first
    assert vectors[0] == vectors[1]


def test_a_changed_scene_or_more_obstacles_go_to_the_thread_first(served: tuple[ThreadNotingManager, httpx.Client]
                                                                  ) -> None:
    manager, client = served
    for _ in range(2):
        call(client, "compute_assistance", ASSIST)
    publish_balls(manager, 0.55)  # the same count, a new scene: its field is built on the thread
    for _ in range(2):
        call(client, "compute_assistance", ASSIST)
    publish_balls(manager, 0.55, 0.7)  # more obstacles than the measured call had
    for _ in range(2):
        call(client, "compute_assistance", ASSIST)
    assert where(manager) == ["calls", "loop", "calls", "loop", "calls", "loop"]


def test_bad_input_on_the_quick_path_is_refused_and_changes_nothing(
        served: tuple[ThreadNotingManager, httpx.Client]) -> None:
    manager, client = served
    good = without_stamps(call(client, "compute_assistance", ASSIST))
    before = manager.state
    refused = client.post("/srv/pfield/compute_assistance", json=ASSIST | {"arbitration": "boss"})
    assert refused.status_code == 400 and refused.json()["field"] == "arbitration"
    malformed = client.post("/srv/pfield/compute_assistance", content=b'{"query_pose": ',
                            headers={"content-type": "application/json"})
    assert malformed.status_code == 400 and malformed.json()["field"].startswith("body")
    mistyped = client.post("/srv/pfield/compute_assistance", json=ASSIST | {"delta_time": "fast"})
    assert mistyped.status_code == 400 and "delta_time" in mistyped.json()["field"]
    assert manager.state is before
    assert without_stamps(call(client, "compute_assistance", ASSIST)) == good
    assert where(manager) == ["calls", "loop", "loop"]  # the refused decodes never reached the handler


def test_calls_slower_than_the_bound_stay_on_the_thread(served: tuple[ThreadNotingManager, httpx.Client],
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    manager, client = served
    monkeypatch.setattr(manager_module, "QUICK_CALL_SECONDS", 0.0)
    for _ in range(3):
        call(client, "compute_assistance", ASSIST)
    assert where(manager) == ["calls", "calls", "calls"]
    monkeypatch.setattr(manager_module, "QUICK_CALL_SECONDS", 10.0)  # the bound is read at each call
    for _ in range(2):
        call(client, "compute_assistance", ASSIST)
    assert where(manager) == ["loop", "loop"]
