"""The CLI's defects of hostile or mistaken input, and the ros2 verbs users reach for, against a real server."""

from __future__ import annotations

import math
import os
import subprocess
from pathlib import Path

import httpx
import pytest
import yaml
from pfield_node_server import PFIELD, REPO, NodeServer

from pfield import __version__
from pfield.cli._introspection import rate_statistics
from pfield.interfaces._yaml import MAX_DEPTH, load_yaml

DEEP_FLOW = "[" * 2000 + "]" * 2000
DEEP_MAPPING = "{a: " * 2000 + "1" + "}" * 2000
DEEP_JSON = '{"a": ' * 2000 + "1" + "}" * 2000


def _clean_error(done: subprocess.CompletedProcess[str], *phrases: str) -> None:
    """A failure with exit status != 0, the phrases on stderr, and no traceback anywhere."""
    assert done.returncode != 0
    assert "Traceback" not in done.stderr + done.stdout
    for phrase in phrases:
        assert phrase in done.stderr


# -- YAML nested 2 000 deep: a clear error, no traceback ---------------------------------------------------

@pytest.mark.parametrize("text", [DEEP_FLOW, DEEP_MAPPING, DEEP_JSON], ids=["flow", "mapping", "json"])
def test_deep_yaml_argument_is_refused_clearly(node_server: NodeServer, text: str) -> None:
    before = node_server.obstacle_ids()
    published = node_server.cli("topic", "pub", "--once", "/pfield/obstacles",
                                "potential_fields_interfaces/msg/ObstacleArray", text)
    _clean_error(published, f"nested deeper than {MAX_DEPTH} levels")
    called = node_server.cli("service", "call", "/pfield/plan_path", "potential_fields_interfaces/srv/PlanPath", text)
    _clean_error(called, f"nested deeper than {MAX_DEPTH} levels")
    assert node_server.obstacle_ids() == before


def test_deep_parameter_value_and_files_are_refused_clearly(node_server: NodeServer, tmp_path: Path) -> None:
    before = httpx.get(f"{node_server.url}/param/pfield_manager").json()
    _clean_error(node_server.cli("param", "set", "/pfield_manager", "repulsive_gain", DEEP_FLOW),
                 "repulsive_gain", "nested deeper")
    deep_file = tmp_path / "deep.yaml"
    deep_file.write_text("pfield_manager:\n  ros__parameters:\n    repulsive_gain: " + DEEP_FLOW + "\n")
    _clean_error(node_server.cli("param", "load", "/pfield_manager", str(deep_file)), "deep.yaml", "nested deeper")
    assert httpx.get(f"{node_server.url}/param/pfield_manager").json() == before
    served = subprocess.run([str(PFIELD), "serve", "--params", str(deep_file), "--port", "1"], capture_output=True,
                            text=True, cwd=REPO, timeout=300, check=False)
    _clean_error(served, "--params", "nested deeper")


def test_yaml_depth_bound_keeps_ordinary_documents() -> None:
    nested = "[" * MAX_DEPTH + "]" * MAX_DEPTH
    value = load_yaml(nested)
    for _ in range(MAX_DEPTH - 1):
        value = value[0]
    assert value == []
    assert load_yaml("{a: [1, {b: 2.5}], c: .nan}")["a"] == [1, {"b": 2.5}]
    with pytest.raises(ValueError, match="nested deeper than"):
        load_yaml("[" + nested + "]")


# -- topic pub --rate 0 or negative ---------------------------------------------------------------------------

@pytest.mark.parametrize(("rate", "reason"), [("0", "must be > 0"), ("-2", "must be > 0"), ("nan", "finite")])
def test_publish_rate_must_be_positive(node_server: NodeServer, rate: str, reason: str) -> None:
    done = node_server.cli("topic", "pub", "--times", "2", "--rate", rate, "/pfield/query_pose",
                           "geometry_msgs/msg/PoseStamped", "{}")
    _clean_error(done, "--rate", reason)
    assert "publishing" not in done.stderr


# -- topic echo on a topic nobody publishes ---------------------------------------------------------------------

def test_echo_says_it_waits_and_times_out(node_server: NodeServer) -> None:
    done = node_server.cli("topic", "echo", "/nobody/publishes/this", "--timeout", "1.5")
    _clean_error(done, "waiting for the first message on /nobody/publishes/this (Ctrl-C to stop)",
                 "no message on /nobody/publishes/this within 1.5 s")
    assert done.stdout == ""
    _clean_error(node_server.cli("topic", "echo", "/x", "--timeout", "0"), "--timeout", "must be > 0")


def test_echo_with_timeout_prints_the_latest_message(node_server: NodeServer) -> None:
    published = node_server.cli("topic", "pub", "--once", "/pfield/planning_goal_pose",
                                "geometry_msgs/msg/PoseStamped",
                                "{header: {frame_id: world}, pose: {position: {x: 0.25, y: 0.2, z: 0.4}}}")
    assert published.returncode == 0, published.stderr
    echoed = node_server.cli("topic", "echo", "--once", "--timeout", "30", "/pfield/planning_goal_pose")
    assert echoed.returncode == 0, echoed.stderr
    assert yaml.safe_load(echoed.stdout.split("---")[0])["pose"]["position"]["x"] == 0.25
    assert "waiting" not in echoed.stderr


# -- node list / node info --------------------------------------------------------------------------------------

def test_node_list_is_the_servers_nodes(node_server: NodeServer) -> None:
    done = node_server.cli("node", "list")
    assert done.returncode == 0
    assert done.stdout.split() == httpx.get(f"{node_server.url}/nodes").json()
    assert "/pfield_manager" in done.stdout.split()


def test_node_info_lists_what_the_node_uses(node_server: NodeServer) -> None:
    done = node_server.cli("node", "info", "pfield_manager")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == "/pfield_manager"
    topics = httpx.get(f"{node_server.url}/topics").json()
    services = httpx.get(f"{node_server.url}/services").json()
    parameters = httpx.get(f"{node_server.url}/param/pfield_manager").json()

    def section(title: str) -> list[str]:
        start = lines.index(f"  {title}:") + 1
        end = next((i for i in range(start, len(lines)) if not lines[i].startswith("    ")), len(lines))
        return lines[start:end]

    assert section("Subscribers") == [f"    {t['name']}: {t['type']}" for t in topics
                                      if "/pfield_manager" in t["subscribers"]]
    assert section("Publishers") == [f"    {t['name']}: {t['type']}" for t in topics
                                     if "/pfield_manager" in t["publishers"]]
    assert "    /pfield/obstacles: potential_fields_interfaces/msg/ObstacleArray" in section("Subscribers")
    assert section("Service Servers") == [f"    {s['name']}: {s['type']}" for s in services
                                          if s["node"] == "/pfield_manager"]
    assert "    /pfield/plan_path: potential_fields_interfaces/srv/PlanPath" in section("Service Servers")
    assert [line.split(":")[0].strip() for line in section("Parameters")] == list(parameters)
    _clean_error(node_server.cli("node", "info", "/nobody"), "node /nobody not found", "/pfield_manager")


# -- topic type / info / hz -------------------------------------------------------------------------------------

def test_topic_type_and_info(node_server: NodeServer) -> None:
    typed = node_server.cli("topic", "type", "/pfield/obstacles")
    assert typed.returncode == 0 and typed.stdout == "potential_fields_interfaces/msg/ObstacleArray\n"
    entry = next(t for t in httpx.get(f"{node_server.url}/topics").json() if t["name"] == "/pfield/markers")
    info = node_server.cli("topic", "info", "/pfield/markers")
    assert info.returncode == 0
    assert info.stdout.splitlines() == [f"Type: {entry['type']}", f"Publisher count: {len(entry['publishers'])}",
                                        f"Subscription count: {len(entry['subscribers'])}"]
    verbose = node_server.cli("topic", "info", "-v", "/pfield/obstacles").stdout.splitlines()
    assert verbose[-2:] == ["Subscription count: 1", "  Node name: /pfield_manager"]
    _clean_error(node_server.cli("topic", "type", "/not/a/topic"), "unknown topic /not/a/topic")
    _clean_error(node_server.cli("topic", "info", "/not/a/topic"), "unknown topic /not/a/topic")


def test_rate_statistics_are_exact() -> None:
    rate, low, high, deviation = rate_statistics([0.0, 0.1, 0.3])
    assert math.isclose(rate, 1 / 0.15) and math.isclose(low, 0.1) and math.isclose(high, 0.2)
    assert math.isclose(deviation, 0.05)


def test_topic_hz_measures_a_publisher(node_server: NodeServer) -> None:
    env = os.environ | {"PFIELD_URL": node_server.url}
    publisher = subprocess.Popen([str(PFIELD), "topic", "pub", "--rate", "20", "--times", "400", "/hz/probe",
                                  "geometry_msgs/msg/Point", "{x: 1.0}"], env=env, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
    try:
        done = node_server.cli("topic", "hz", "/hz/probe", "--duration", "4", "--timeout", "60")
    finally:
        publisher.kill()
        publisher.wait()
    assert done.returncode == 0, done.stderr
    rate_line, period_line = done.stdout.splitlines()[-2:]
    rate = float(rate_line.removeprefix("average rate: "))
    assert math.isfinite(rate) and rate > 0
    fields = period_line.split()
    assert fields[0] == "min:" and fields[2] == "max:" and fields[4:6] == ["std", "dev:"] and fields[7] == "window:"
    assert float(fields[1].rstrip("s")) <= float(fields[3].rstrip("s")) and int(fields[8]) >= 1
    _clean_error(node_server.cli("topic", "hz", "/hz/silent", "--timeout", "1"), "no message on /hz/silent")


# -- param load / describe --------------------------------------------------------------------------------------

def test_param_load_sets_the_nodes_section_all_or_nothing(node_server: NodeServer, tmp_path: Path) -> None:
    url = f"{node_server.url}/param/pfield_manager"
    before = httpx.get(url).json()
    good = tmp_path / "good.yaml"
    good.write_text("pfield_manager:\n  ros__parameters:\n    repulsive_gain: 0.45\n"
                    "/**:\n  ros__parameters:\n    influence_distance: 0.2\n    no_such_parameter_here: 1\n")
    try:
        done = node_server.cli("param", "load", "/pfield_manager", str(good))
        assert done.returncode == 0, done.stderr
        assert sorted(done.stdout.splitlines()) == ["Set parameter influence_distance successful",
                                                    "Set parameter repulsive_gain successful"]
        after = httpx.get(url).json()
        assert after == before | {"repulsive_gain": 0.45, "influence_distance": 0.2}
        bad = tmp_path / "bad.yaml"
        bad.write_text("pfield_manager:\n  ros__parameters:\n    attractive_gain: 2.0\n    repulsive_gain: -1.0\n")
        _clean_error(node_server.cli("param", "load", "/pfield_manager", str(bad)), "repulsive_gain")
        assert httpx.get(url).json() == after
        other = tmp_path / "other.yaml"
        other.write_text("costmap:\n  ros__parameters:\n    robot_radius: 0.3\n")
        _clean_error(node_server.cli("param", "load", "/pfield_manager", str(other)), "no parameters for")
        _clean_error(node_server.cli("param", "load", "/pfield_manager", str(tmp_path / "missing.yaml")),
                     "missing.yaml")
    finally:
        httpx.put(url, json=before).raise_for_status()


def test_param_describe_unknown_node_is_a_clear_error(node_server: NodeServer) -> None:
    _clean_error(node_server.cli("param", "describe", "/nobody", "x"), "node /nobody not found")


# -- --version and shell completion -----------------------------------------------------------------------------

def test_version() -> None:
    done = subprocess.run([str(PFIELD), "--version"], capture_output=True, text=True, check=False)
    assert done.returncode == 0 and done.stdout == f"pfield {__version__}\n"


def test_shell_completion_is_enabled() -> None:
    shown = subprocess.run([str(PFIELD), "--show-completion", "bash"], capture_output=True, text=True, check=False)
    assert shown.returncode == 0 and "_PFIELD_COMPLETE=complete_bash" in shown.stdout
    env = os.environ | {"_PFIELD_COMPLETE": "complete_bash", "COMP_WORDS": "pfield topic h", "COMP_CWORD": "2"}
    completed = subprocess.run([str(PFIELD)], capture_output=True, text=True, env=env, check=False)
    assert completed.stdout.split() == ["hz"]
