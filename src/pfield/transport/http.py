"""HTTP/WebSocket transport: a FastAPI app exposing transport-free nodes under their ROS names.

Routes (DESIGN §3.2; a ROS name ``/pfield/plan_path`` appears without its leading slash):

* ``POST /srv/<service>``: request JSON → response JSON (typed per service in ``/openapi.json``).
* ``POST /topic/<topic>``: publish (subscribed topics are typed; others need ``?type=pkg/msg/Name``).
* ``GET /topic/<topic>``: latest message; ``WS /ws/topic/<topic>``: stream (latest first, like a latched
  topic), and JSON frames sent by the client are published.
* ``GET /param/<node>`` / ``PUT /param/<node>``: all parameters / set some (all-or-nothing).
* ``GET /topics``, ``GET /services``, ``GET /nodes``: listings for ``pfield topic list`` etc.

* ``GET /health``: ``{"ready": bool, "start_up": "done" | "running" | "failed", ...}`` plus the caps' counters
  (``"errors"`` when start-up work failed).

Browser protections and body checks run first, for every route (:mod:`pfield.transport._asgi`): a ``Host``
other than this server is refused (421), a state-changing request or WebSocket from another page's
``Origin`` is refused (403), bodies must be non-empty ``application/json`` (415, 400) and at most
``max_request_bytes`` (413). No CORS headers are sent unless ``allowed_origins`` names pages.

Errors are JSON ``{"error", "field", "value"}``: 400 for bad input (the field path named), 404 for
unknown names, 405 for a wrong method, 401 without the token, 500 (connection kept) for a server fault.
Handlers run off the event loop: short services and parameter changes run one at a time on a calls
thread (control-loop calls that their node knows to be quick now are answered on the loop), subscription
handlers on a topics thread, ``long_running`` services (planning) on a pool of ``workers`` threads so that
short calls keep answering; ``cancellable`` ones get a
:class:`~pfield.planning.CancelToken` that is cancelled when the client disconnects. Nodes with a
``tick_period`` are ticked from a background task.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import inspect
import json
import logging
import threading
import time
from collections.abc import AsyncIterator, Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from fastapi import Body, FastAPI, Query, Request, WebSocket, WebSocketDisconnect
from fastapi.exceptions import RequestValidationError
from fastapi.responses import Response, StreamingResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

import pfield.interfaces.all  # noqa: F401 - the generic topic route knows every message type
from pfield.errors import InvalidInput, PfieldError
from pfield.interfaces import RosMessage, field_path, lookup_type, message_from_data
from pfield.node import Bus, Node, ServiceSpec, SubscriptionSpec, distinct_buses
from pfield.transport._asgi import DEFAULT_MAX_REQUEST_BYTES, MAX_JSON_DEPTH, GuardMiddleware, error_body, excess_depth
from pfield.transport._fanout import TopicFanout
from pfield.transport._server import ServerLimits, uvicorn_config

__all__ = ["DEFAULT_MAX_REQUEST_BYTES", "NotFound", "ServerLimits", "ServerThread", "create_app", "run_server"]

_log = logging.getLogger(__name__)
QUICK_BODY_BYTES = 16_384
"""Largest body of a quick call decoded on the event loop (a control-loop request is ~1 kB; decoding this
much takes well under 0.1 ms)."""
_NO_TELEMETRY: dict[str, Any] = ({"telemetry": {"tracing": False, "metrics": False, "logs": False}}
                                  if "telemetry" in inspect.signature(FastAPI.__init__).parameters else {})
"""FastAPI's own OpenTelemetry hooks off (versions that have them look up the providers on every request):
the node exports no traces, metrics or logs."""
DISCONNECT_POLL_S = 0.05
"""s between checks of whether the client of a cancellable call has gone away."""


LONG_RUNNING_NICENESS = 10
"""Added to the niceness of the threads that run ``long_running`` services: when the CPUs are busy, the
operating system runs the event loop and the calls thread first, so a plan of seconds (compiled, without the
GIL) takes the CPU time that is left instead of delaying every control-loop call behind it."""


def _lower_priority() -> None:
    """Lower this thread's scheduling priority by :data:`LONG_RUNNING_NICENESS` (Linux: niceness is per thread)."""
    import os

    try:
        tid = threading.get_native_id()
        os.setpriority(os.PRIO_PROCESS, tid, min(19, os.getpriority(os.PRIO_PROCESS, tid) + LONG_RUNNING_NICENESS))
    except (AttributeError, OSError):  # no per-thread priorities here: plans run at the node's priority
        _log.debug("could not lower the priority of %s", threading.current_thread().name)


class NotFound(PfieldError, LookupError):
    """A service, topic or node name the server does not know."""

    def __init__(self, kind: str, name: str, known: Sequence[str], reason: str = "") -> None:
        self.field = kind
        super().__init__(reason or f"unknown {kind} {name!r}; known: {', '.join(known) or 'none'}")


def _error(status: int, error: str, field: str = "", value: object = None,
           headers: dict[str, str] | None = None) -> Response:
    return Response(error_body(error, field, value), status, headers=headers, media_type="application/json")


class _Routes:
    """Routing tables built once from the nodes (names are ROS names with a leading slash), and the threads
    handlers run on."""

    def __init__(self, nodes: Sequence[Node], workers: int) -> None:
        self.nodes = {node.name: node for node in nodes}
        self.services = {spec.name: spec for node in nodes for spec in node.services()}
        self.service_nodes = {spec.name: node.name for node in nodes for spec in node.services()}
        self.subscriptions: dict[str, list[SubscriptionSpec]] = {}
        self.topics: dict[str, dict[str, Any]] = {}
        for node in nodes:
            for sub in node.subscriptions():
                self.subscriptions.setdefault(sub.topic, []).append(sub)
                self._topic(sub.topic, sub.type_name)["subscribers"].append(node.name)
            for pub in node.publications():
                self._topic(pub.topic, pub.type_name)["publishers"].append(node.name)
        self.buses: list[Bus] = distinct_buses(nodes)
        for bus in self.buses:
            bus.declare(*self.topics)
        self.topic_worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="pfield-topics")
        """Subscription handlers run here, one message at a time in arrival order, so that slow ones (a mesh
        obstacle's first load) never block the event loop."""
        self.call_worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="pfield-calls")
        """Short services and parameter changes run here, one at a time in arrival order (as the nodes
        expect), off the event loop."""
        self.long_workers = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="pfield-service",
                                               initializer=_lower_priority)
        """``long_running`` services (planning), at a lower scheduling priority (:data:`LONG_RUNNING_NICENESS`)."""
        self.answer_writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="pfield-answers",
                                                initializer=_lower_priority)
        """Streamed answers (long plans) are written here, at the plans' priority and never behind a plan."""

    def _topic(self, name: str, type_name: str) -> dict[str, Any]:
        return self.topics.setdefault(name, {"name": name, "type": type_name, "publishers": [], "subscribers": []})

    def service(self, name: str) -> ServiceSpec:
        if name not in self.services:
            raise NotFound("service", name, sorted(self.services))
        return self.services[name]

    def node(self, name: str) -> Node:
        if name not in self.nodes:
            raise NotFound("node", name, sorted(self.nodes))
        return self.nodes[name]

    def latest(self, topic: str) -> RosMessage | None:
        return next((m for bus in self.buses if (m := bus.latest(topic)) is not None), None)

    def publish(self, topic: str, message: RosMessage) -> None:
        """Deliver to the subscribers (which validate and may raise), then to the bus (echo, WebSocket).
        A topic no node declared keeps its latest message only within the bus's ``max_undeclared``."""
        for sub in self.subscriptions.get(topic, []):
            sub.handler(message)
        for bus in self.buses:
            bus.publish(topic, message, declare=topic in self.topics)

    async def deliver(self, topic: str, message: RosMessage) -> None:
        """:meth:`publish` on the topic worker thread."""
        await asyncio.get_running_loop().run_in_executor(self.topic_worker, self.publish, topic, message)

    async def call(self, fn: Callable[..., Any], *args: Any) -> Any:
        """``fn(*args)`` on the calls thread."""
        return await asyncio.get_running_loop().run_in_executor(self.call_worker, fn, *args)

    def model_for(self, topic: str, type_name: str | None) -> type[RosMessage]:
        known = self.topics.get(topic, {}).get("type")
        if type_name and known and lookup_type(type_name) is not lookup_type(known):
            raise InvalidInput("type", type_name, f"topic {topic} carries {known}")
        if not (type_name or known):
            raise InvalidInput("type", None, f"topic {topic} is not known to the server: give ?type=pkg/msg/Name")
        return lookup_type(str(type_name or known))

    def shutdown(self) -> None:
        for executor in (self.long_workers, self.answer_writer, self.call_worker, self.topic_worker):
            executor.shutdown(wait=False, cancel_futures=True)


def _install_error_handlers(app: FastAPI) -> None:
    """Every error in pfield's format (unexpected exceptions: :class:`GuardMiddleware` answers the 500)."""

    @app.exception_handler(NotFound)
    async def not_found(_: Request, exc: NotFound) -> Response:
        return _error(404, str(exc), exc.field)

    @app.exception_handler(InvalidInput)
    async def invalid(_: Request, exc: InvalidInput) -> Response:
        return _error(400, str(exc), exc.field, exc.value)

    @app.exception_handler(PfieldError)
    async def pfield_error(_: Request, exc: PfieldError) -> Response:
        return _error(400, str(exc))

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException) -> Response:
        reason = {404: f"no route {request.method} {request.url.path} (GET /openapi.json lists the routes)",
                  405: f"{request.method} is not allowed on {request.url.path}"}.get(exc.status_code, str(exc.detail))
        return _error(exc.status_code, reason, "path" if exc.status_code in (404, 405) else "",
                      headers=dict(exc.headers or {}))

    @app.exception_handler(RequestValidationError)
    async def validation(_: Request, exc: RequestValidationError) -> Response:
        return _validation_error(exc.errors())


def _validation_error(errors: Sequence[Any]) -> Response:
    """400 naming the first invalid field of a body (``errors`` as pydantic lists them, under ``body``)."""
    first = errors[0]
    location = tuple(first.get("loc", ()))[1:]
    if first.get("type") == "json_invalid":
        return _error(400, f"malformed JSON: {first.get('msg')}", "body")
    reason = "unknown field" if first.get("type") == "extra_forbidden" else first.get("msg", "")
    field = field_path(location) if location else "body"
    return _error(400, f"{field}={first.get('input')!r:.200}: {reason}", field, first.get("input"))


def _known_error(exc: Exception) -> Response | None:
    """The answer of the error handlers above for a pfield error raised by a handler (None: not one)."""
    if isinstance(exc, NotFound):
        return _error(404, str(exc), exc.field)
    if isinstance(exc, InvalidInput):
        return _error(400, str(exc), exc.field, exc.value)
    if isinstance(exc, PfieldError):
        return _error(400, str(exc))
    return None


class _ShortServices:
    """ASGI middleware answering ``POST /srv/<service>`` of short services (not ``long_running``) directly:
    decoding, validating, the handler and the JSON answer all run as one job on the calls thread, without
    FastAPI's routing and dependency machinery (about half of a control-loop call's time on the event loop).
    A call its node says is quick now (:attr:`~pfield.node.ServiceSpec.quick`; bodies up to
    :data:`QUICK_BODY_BYTES`) runs on the event loop instead: the two thread hand-offs cost a fast call
    more than its work, and under load each waits for the GIL.
    Answers and errors are those of the typed FastAPI routes, which still document the services in
    ``/openapi.json`` (and answer every other method and path)."""

    def __init__(self, app: Any, routes: _Routes) -> None:
        self.app = app
        self.routes = routes
        self.paths = {f"/srv{spec.name}": spec for spec in routes.services.values() if not spec.long_running}

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        spec = self.paths.get(scope["path"]) if scope["type"] == "http" and scope["method"] == "POST" else None
        if spec is None:
            await self.app(scope, receive, send)
            return
        chunks = []
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return
            chunks.append(message.get("body", b""))
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        quick = spec.quick if len(body) <= QUICK_BODY_BYTES else None
        request = body if quick is None else _decoded(spec, body)
        if isinstance(request, tuple):  # refused while decoding
            status, body = request
        elif quick is not None and quick(request):  # known to be cheap now: no thread hand-off
            status, body = _answer(spec, request)
        else:
            status, body = await self.routes.call(_answer, spec, request)
        await send({"type": "http.response.start", "status": status,
                    "headers": [(b"content-length", str(len(body)).encode()),
                                (b"content-type", b"application/json")]})
        await send({"type": "http.response.body", "body": body})


def _decoded(spec: ServiceSpec, body: bytes) -> RosMessage | tuple[int, bytes]:
    """The request message of a short service's call, or the (status, JSON) of its 400."""
    from pydantic import ValidationError

    try:
        data = json.loads(body)
    except ValueError as exc:
        if not isinstance(exc, json.JSONDecodeError):  # not UTF-8
            return 400, bytes(_error(400, f"malformed JSON: {exc}", "body").body)
        errors = [{"type": "json_invalid", "loc": ("body", exc.pos), "msg": "JSON decode error", "input": {}}]
        return 400, bytes(_validation_error(errors).body)
    try:
        return spec.request.model_validate(data, from_attributes=True)
    except ValidationError as exc:
        located = [dict(error, loc=("body", *error["loc"])) for error in exc.errors(include_url=False)]
        return 400, bytes(_validation_error(located).body)


def _answer(spec: ServiceSpec, body: bytes | RosMessage) -> tuple[int, bytes]:
    """(status, JSON) of a short service's call with request ``body`` (raw or decoded)."""
    request = _decoded(spec, body) if isinstance(body, bytes) else body
    if isinstance(request, tuple):
        return request
    try:
        response = spec.handler(request)
    except Exception as exc:
        known = _known_error(exc)
        if known is None:
            raise
        return known.status_code, bytes(known.body)
    return 200, response.model_dump_json().encode()


def _endpoint(handler: Any, model: type[RosMessage], with_type: bool = False) -> Any:
    """Give a generic handler the signature ``(request, body: model[, type: str])`` so that FastAPI
    validates and documents the body (and the optional ``?type=`` of topics)."""
    parameters = [inspect.Parameter("request", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=Request),
                  inspect.Parameter("body", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=model,
                                    default=Body(...))]
    if with_type:
        parameters.append(inspect.Parameter("type", inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                            annotation=str | None, default=Query(None)))
    handler.__signature__ = inspect.Signature(parameters)
    return handler


STREAM_PIECE_BYTES = 1 << 16
"""A streamed answer is sent in pieces of about this many bytes (each written by one worker call)."""


def _next_piece(pieces: Iterator[str]) -> bytes:
    """The next :data:`STREAM_PIECE_BYTES` or so of ``pieces`` (b"" at the end)."""
    out: list[bytes] = []
    size = 0
    for piece in pieces:
        out.append(piece.encode())
        size += len(out[-1])
        if size >= STREAM_PIECE_BYTES:
            break
    return b"".join(out)


def _json(message: RosMessage, writer: ThreadPoolExecutor | None = None) -> Response:
    """The message as a JSON response. Messages that write their JSON in pieces (plan responses) are streamed,
    so a 100 MB plan is neither held in memory twice nor written on the loop; ``writer`` writes the pieces
    (the server's answer writer, at the plans' lower priority: a long answer is background work; default:
    the loop's own thread pool)."""
    chunks = getattr(message, "json_chunks", None)
    if chunks is None:
        return Response(message.model_dump_json(), media_type="application/json")
    pieces = chunks()

    async def stream() -> AsyncIterator[bytes]:
        loop = asyncio.get_running_loop()
        while piece := await loop.run_in_executor(writer, _next_piece, pieces):
            yield piece

    return StreamingResponse(stream(), media_type="application/json")


async def _until_done_or_gone(future: asyncio.Future[Any], request: Request, cancel: Any) -> Any:
    """Await ``future``; cancel the plan's token as soon as the client disconnects (then wait for the end)."""
    while True:
        done, _ = await asyncio.wait({future}, timeout=DISCONNECT_POLL_S)
        if done:
            return future.result()
        if await request.is_disconnected():
            cancel.cancel()
            _log.info("client of %s went away: its call is cancelled", request.url.path)
            return await future


def _add_service_routes(app: FastAPI, routes: _Routes) -> None:
    from pfield.planning.cancel import CancelToken

    for spec in routes.services.values():
        def make(spec: ServiceSpec = spec) -> Any:
            async def call(request: Request, body: RosMessage) -> Response:
                if not spec.long_running:
                    return _json(await routes.call(spec.handler, body))
                loop = asyncio.get_running_loop()
                if not spec.cancellable:
                    return _json(await loop.run_in_executor(routes.long_workers, spec.handler, body),
                                 routes.answer_writer)
                token = CancelToken()
                handler: Callable[..., RosMessage] = spec.handler
                future = loop.run_in_executor(routes.long_workers, functools.partial(handler, body, cancel=token))
                return _json(await _until_done_or_gone(future, request, token), routes.answer_writer)
            return _endpoint(call, spec.request)
        app.post(f"/srv{spec.name}", response_class=Response, name=f"service {spec.name} ({spec.type_name})",
                 responses={200: {"model": spec.response}}, tags=["services"])(make())

    @app.post("/srv/{name:path}", tags=["services"])
    async def unknown_service(name: str) -> Response:
        raise NotFound("service", "/" + name, sorted(routes.services))

    @app.get("/services", tags=["listings"])
    async def list_services() -> list[dict[str, str]]:
        return [{"name": s.name, "type": s.type_name, "node": routes.service_nodes[s.name]}
                for s in sorted(routes.services.values(), key=lambda s: s.name)]


def _add_topic_routes(app: FastAPI, routes: _Routes) -> None:
    for topic, subs in routes.subscriptions.items():
        def make(topic: str = topic, model: type[RosMessage] = subs[0].model) -> Any:
            async def publish(request: Request, body: RosMessage, type: str | None = None) -> dict[str, str]:
                routes.model_for(topic, type)
                await routes.deliver(topic, body)
                return {"published": topic}
            return _endpoint(publish, model, with_type=True)
        app.post(f"/topic{topic}", name=f"publish {topic} ({subs[0].type_name})", tags=["topics"])(make())

    @app.post("/topic/{topic:path}", tags=["topics"])
    async def publish_any(topic: str, request: Request, type: str | None = None) -> dict[str, str]:
        name = "/" + topic
        model = routes.model_for(name, type)
        try:
            data = json.loads(await request.body())  # the guard checked type, presence, size and depth
        except ValueError as exc:
            raise InvalidInput("body", None, f"malformed JSON: {exc}") from None
        await routes.deliver(name, _message(model, data, "body"))
        return {"published": name}

    @app.get("/topic/{topic:path}", tags=["topics"])
    async def latest(topic: str) -> Response:
        message = routes.latest("/" + topic)
        if message is None:
            raise NotFound("topic", "/" + topic, [], f"no message on /{topic} yet (GET /topics lists the topics)")
        return _json(message)

    @app.get("/topics", tags=["listings"])
    async def list_topics() -> list[dict[str, Any]]:
        names = set(routes.topics) | {t for bus in routes.buses for t in bus.topics()}
        return [routes.topics.get(n) or {"name": n, "type": getattr(routes.latest(n), "ros_type", ""),
                                         "publishers": [], "subscribers": []} for n in sorted(names)]


def _add_param_routes(app: FastAPI, routes: _Routes) -> None:
    @app.get("/nodes", tags=["listings"])
    async def list_nodes() -> list[str]:
        return sorted(routes.nodes)

    @app.get("/param/{node:path}", tags=["parameters"])
    async def get_params(node: str, describe: bool = False) -> dict[str, Any]:
        target = routes.node("/" + node)
        return await routes.call(target.describe_parameters if describe else target.get_parameters)

    @app.put("/param/{node:path}", tags=["parameters"])
    async def set_params(node: str, values: dict[str, Any] = Body(...)) -> dict[str, Any]:
        return await routes.call(routes.node("/" + node).set_parameters, values)


def _message(model: type[RosMessage], data: Any, field: str) -> RosMessage:
    """``data`` (decoded JSON) as a ``model`` message; anything but an object is refused (``null`` is not a
    message of defaults: send ``{}`` for that)."""
    if not isinstance(data, dict):
        raise InvalidInput(field, data, f"expected a JSON object with the fields of {model.ros_type}")
    return message_from_data(model, data)


def _frame_error(error: str, field: str = "", value: object = None) -> str:
    return error_body(error, field, value).decode()


async def _receive_messages(websocket: WebSocket, routes: _Routes, topic: str) -> None:
    """Publish each JSON text frame the client sends; answer an error frame for each bad one."""
    while True:
        frame = await websocket.receive()
        if frame["type"] == "websocket.disconnect":
            return
        text = frame.get("text")
        if text is None:
            await websocket.send_text(_frame_error("binary frames are not accepted: send JSON text", "frame"))
            continue
        try:
            if excess_depth(text):
                raise InvalidInput("frame", None, f"JSON nested more than {MAX_JSON_DEPTH} levels deep")
            try:
                data = json.loads(text)
            except ValueError as exc:
                raise InvalidInput("frame", None, f"malformed JSON: {exc}") from None
            await routes.deliver(topic, _message(routes.model_for(topic, None), data, "frame"))
        except InvalidInput as exc:
            await websocket.send_text(_frame_error(str(exc), exc.field, exc.value))
        except PfieldError as exc:
            await websocket.send_text(_frame_error(str(exc)))
        except Exception as exc:  # a server fault: logged once, the client gets an error frame, the socket stays
            _log.error("WebSocket %s: publishing failed", topic, exc_info=exc)
            await websocket.send_text(_frame_error(f"internal error: {type(exc).__name__}: {exc}"))


async def _stream(websocket: WebSocket, routes: _Routes, topic: str) -> None:
    fanout: TopicFanout = websocket.app.state.fanout
    outbox = fanout.subscribe(topic)
    latest = routes.latest(topic)
    if latest is not None:
        outbox.offer(latest.model_dump_json())

    async def sender() -> None:
        while True:
            await websocket.send_text(await outbox.get())

    sending = asyncio.create_task(sender())
    try:
        await _receive_messages(websocket, routes, topic)
    except WebSocketDisconnect:
        pass
    finally:
        sending.cancel()
        with contextlib.suppress(asyncio.CancelledError, Exception):
            await sending  # a send to a client that went away ends here, quietly
        fanout.unsubscribe(topic, outbox)


async def _tick_forever(node: Node) -> None:
    period = float(node.tick_period or 0.0)
    while True:
        await asyncio.sleep(period)
        try:
            await asyncio.to_thread(node.tick, time.monotonic())
        except Exception:  # a failing tick must not stop the server
            _log.exception("tick of %s failed", node.name)


def _add_health_route(app: FastAPI, routes: _Routes, ready: Callable[[], bool] | None,
                      errors: Callable[[], list[str]] | None, limits: dict[str, Any]) -> None:
    started = time.monotonic()

    @app.get("/health", tags=["listings"])
    async def health() -> dict[str, Any]:
        """Whether the node's start-up work has finished, and the caps' counters.

        ``ready`` (bool) and ``start_up`` (``"done"`` | ``"running"``) say the same: the ``ready`` callable of
        :func:`create_app` has returned true (for ``pfield serve``: :func:`pfield.warmup.ready`, its self-check and
        its robot's link-model fit have ended; a failed self-check step is logged and the node serves what works).
        ``"start_up": "failed"`` (and ``ready`` false) with ``"errors"``: start-up work that cannot be done (for
        ``pfield serve``, :func:`pfield.warmup.start_up_errors`: a robot whose link model cannot be fitted, so it
        cannot plan); the node serves what needs no such work. The kernels are compiled ahead of time (the core,
        :mod:`pfield._core`), so nothing compiles here: this field replaced ``"kernels": "warm" | "compiling"`` of
        the numba engine."""
        failed = [] if errors is None else list(errors())
        done = not failed and (True if ready is None else bool(ready()))
        fanout: TopicFanout = app.state.fanout
        state = {"start_up": "failed", "errors": failed} if failed else {"start_up": "done" if done else "running"}
        return {"ready": done, **state,
                "nodes": sorted(routes.nodes), "uptime_s": round(time.monotonic() - started, 3),
                "websocket": {"connections": fanout.connections, "dropped_messages": fanout.dropped},
                "topics_kept": sum(len(bus.topics()) for bus in routes.buses),
                "limits": limits}


def create_app(nodes: Sequence[Node], *, token: str | None = None,
               max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES, workers: int = 2,
               ws_queue_size: int = 1000, ws_queue_bytes: int = 16_000_000,
               allowed_origins: Sequence[str] = (), allowed_hosts: Sequence[str] = (),
               ready: Callable[[], bool] | None = None, errors: Callable[[], list[str]] | None = None) -> FastAPI:
    """The FastAPI app serving ``nodes`` (see the module docstring for the routes).

    ``token``: required bearer token (set it whenever binding beyond 127.0.0.1); ``workers``: threads
    for ``long_running`` services; ``ws_queue_size`` / ``ws_queue_bytes``: messages / bytes of JSON buffered
    per WebSocket before the oldest drop; ``allowed_origins``: pages (``http://host:port``) besides this
    server's own loopback origins that may change state and open WebSockets (they also get CORS headers);
    ``allowed_hosts``: ``Host`` names accepted besides the loopback names and the bound address;
    ``ready``: says whether the node's start-up work has finished (``GET /health``; None: always ready);
    ``errors``: why start-up work cannot be done, if any (``GET /health`` then says ``"start_up": "failed"``).
    """
    routes = _Routes(nodes, workers)

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        loop = asyncio.get_running_loop()
        app.state.fanout = TopicFanout(routes.buses, loop, ws_queue_size, ws_queue_bytes)
        ticks = [asyncio.create_task(_tick_forever(n)) for n in nodes if n.tick_period]
        yield
        for task in ticks:
            task.cancel()
        app.state.fanout.close()
        routes.shutdown()
        for node in nodes:
            node.close()

    app = FastAPI(title="pfield node", version="0.1.0", lifespan=lifespan, **_NO_TELEMETRY,
                  description="pfield's nodes over HTTP: ROS services, topics and parameters by their ROS names.")
    app.state.max_request_bytes = max_request_bytes  # the server refuses chunk sizes beyond it (_server)
    _install_error_handlers(app)
    _add_service_routes(app, routes)
    _add_topic_routes(app, routes)
    _add_param_routes(app, routes)
    limits = {"max_request_bytes": max_request_bytes, "max_json_depth": MAX_JSON_DEPTH,
              "ws_queue_messages": ws_queue_size, "ws_queue_bytes": ws_queue_bytes,
              "undeclared_topics_kept": min((bus.max_undeclared for bus in routes.buses), default=0)}
    _add_health_route(app, routes, ready, errors, limits)

    @app.websocket("/ws/topic/{topic:path}")
    async def stream(websocket: WebSocket, topic: str) -> None:
        await websocket.accept()
        await _stream(websocket, routes, "/" + topic)

    app.add_middleware(_ShortServices, routes=routes)  # type: ignore[arg-type]
    if allowed_origins:
        from starlette.middleware.cors import CORSMiddleware

        app.add_middleware(CORSMiddleware, allow_origins=list(allowed_origins),  # type: ignore[arg-type]
                           allow_methods=["GET", "POST", "PUT"], allow_headers=["authorization", "content-type"])
    app.add_middleware(GuardMiddleware, token=token, max_bytes=max_request_bytes,  # type: ignore[arg-type]
                       allowed_origins=allowed_origins, allowed_hosts=allowed_hosts)
    return app


def run_server(app: FastAPI, host: str, port: int, *, limits: ServerLimits | None = None,
               log_level: str = "warning") -> None:
    """Serve ``app`` on ``host:port`` until Ctrl-C or SIGTERM (``pfield serve``), with ``limits`` applied; a stop
    asked for that way returns (the command exits 0, as ``pfield ros2 node`` does)."""
    import uvicorn

    class Server(uvicorn.Server):
        @contextlib.contextmanager
        def capture_signals(self) -> Iterator[None]:
            # uvicorn shuts down gracefully on the signal, then raises it again so the process dies by it (status
            # 130 or 143): the stop was asked for, so it is forgotten and run() returns
            with super().capture_signals():
                try:
                    yield
                finally:
                    getattr(self, "_captured_signals", []).clear()

    limits = limits or ServerLimits()
    limits.apply_to_process()
    Server(uvicorn_config(app, limits, host=host, port=port, log_level=log_level)).run()


class ServerThread:
    """Run an app with uvicorn in a background thread (demo, benchmarks, in-process tests).

    ``with ServerThread(app) as server: httpx.get(server.url + "/nodes")``; port 0 picks a free port;
    ``limits`` are the connection caps of ``pfield serve``.
    """

    def __init__(self, app: FastAPI, host: str = "127.0.0.1", port: int = 0,
                 limits: ServerLimits | None = None) -> None:
        import socket

        import uvicorn

        self._socket = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._socket.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._socket.bind((host, port))
        self.host, self.port = self._socket.getsockname()[:2]
        self.url = f"http://{self.host}:{self.port}"
        self._limits = limits or ServerLimits()
        self._server = uvicorn.Server(uvicorn_config(app, self._limits, log_level="warning"))
        self._thread: threading.Thread | None = None

    def start(self) -> ServerThread:
        self._limits.apply_to_process()
        self._thread = threading.Thread(target=self._server.run, kwargs={"sockets": [self._socket]},
                                        name="pfield-http", daemon=True)
        self._thread.start()
        deadline = time.monotonic() + 30.0
        while not self._server.started:
            if time.monotonic() > deadline or not self._thread.is_alive():
                raise RuntimeError("the HTTP server did not start")
            time.sleep(0.01)
        return self

    def stop(self) -> None:
        self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout=10.0)
        self._socket.close()

    def __enter__(self) -> ServerThread:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
