"""HTTP/WebSocket transport: a FastAPI app exposing transport-free nodes under their ROS names.

Routes (DESIGN §3.2; a ROS name ``/pfield/plan_path`` appears without its leading slash):

* ``POST /srv/<service>``: request JSON → response JSON (typed per service in ``/openapi.json``).
* ``POST /topic/<topic>``: publish (subscribed topics are typed; others need ``?type=pkg/msg/Name``).
* ``GET /topic/<topic>``: latest message; ``WS /ws/topic/<topic>``: stream (latest first, like a latched
  topic), and JSON frames sent by the client are published.
* ``GET /param/<node>`` / ``PUT /param/<node>``: all parameters / set some (all-or-nothing).
* ``GET /topics``, ``GET /services``, ``GET /nodes``: listings for ``pfield topic list`` etc.

Errors are JSON ``{"error", "field", "value"}``: 400 for bad input (the field path named), 404 for
unknown names, 401 without the token, 413 for bodies over the cap. Services flagged ``long_running``
(planning) run in a worker thread so short calls keep answering; nodes with a ``tick_period`` are
ticked from a background task.
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import json
import logging
import threading
import time
from collections.abc import AsyncIterator, Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from fastapi import Body, FastAPI, Query, Request, WebSocket, WebSocketDisconnect
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response

from pfield.errors import InvalidInput, PfieldError
from pfield.interfaces import lookup_type, message_from_data
from pfield.interfaces._base import RosMessage
from pfield.interfaces._yaml import _path
from pfield.node._base import Bus, Node, ServiceSpec, SubscriptionSpec, distinct_buses
from pfield.transport._asgi import GuardMiddleware
from pfield.transport._fanout import TopicFanout

__all__ = ["DEFAULT_MAX_REQUEST_BYTES", "NotFound", "ServerThread", "create_app"]

_log = logging.getLogger(__name__)
DEFAULT_MAX_REQUEST_BYTES = 1_000_000
"""Request bodies above this many bytes are refused with 413 (a seed request is < 1 kB)."""


class NotFound(PfieldError, LookupError):
    """A service, topic or node name the server does not know."""

    def __init__(self, kind: str, name: str, known: Sequence[str], reason: str = "") -> None:
        self.field = kind
        super().__init__(reason or f"unknown {kind} {name!r}; known: {', '.join(known) or 'none'}")


def _error(status: int, error: str, field: str = "", value: object = None) -> JSONResponse:
    return JSONResponse({"error": error, "field": field, "value": None if value is None else repr(value)}, status)


class _Routes:
    """Routing tables built once from the nodes (names are ROS names with a leading slash)."""

    def __init__(self, nodes: Sequence[Node]) -> None:
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
        self.topic_worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="pfield-topics")
        """Subscription handlers run here, one message at a time in arrival order, so that slow ones (a mesh
        obstacle's first load) never block the event loop."""

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
        """Deliver to the subscribers (which validate and may raise), then to the bus (echo, WebSocket)."""
        for sub in self.subscriptions.get(topic, []):
            sub.handler(message)
        for bus in self.buses:
            bus.publish(topic, message)

    async def deliver(self, topic: str, message: RosMessage) -> None:
        """:meth:`publish` on the topic worker thread."""
        await asyncio.get_running_loop().run_in_executor(self.topic_worker, self.publish, topic, message)

    def model_for(self, topic: str, type_name: str | None) -> type[RosMessage]:
        known = self.topics.get(topic, {}).get("type")
        if type_name and known and lookup_type(type_name) is not lookup_type(known):
            raise InvalidInput("type", type_name, f"topic {topic} carries {known}")
        if not (type_name or known):
            raise InvalidInput("type", None, f"topic {topic} is not known to the server: give ?type=pkg/msg/Name")
        return lookup_type(str(type_name or known))


def _install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(NotFound)
    async def not_found(_: Request, exc: NotFound) -> JSONResponse:
        return _error(404, str(exc), exc.field)

    @app.exception_handler(InvalidInput)
    async def invalid(_: Request, exc: InvalidInput) -> JSONResponse:
        return _error(400, str(exc), exc.field, exc.value)

    @app.exception_handler(PfieldError)
    async def pfield_error(_: Request, exc: PfieldError) -> JSONResponse:
        return _error(400, str(exc))

    @app.exception_handler(Exception)
    async def internal(request: Request, exc: Exception) -> JSONResponse:
        _log.error("%s %s failed", request.method, request.url.path, exc_info=exc)
        return _error(500, f"internal error: {type(exc).__name__}: {exc}")

    @app.exception_handler(RequestValidationError)
    async def validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        first = exc.errors()[0]
        location = tuple(first.get("loc", ()))[1:]
        if first.get("type") == "json_invalid":
            return _error(400, f"malformed JSON: {first.get('msg')}", "body")
        reason = "unknown field" if first.get("type") == "extra_forbidden" else first.get("msg", "")
        field = _path(location)
        return _error(400, f"{field}={first.get('input')!r}: {reason}", field, first.get("input"))


def _endpoint(handler: Any, model: type[RosMessage], with_type: bool = False) -> Any:
    """Give a generic handler the signature ``(body: model = default[, type: str])`` so that FastAPI
    validates and documents the body (and the optional ``?type=`` of topics)."""
    parameters = [inspect.Parameter("body", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=model | None,
                                    default=Body(None))]
    if with_type:
        parameters.append(inspect.Parameter("type", inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                            annotation=str | None, default=Query(None)))
    handler.__signature__ = inspect.Signature(parameters)
    return handler


def _json(message: RosMessage) -> Response:
    return Response(message.model_dump_json(), media_type="application/json")


def _add_service_routes(app: FastAPI, routes: _Routes, executor: ThreadPoolExecutor) -> None:
    for spec in routes.services.values():
        def make(spec: ServiceSpec = spec) -> Any:
            async def call(body: RosMessage | None = None) -> Response:
                request = body if body is not None else spec.request()
                if spec.long_running:
                    loop = asyncio.get_running_loop()
                    return _json(await loop.run_in_executor(executor, spec.handler, request))
                return _json(spec.handler(request))
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
            async def publish(body: RosMessage | None = None, type: str | None = None) -> dict[str, str]:
                routes.model_for(topic, type)
                await routes.deliver(topic, body if body is not None else model())
                return {"published": topic}
            return _endpoint(publish, model, with_type=True)
        app.post(f"/topic{topic}", name=f"publish {topic} ({subs[0].type_name})", tags=["topics"])(make())

    @app.post("/topic/{topic:path}", tags=["topics"])
    async def publish_any(topic: str, request: Request, type: str | None = None) -> dict[str, str]:
        name = "/" + topic
        model = routes.model_for(name, type)
        try:
            data = json.loads(await request.body() or b"{}")
        except ValueError as exc:
            raise InvalidInput("body", None, f"malformed JSON: {exc}") from None
        await routes.deliver(name, message_from_data(model, data))
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
        return target.describe_parameters() if describe else target.get_parameters()

    @app.put("/param/{node:path}", tags=["parameters"])
    async def set_params(node: str, values: dict[str, Any] = Body(...)) -> dict[str, Any]:
        return routes.node("/" + node).set_parameters(values)


async def _stream(websocket: WebSocket, routes: _Routes, topic: str) -> None:
    fanout: TopicFanout = websocket.app.state.fanout
    queue = fanout.subscribe(topic)
    latest = routes.latest(topic)
    if latest is not None:
        queue.put_nowait(latest.model_dump_json())

    async def sender() -> None:
        while True:
            await websocket.send_text(await queue.get())

    sending = asyncio.create_task(sender())
    try:
        while True:
            text = await websocket.receive_text()
            try:
                await routes.deliver(topic, message_from_data(routes.model_for(topic, None), json.loads(text)))
            except (PfieldError, ValueError) as exc:
                await websocket.send_text(json.dumps({"error": str(exc)}))
    except WebSocketDisconnect:
        pass
    finally:
        sending.cancel()
        fanout.unsubscribe(topic, queue)


async def _tick_forever(node: Node) -> None:
    period = float(node.tick_period or 0.0)
    while True:
        await asyncio.sleep(period)
        try:
            await asyncio.to_thread(node.tick, time.monotonic())
        except Exception:  # a failing tick must not stop the server
            _log.exception("tick of %s failed", node.name)


def create_app(nodes: Sequence[Node], *, token: str | None = None,
               max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES, workers: int = 2,
               ws_queue_size: int = 1000, ready: Callable[[], bool] | None = None) -> FastAPI:
    """The FastAPI app serving ``nodes`` (see the module docstring for the routes).

    ``token``: required bearer token (set it whenever binding beyond 127.0.0.1); ``workers``: threads
    for ``long_running`` services; ``ws_queue_size``: messages buffered per WebSocket before the oldest drop.
    """
    routes = _Routes(nodes)
    executor = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="pfield-service")

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        loop = asyncio.get_running_loop()
        app.state.fanout = TopicFanout(routes.buses, loop, ws_queue_size)
        ticks = [asyncio.create_task(_tick_forever(n)) for n in nodes if n.tick_period]
        yield
        for task in ticks:
            task.cancel()
        app.state.fanout.close()
        executor.shutdown(wait=False, cancel_futures=True)
        routes.topic_worker.shutdown(wait=False, cancel_futures=True)
        for node in nodes:
            node.close()

    app = FastAPI(title="pfield node", version="0.1.0", lifespan=lifespan,
                  description="pfield's nodes over HTTP: ROS services, topics and parameters by their ROS names.")
    _install_error_handlers(app)
    _add_service_routes(app, routes, executor)
    _add_topic_routes(app, routes)
    _add_param_routes(app, routes)

    @app.get("/health", tags=["listings"])
    async def health() -> dict[str, Any]:
        return {"ready": True if ready is None else bool(ready())}

    @app.websocket("/ws/topic/{topic:path}")
    async def stream(websocket: WebSocket, topic: str) -> None:
        await websocket.accept()
        await _stream(websocket, routes, "/" + topic)

    app.add_middleware(GuardMiddleware, token=token, max_bytes=max_request_bytes)  # type: ignore[arg-type]
    return app


class ServerThread:
    """Run an app with uvicorn in a background thread (demo, benchmarks, in-process tests).

    ``with ServerThread(app) as server: httpx.get(server.url + "/nodes")``; port 0 picks a free port.
    """

    def __init__(self, app: FastAPI, host: str = "127.0.0.1", port: int = 0) -> None:
        import socket

        import uvicorn

        self._socket = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._socket.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._socket.bind((host, port))
        self.host, self.port = self._socket.getsockname()[:2]
        self.url = f"http://{self.host}:{self.port}"
        config = uvicorn.Config(app, log_level="warning", lifespan="on")
        self._server = uvicorn.Server(config)
        self._thread: threading.Thread | None = None

    def start(self) -> ServerThread:
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
