"""The Ray backend: the same records from actors on a Ray cluster (``pip install 'pfield[ray]'``).

One actor per worker; each is created with the robot specs taken from Ray's object store (put there once),
builds its :class:`Workspace` in its constructor, and then plans the problems sent to it. Results come back
in the input order (``ActorPool.map``). With ``address`` the driver connects to a running cluster
(``ray start --head`` prints the address); without, it starts a local one with ``workers`` CPUs on
127.0.0.1 and stops it at the end. The workers import pfield from the driver's environment (``PYTHONPATH``
is passed on).
"""

from __future__ import annotations

import os
import socket
from collections.abc import Iterator, Sequence
from typing import Any

from pfield.batch._solve import Workspace, solve
from pfield.errors import PfieldError, Unreachable
from pfield.scene import Problem, RobotSpec

__all__ = ["CONNECT_TIMEOUT", "check_reachable", "ray_endpoint", "run_ray"]

CONNECT_TIMEOUT = 5.0
"""(s) how long the driver waits for a cluster's address to accept a connection before it gives up: Ray's own
``ray.init(address=...)`` retries an address where nothing listens for minutes, logging a warning every 5 s."""


def _ray() -> Any:
    try:
        import ray
    except ImportError:
        raise PfieldError("the Ray backend needs ray: pip install 'pfield[ray]'") from None
    return ray


class _Planner:
    """The actor's body (wrapped by ``ray.remote`` on first use, so importing this module needs no ray)."""

    def __init__(self, robots: tuple[RobotSpec, ...]) -> None:
        self._workspace = Workspace(robots, warm=True)

    def solve(self, problem: Problem, timeout: float | None, seed: int) -> dict[str, Any]:
        return solve(problem, self._workspace, timeout, seed)


def ray_endpoint(address: str) -> tuple[str, int] | None:
    """(host, port) of a Ray address ``HOST:PORT`` or ``ray://HOST:PORT`` (IPv6 hosts in brackets), None when it
    is neither."""
    host, colon, port = address.removeprefix("ray://").rpartition(":")
    host = host.removeprefix("[").removesuffix("]")
    if not colon or not host or "://" in host or not (port.isascii() and port.isdigit() and len(port) <= 5) \
            or not 0 < int(port) < 65536:
        return None
    return host, int(port)


def check_reachable(address: str) -> None:
    """Raise :class:`Unreachable` unless something accepts a TCP connection at ``address`` (``HOST:PORT`` or
    ``ray://HOST:PORT``) within :data:`CONNECT_TIMEOUT`; other addresses (``auto``, ``local``: Ray's own look-ups,
    which fail at once when there is no cluster) are left to Ray."""
    endpoint = ray_endpoint(address)
    if endpoint is None:
        return
    try:
        with socket.create_connection(endpoint, timeout=CONNECT_TIMEOUT):
            pass
    except OSError as exc:
        raise Unreachable(f"no Ray cluster answers at {address} ({exc.strerror or exc}): start one with "
                          "'ray start --head' and pass the address it prints, or leave out --address to plan on "
                          "a local cluster") from None


def run_ray(problems: Sequence[Problem], robots: tuple[RobotSpec, ...], workers: int, timeout: float | None,
            seed: int, address: str | None) -> Iterator[dict[str, Any]]:
    """The records of ``problems`` in order, planned by ``workers`` Ray actors."""
    ray = _ray()
    from ray.util import ActorPool

    started = False
    if not ray.is_initialized():
        env = {"env_vars": {"PYTHONPATH": os.environ["PYTHONPATH"]}} if os.environ.get("PYTHONPATH") else None
        if address:
            check_reachable(address)
            ray.init(address=address, runtime_env=env, log_to_driver=False)
        else:
            # a local cluster listens on loopback only
            ray.init(num_cpus=workers, include_dashboard=False, runtime_env=env, log_to_driver=False,
                     _node_ip_address="127.0.0.1")
        started = True
    try:
        shared = ray.put(robots)
        actor = ray.remote(num_cpus=1)(_Planner)
        pool = ActorPool([actor.remote(shared) for _ in range(workers)])
        yield from pool.map(lambda planner, problem: planner.solve.remote(problem, timeout, seed), list(problems))
    finally:
        if started:
            ray.shutdown()
