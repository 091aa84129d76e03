"""The ros2 introspection verbs: ``node list|info``, ``topic hz|info|type`` and ``param load|describe``.

Like the other client verbs they talk to a running ``pfield serve`` (``--url``/``PFIELD_URL``) and print
what ``ros2`` prints for the same verb. Everything they show comes from the server's listings
(``GET /nodes``, ``/topics``, ``/services``, ``/param/<node>``) and, for ``topic hz``, the WebSocket stream.
"""

from __future__ import annotations

import itertools
import math
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from pfield.cli import _node_client as _c
from pfield.cli._exit_codes import USAGE
from pfield.cli._node import load_ros_parameters
from pfield.errors import PfieldError
from pfield.transport import DEFAULT_URL

if TYPE_CHECKING:
    import httpx

__all__ = ["register"]

node_app = typer.Typer(help="List nodes and show what one node subscribes, publishes, serves and sets.",
                       no_args_is_help=True)


def _node_name(node: str) -> str:
    return "/" + node.lstrip("/")


def _nodes(client: httpx.Client) -> list[str]:
    return [str(name) for name in _c._request(client, "GET", "/nodes")]


def _known_node(client: httpx.Client, node: str) -> str:
    name, nodes = _node_name(node), _nodes(client)
    if name not in nodes:
        _c._fail(f"node {name} not found; known: {', '.join(nodes) or 'none'} (`pfield node list`)", USAGE)
    return name


@node_app.command("list")
def node_list(url: _c.Url = DEFAULT_URL, token: _c.Token = None) -> None:
    """List the nodes the server runs."""
    with _c._client(url, token) as client:
        for name in _nodes(client):
            typer.echo(name)


@node_app.command("info")
def node_info(node: str, url: _c.Url = DEFAULT_URL, token: _c.Token = None) -> None:
    """Show a node's subscriptions, publications, services and parameters (as ``ros2 node info``)."""
    with _c._client(url, token) as client:
        name = _known_node(client, node)
        topics = _c._request(client, "GET", "/topics")
        services = _c._request(client, "GET", "/services")
        parameters = _c._request(client, "GET", _c._node_path(name))
    typer.echo(name)
    sections = (
        ("Subscribers", [(t["name"], t["type"]) for t in topics if name in t.get("subscribers", ())]),
        ("Publishers", [(t["name"], t["type"]) for t in topics if name in t.get("publishers", ())]),
        ("Service Servers", [(s["name"], s["type"]) for s in services if s.get("node") == name]),
    )
    for title, entries in sections:
        typer.echo(f"  {title}:")
        for entry_name, entry_type in entries:
            typer.echo(f"    {entry_name}: {entry_type}")
    typer.echo("  Parameters:")
    for key, value in parameters.items():
        typer.echo(f"    {key}: {_c.json.dumps(value)}")


def _topic_entry(client: httpx.Client, topic: str) -> dict[str, Any]:
    name = "/" + topic.lstrip("/")
    for entry in _c._request(client, "GET", "/topics"):
        if entry["name"] == name:
            return dict(entry)
    _c._fail(f"unknown topic {name} (`pfield topic list` lists the topics)", USAGE)


@_c.topic_app.command("type")
def topic_type(topic: str, url: _c.Url = DEFAULT_URL, token: _c.Token = None) -> None:
    """Print the message type of a topic."""
    with _c._client(url, token) as client:
        entry = _topic_entry(client, topic)
    if not entry.get("type"):
        _c._fail(f"{entry['name']} has no known type yet (no node declares it and nothing was published)")
    typer.echo(entry["type"])


@_c.topic_app.command("info")
def topic_info(topic: str,
               verbose: Annotated[bool, typer.Option("--verbose", "-v", help="also name the nodes")] = False,
               url: _c.Url = DEFAULT_URL, token: _c.Token = None) -> None:
    """Print a topic's type and how many nodes publish and subscribe to it (as ``ros2 topic info``)."""
    with _c._client(url, token) as client:
        entry = _topic_entry(client, topic)
    publishers, subscribers = list(entry.get("publishers", ())), list(entry.get("subscribers", ()))
    typer.echo(f"Type: {entry.get('type') or 'unknown'}")
    typer.echo(f"Publisher count: {len(publishers)}")
    if verbose:
        for node in publishers:
            typer.echo(f"  Node name: {node}")
    typer.echo(f"Subscription count: {len(subscribers)}")
    if verbose:
        for node in subscribers:
            typer.echo(f"  Node name: {node}")


def rate_statistics(stamps: list[float]) -> tuple[float, float, float, float]:
    """(rate Hz, min period s, max period s, period standard deviation s) of arrival times ``stamps`` (s),
    as ``ros2 topic hz`` reports them: rate = 1 / mean period."""
    periods = [b - a for a, b in itertools.pairwise(stamps)]
    mean = sum(periods) / len(periods)
    deviation = math.sqrt(sum((p - mean) ** 2 for p in periods) / len(periods))
    return (1.0 / mean if mean > 0 else math.inf), min(periods), max(periods), deviation


@_c.topic_app.command("hz")
def topic_hz(topic: str,
             window: Annotated[int, typer.Option("--window", "-w", min=2, help="messages the rate is taken over")]
             = 100,
             duration: Annotated[float | None, typer.Option(help="measure this many seconds, then exit")] = None,
             timeout: _c.TimeoutOption = None,
             url: _c.Url = DEFAULT_URL, token: _c.Token = None) -> None:
    """Print a topic's publishing rate once a second, over the last --window messages (as ``ros2 topic hz``).

    The message the server replays on connect (its latest) only starts the clock.
    """
    from websockets.exceptions import WebSocketException

    from pfield._validation import positive

    limit = None if timeout is None else _c._local(positive, "--timeout", timeout)
    seconds = None if duration is None else _c._local(positive, "--duration", duration)
    name = "/" + topic.lstrip("/")
    stamps: list[float] = []
    try:
        with _c._topic_socket(topic, url, token) as socket:
            # the first frame (the replayed latest message, or the first new one) only starts the clock
            next(_c._messages(socket, topic, _shortest(limit, seconds)))
            stamps.append(time.monotonic())
            end = None if seconds is None else stamps[0] + seconds
            printed = stamps[0]
            while end is None or time.monotonic() < end:
                left = None if end is None else end - time.monotonic()
                if _c._receive(socket, _shortest(limit, left)) is None:
                    if end is not None and time.monotonic() >= end:
                        break
                    _c._fail(f"no message on {name} within {limit:g} s")
                stamps.append(time.monotonic())
                del stamps[:-(window + 1)]
                if stamps[-1] - printed >= 1.0:
                    _print_rate(stamps)
                    printed = stamps[-1]
    except (OSError, WebSocketException) as exc:
        _c._fail(f"cannot stream {name} from {url}: {exc}")
    if len(stamps) < 2:
        _c._fail(f"fewer than two messages on {name} in {seconds:g} s: no rate")
    _print_rate(stamps)


def _shortest(*waits: float | None) -> float | None:
    """The shortest of the given waits (s); None (for ever) when none is given."""
    given = [w for w in waits if w is not None]
    return max(min(given), 0.0) if given else None


def _print_rate(stamps: list[float]) -> None:
    rate, low, high, deviation = rate_statistics(stamps)
    typer.echo(f"average rate: {rate:.3f}\n\tmin: {low:.3f}s max: {high:.3f}s std dev: {deviation:.5f}s "
               f"window: {len(stamps) - 1}")


@_c.param_app.command("load")
def param_load(node: str, file: Annotated[Path, typer.Argument(metavar="FILE.yaml", help="ROS 2 parameters file")],
               url: _c.Url = DEFAULT_URL, token: _c.Token = None) -> None:
    """Set a node's parameters from a ROS 2 parameters file (its ``NODE: ros__parameters:`` and ``/**``
    sections); the node validates them all and changes nothing on error."""
    try:
        sections = load_ros_parameters(file, "FILE")
    except PfieldError as exc:
        _c._fail(str(exc), USAGE)
    with _c._client(url, token) as client:
        name = _known_node(client, node)
        current = _c._request(client, "GET", _c._node_path(name))
        values = {k: v for k, v in sections.get("/**", {}).items() if k in current} | sections.get(name, {})
        if not values:
            _c._fail(f"{file} has no parameters for {name} (expected a '{name.lstrip('/')}:' or '/**:' section "
                     "with ros__parameters)", USAGE)
        _c._request(client, "PUT", _c._node_path(name), _c.json.dumps(values))
    for key in values:
        typer.echo(f"Set parameter {key} successful")


_DESCRIPTION_FIELDS = ("type", "description", "range", "default", "read_only")


@_c.param_app.command("describe")
def param_describe(node: str, names: Annotated[list[str], typer.Argument(metavar="NAME...")],
                   url: _c.Url = DEFAULT_URL, token: _c.Token = None) -> None:
    """Show parameters' type, description, range, default and whether they are read-only."""
    with _c._client(url, token) as client:
        name = _known_node(client, node)
        described = _c._request(client, "GET", _c._node_path(name), params={"describe": "true"})
    if not isinstance(described, dict) or not all(isinstance(v, dict) and "type" in v for v in described.values()):
        _c._fail(f"the server does not describe {name}'s parameters (GET /param{name}?describe=true answered "
                 "plain values): update pfield on the server")
    unknown = [n for n in names if n not in described]
    if unknown:
        _c._fail(f"{name} has no parameter {', '.join(map(repr, unknown))}; known: {', '.join(described)}", USAGE)
    for parameter in names:
        _print_description(parameter, described[parameter])


def _print_description(name: str, info: dict[str, Any]) -> None:
    typer.echo(f"Parameter name: {name}")
    typer.echo(f"  Type: {info.get('type')}")
    if info.get("description"):
        typer.echo(f"  Description: {info['description']}")
    bounds = info.get("range")
    if isinstance(bounds, list | tuple) and len(bounds) == 2:
        bounds = {"min": bounds[0], "max": bounds[1]}
    if isinstance(bounds, dict) and bounds:
        typer.echo("  Constraints:")
        for key, value in bounds.items():
            typer.echo(f"    {key.replace('_', ' ').capitalize()} value: {_c.json.dumps(value)}"
                       if key in ("min", "max") else f"    {key}: {_c.json.dumps(value)}")
    elif bounds:
        typer.echo(f"  Constraints: {bounds}")
    if "default" in info:
        typer.echo(f"  Default: {_c.json.dumps(info['default'])}")
    typer.echo(f"  Read only: {'true' if info.get('read_only') else 'false'}")


def register(app: typer.Typer) -> None:
    """Add the ``node`` group (``topic``/``param`` verbs attach to their groups at import)."""
    app.add_typer(node_app, name="node")
