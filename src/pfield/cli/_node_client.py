"""The ros2-like client verbs: ``topic``, ``service``, ``param`` and ``interface``.

They talk to a running ``pfield serve`` found through ``--url``, ``PFIELD_URL`` or http://127.0.0.1:8357
(token from ``--token``/``PFIELD_TOKEN``). YAML arguments are validated locally first (ROS's flow syntax
and default filling), so a typo is reported before anything is sent. Answers print as YAML; a failure prints
``error: ...`` on stderr and exits with status 2 when the command is wrong as given (a local check, or the node's
4xx refusal) or 1 when its outcome failed (:mod:`pfield.cli._exit_codes`); ``service call`` exits 1 when the
response says ``success: false``.
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Annotated, Any, NoReturn

import typer

from pfield.cli._exit_codes import FAILED, USAGE, for_http_status
from pfield.errors import PfieldError
from pfield.transport import DEFAULT_URL

if TYPE_CHECKING:
    import httpx

# A command imports what it uses when it runs (httpx, PyYAML, the message types of pfield.interfaces, numpy), so that
# every ``pfield`` process, a client verb's included, starts without the modules other commands need.

__all__ = ["register"]

Url = Annotated[str, typer.Option(envvar="PFIELD_URL", help="server address")]
Token = Annotated[str | None, typer.Option(envvar="PFIELD_TOKEN", help="bearer token of the server")]
ShowTypes = Annotated[bool, typer.Option("--show-types", "-t", help="also print each type")]
FieldOption = Annotated[str | None, typer.Option("--field", help="print only this field (dotted path, e.g. "
                                                 "pose.position; an integer indexes an array)")]
NoArrOption = Annotated[bool, typer.Option("--no-arr", help="show arrays as '<sequence type: T, length: N>'")]

topic_app = typer.Typer(help="Publish, echo and list topics.", no_args_is_help=True)
service_app = typer.Typer(help="Call and list services.", no_args_is_help=True)
param_app = typer.Typer(help="Get, set and dump node parameters.", no_args_is_help=True)
interface_app = typer.Typer(help="Show message and service definitions.", no_args_is_help=True)


def _fail(message: str, code: int = FAILED) -> NoReturn:
    """Print ``error: message`` on stderr and exit with ``code`` (``USAGE`` when the command is wrong as given)."""
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code)


def _print_yaml(data: Any) -> None:
    import yaml

    if not isinstance(data, dict | list):
        typer.echo(json.dumps(data) if data is None or isinstance(data, bool) else str(data))
        return
    typer.echo(yaml.safe_dump(data, sort_keys=False, default_flow_style=False).rstrip("\n"))


@contextmanager
def _client(url: str, token: str | None) -> Iterator[httpx.Client]:
    import httpx

    headers = {"Authorization": f"Bearer {token}"} if token else {}
    # certificates only for an https node: loading the CA bundle costs 40 ms, a tenth of a command's run
    verify = url.lower().startswith("https://")
    try:
        with httpx.Client(base_url=url.rstrip("/"), headers=headers, timeout=None, verify=verify) as client:
            yield client
    except httpx.TransportError as exc:
        _fail(_unreachable(url, exc))


def _unreachable(url: str, exc: BaseException) -> str:
    """What a command that found no node at ``url`` says, and what to do."""
    return f"cannot reach the pfield node at {url} ({exc}); start it with `pfield serve`"


def _request(client: httpx.Client, method: str, path: str, json_text: str | None = None, **kwargs: Any) -> Any:
    """Send ``json_text`` as the body if given; return the decoded answer, or fail with the server's error."""
    if json_text is not None:
        kwargs |= {"content": json_text, "headers": {"content-type": "application/json"}}
    response = client.request(method, path, **kwargs)
    if response.status_code >= 400:
        code = for_http_status(response.status_code)
        try:
            body = response.json()
        except ValueError:
            _fail(f"HTTP {response.status_code}: {response.text}", code)
        _fail((body.get("error") if isinstance(body, dict) else None) or json.dumps(body), code)
    return response.json()


def _local(parse: Any, *args: Any) -> Any:
    """``parse(*args)``, a check made before anything is sent: its error exits with ``USAGE``."""
    try:
        return parse(*args)
    except PfieldError as exc:
        _fail(str(exc), USAGE)


TimeoutOption = Annotated[float | None, typer.Option(
    "--timeout", help="give up (exit status 1) when no message arrives for this many seconds")]

_WAITING_AFTER = 0.5
"""s without a message after connecting before ``topic echo``/``hz`` say that they are waiting."""


@contextmanager
def _topic_socket(topic: str, url: str, token: str | None) -> Iterator[Any]:
    """The WebSocket stream of ``topic`` (the server sends its latest message first, if it has one)."""
    from websockets.sync.client import connect

    ws_url = url.rstrip("/").replace("http", "ws", 1) + f"/ws/topic/{topic.lstrip('/')}"
    headers = {"Authorization": f"Bearer {token}"} if token else None
    try:
        opened = connect(ws_url, additional_headers=headers, max_size=None)
    except OSError as exc:  # refused, no such host, no route, timed out: no node there, as every verb says
        _fail(_unreachable(url, exc))
    with opened as socket:
        yield socket


def _messages(socket: Any, topic: str, timeout: float | None) -> Iterator[str]:
    """The frames of ``socket``. Says on stderr that it waits when the first one does not come at once, and
    fails when ``timeout`` (s) passes without a frame."""
    from pfield._validation import positive

    limit = None if timeout is None else _local(positive, "--timeout", timeout)
    text = _receive(socket, _WAITING_AFTER if limit is None else min(_WAITING_AFTER, limit))
    if text is None:
        typer.echo(f"waiting for the first message on /{topic.lstrip('/')} (Ctrl-C to stop)", err=True)
        text = _receive(socket, None if limit is None else max(limit - _WAITING_AFTER, 0.0))
    while text is not None:
        yield text
        text = _receive(socket, limit)
    _fail(f"no message on /{topic.lstrip('/')} within {limit:g} s")


def _receive(socket: Any, timeout: float | None) -> str | None:
    """The next text frame, or None after ``timeout`` s (None: wait for ever)."""
    try:
        return str(socket.recv(timeout=timeout))
    except TimeoutError:
        return None


@topic_app.command("pub")
def topic_pub(topic: str, type_name: Annotated[str, typer.Argument(metavar="TYPE")],
              values: Annotated[str, typer.Argument(metavar="YAML")] = "",
              once: Annotated[bool, typer.Option("--once", "-1", help="publish one message and exit")] = False,
              times: Annotated[int, typer.Option("--times", "-t", help="publish this many messages")] = 0,
              rate: Annotated[float, typer.Option("--rate", "-r", help="messages per second")] = 1.0,
              url: Url = DEFAULT_URL, token: Token = None) -> None:
    """Publish a message given as YAML (ROS flow syntax), once or repeatedly at --rate."""
    from pfield._validation import positive
    from pfield.interfaces import lookup_type, message_from_yaml

    period = 1.0 / _local(positive, "--rate", rate)
    message = _local(message_from_yaml, _local(lookup_type, type_name), values)
    count = 1 if once else times
    with _client(url, token) as client:
        sent, start = 0, time.monotonic()
        while count == 0 or sent < count:
            if sent:  # on a fixed schedule, so the time a request takes does not lower the rate
                time.sleep(max(start + sent * period - time.monotonic(), 0.0))
            _request(client, "POST", f"/topic/{topic.lstrip('/')}", message.model_dump_json(),
                     params={"type": type_name})
            sent += 1
            typer.echo(f"publishing #{sent}: {type(message).ros_type}", err=True)


@topic_app.command("echo")
def topic_echo(topic: str, type_name: Annotated[str | None, typer.Argument(metavar="[TYPE]")] = None,
               once: Annotated[bool, typer.Option("--once", help="print one message and exit")] = False,
               timeout: TimeoutOption = None, field: FieldOption = None, no_arr: NoArrOption = False,
               url: Url = DEFAULT_URL, token: Token = None) -> None:
    """Print the messages of a topic as YAML (the latest one first), separated by ``---``."""
    from websockets.exceptions import WebSocketException

    from pfield.cli._message_view import MessageView, format_yaml
    from pfield.interfaces import lookup_type, registered_types

    view = MessageView(_local(lookup_type, type_name).ros_type if type_name else None)
    if type_name is None and (field or no_arr):  # the array types come from the topic's type
        with _client(url, token) as client:
            listed = {t["name"]: t["type"] for t in _request(client, "GET", "/topics")}
        known = listed.get("/" + topic.lstrip("/"))
        view = MessageView(known if known in registered_types() else None)
    try:
        with _topic_socket(topic, url, token) as socket:
            for text in _messages(socket, topic, timeout):
                typer.echo(format_yaml(_local(view.show, json.loads(text), field, no_arr)))
                typer.echo("---")
                if once:
                    return
    except BrokenPipeError:
        # The reader went away (``pfield topic echo ... | head``): stop quietly, as ``ros2 topic echo`` does.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, WebSocketException) as exc:
        _fail(f"cannot stream {topic} from {url}: {exc}")


def _echo_names(path: str, show_types: bool, url: str, token: str | None) -> None:
    """Print the ``name`` (with ``[type]`` when ``show_types``) of each entry the server lists at ``path``."""
    with _client(url, token) as client:
        for entry in _request(client, "GET", path):
            typer.echo(f"{entry['name']} [{entry['type']}]" if show_types else entry["name"])


@topic_app.command("list")
def topic_list(show_types: ShowTypes = False, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """List the topics the server knows (subscribed, published or seen)."""
    _echo_names("/topics", show_types, url, token)


@service_app.command("call")
def service_call(service: str, type_name: Annotated[str, typer.Argument(metavar="TYPE")],
                 values: Annotated[str, typer.Argument(metavar="YAML")] = "",
                 field: FieldOption = None, no_arr: NoArrOption = False,
                 exit_zero: Annotated[bool, typer.Option(
                     "--exit-zero", help="exit 0 even when the response says success: false (as ros2 service "
                                         "call does); errors still exit 1 or 2")] = False,
                 url: Url = DEFAULT_URL, token: Token = None) -> None:
    """Call a service with a request given as YAML; print the response as YAML (stdout).

    A response with a ``success`` field is followed by one line on stderr, ``success: false
    (error_message: ...)``, so the outcome of a long answer is the last line on the terminal; a false
    ``success`` exits with status 1 (0 with --exit-zero), so ``pfield service call ... && next`` stops there.
    """
    from pfield.cli._message_view import MessageView, format_yaml, outcome_line
    from pfield.interfaces import lookup_service, message_from_yaml

    service_type = _local(lookup_service, type_name)
    request = _local(message_from_yaml, service_type.request, values)
    name = "/" + service.lstrip("/")
    with _client(url, token) as client:
        served = {s["name"]: s["type"] for s in _request(client, "GET", "/services")}
        if name in served and lookup_service(served[name]).name != service_type.name:
            _fail(f"{name} is a {served[name]} service, not {type_name}", USAGE)
        typer.echo(f"requester: making request: {service_type.request.ros_type}", err=True)
        response = _request(client, "POST", f"/srv{name}", request.model_dump_json())
    shown = _local(MessageView(service_type.response.ros_type).show, response, field, no_arr)
    if not field:
        typer.echo("response:")
    typer.echo(format_yaml(shown))
    outcome = outcome_line(response)
    if outcome is not None:
        typer.echo(outcome, err=True)
    if isinstance(response, dict) and response.get("success") is False and not exit_zero:
        raise typer.Exit(FAILED)


@service_app.command("list")
def service_list(show_types: ShowTypes = False, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """List the services the server offers."""
    _echo_names("/services", show_types, url, token)


def _node_path(node: str) -> str:
    return "/param/" + node.lstrip("/")


@param_app.command("list")
def param_list(node: str, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """List a node's parameter names."""
    with _client(url, token) as client:
        for name in _request(client, "GET", _node_path(node)):
            typer.echo(f"  {name}")


@param_app.command("get")
def param_get(node: str, name: str, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """Print one parameter's value."""
    with _client(url, token) as client:
        values = _request(client, "GET", _node_path(node))
    if name not in values:
        _fail(f"{node} has no parameter {name!r}; known: {', '.join(values)}", USAGE)
    _print_yaml(values[name])


@param_app.command("set", context_settings={"ignore_unknown_options": True})  # "-1" is a value, as in ros2
def param_set(node: str, name: str, value: str, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """Set one parameter (value parsed as YAML); the node validates it and keeps the old value on error."""
    from pfield.interfaces import load_yaml

    parsed = _local(load_yaml, value, name)
    # json.dumps keeps .nan/.inf as NaN/Infinity so the node itself refuses them, naming the parameter.
    with _client(url, token) as client:
        _request(client, "PUT", _node_path(node), json.dumps({name: parsed}))
    typer.echo("Set parameter successful")


@param_app.command("dump")
def param_dump(node: str, url: Url = DEFAULT_URL, token: Token = None) -> None:
    """Print a node's parameters as a ROS 2 parameters file (usable with ``pfield serve --params``)."""
    with _client(url, token) as client:
        values = _request(client, "GET", _node_path(node))
    _print_yaml({"/" + node.lstrip("/"): {"ros__parameters": values}})


@interface_app.command("show")
def interface_show(type_name: Annotated[str, typer.Argument(metavar="TYPE")]) -> None:
    """Print a message or service definition (the .msg/.srv text)."""
    from pfield.interfaces import interface_text

    typer.echo(_local(interface_text, type_name))


@interface_app.command("list")
def interface_list() -> None:
    """List every message and service type pfield knows."""
    from pfield.interfaces import registered_services, registered_types

    for name in sorted(n for n in registered_types() if "/msg/" in n):
        typer.echo(name)
    for name in sorted(registered_services()):
        typer.echo(name)


def register(app: typer.Typer) -> None:
    app.add_typer(topic_app, name="topic")
    app.add_typer(service_app, name="service")
    app.add_typer(param_app, name="param")
    app.add_typer(interface_app, name="interface")
