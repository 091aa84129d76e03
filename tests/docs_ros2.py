"""The few ``ros2`` CLI verbs the README's "Drive a robot" block uses, over rclpy, for tests/test_docs.py.

The ``ros2`` command (ros2cli) is not among the PyPI wheels; the docs test runs that block in a private network
namespace with ``ros2`` meaning this script, against the real ``pfield ros2 node``. It does what ros2cli does
for these forms (Jazzy), no more:

* ``topic pub [--once] [-r RATE] [-t TIMES] TOPIC TYPE VALUES``: waits for a subscriber, publishes VALUES (YAML)
  once, TIMES times or until interrupted, at RATE Hz (default 1);
* ``topic echo [--once] TOPIC [TYPE]``: prints each message as YAML followed by ``---`` (QoS matched to the
  publishers: best effort if one offers it, transient local if all do); with ``--once`` it fails after
  :data:`ONCE_TIMEOUT` without a message, where ros2cli would wait for ever;
* ``service call NAME TYPE [VALUES]``: prints ``requester: making request: …`` and ``response:`` with the
  response (as YAML here, where ros2cli prints the message's repr).
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import rclpy
import yaml
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from pfield.interfaces import lookup_type
from pfield.interfaces._yaml import load_yaml, message_from_data
from pfield.transport._ros2_convert import from_ros, interface_class, to_ros

ONCE_TIMEOUT = 120.0
"""``topic echo --once`` gives up after this many seconds (ros2cli waits for ever)."""


def _model(type_name: str, text: str | None) -> Any:
    return message_from_data(lookup_type(type_name), load_yaml(text or "{}", "values") or {})


def _show(message: Any, type_name: str) -> str:
    return yaml.safe_dump(from_ros(message, lookup_type(type_name)).model_dump(mode="json"), sort_keys=False)


def _wait(condition: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise SystemExit(f"ros2 (docs test): {what} within {timeout} s")
        time.sleep(0.05)


def pub(node: Any, args: argparse.Namespace) -> None:
    message_class = interface_class(args.type)
    publisher = node.create_publisher(message_class, args.topic, QoSProfile(
        depth=10, reliability=ReliabilityPolicy.RELIABLE))
    message = to_ros(_model(args.type, args.values), message_class)
    _wait(lambda: publisher.get_subscription_count() > 0, 60.0, f"no subscriber on {args.topic}")
    times = 1 if args.once else args.times
    sent = 0
    while times == 0 or sent < times:
        publisher.publish(message)
        sent += 1
        print(f"publishing #{sent}: {args.type}", flush=True) if sent == 1 or args.once else None
        time.sleep(1.0 / args.rate)


def echo(node: Any, args: argparse.Namespace) -> None:
    _wait(lambda: node.get_publishers_info_by_topic(args.topic), 60.0, f"no publisher on {args.topic}")
    publishers = node.get_publishers_info_by_topic(args.topic)
    type_name = args.type or publishers[0].topic_type
    best_effort = any(p.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for p in publishers)
    latched = all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers)
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
    received: list[Any] = []
    node.create_subscription(interface_class(type_name), args.topic, received.append, qos)
    shown = 0
    deadline = time.monotonic() + ONCE_TIMEOUT
    while not (args.once and shown):
        if args.once and time.monotonic() > deadline:  # a test fails with this message instead of hanging
            raise SystemExit(f"ros2 (docs test): no message on {args.topic} within {ONCE_TIMEOUT} s")
        rclpy.spin_once(node, timeout_sec=0.1)
        for message in received[shown:]:
            print(_show(message, type_name) + "---", flush=True)
            shown += 1
            if args.once:
                break


def call(node: Any, args: argparse.Namespace) -> None:
    service_class = interface_class(args.type)
    request = to_ros(_model(f"{args.type}_Request", args.values), service_class.Request)
    client = node.create_client(service_class, args.name)
    if not client.wait_for_service(timeout_sec=60.0):
        raise SystemExit(f"ros2 (docs test): no service {args.name} within 60 s")
    print(f"requester: making request: {args.type}\n", flush=True)
    future = client.call_async(request)
    rclpy.spin_until_future_complete(node, future, timeout_sec=600.0)
    print("response:\n" + _show(future.result(), f"{args.type}_Response"), flush=True)


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog="ros2")
    verbs = parser.add_subparsers(dest="group", required=True)
    topic = verbs.add_parser("topic").add_subparsers(dest="verb", required=True)
    p = topic.add_parser("pub")
    p.add_argument("--once", action="store_true")
    p.add_argument("-r", "--rate", type=float, default=1.0)
    p.add_argument("-t", "--times", type=int, default=0)
    p.add_argument("topic"), p.add_argument("type"), p.add_argument("values", nargs="?")
    p.set_defaults(run=pub)
    e = topic.add_parser("echo")
    e.add_argument("--once", action="store_true")
    e.add_argument("topic"), e.add_argument("type", nargs="?")
    e.set_defaults(run=echo)
    c = verbs.add_parser("service").add_subparsers(dest="verb", required=True).add_parser("call")
    c.add_argument("name"), c.add_argument("type"), c.add_argument("values", nargs="?")
    c.set_defaults(run=call)
    args = parser.parse_args(argv)
    rclpy.init()
    node = rclpy.create_node("ros2cli_docs_test")
    try:
        args.run(node, args)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main(sys.argv[1:])
