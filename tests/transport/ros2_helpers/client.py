"""A blocking rclpy client for tests and benchmarks: services, topics and parameters of pfield's nodes.

Uses the pattern that avoids rclpy 7.1's task leak (ros2/rclpy#1371): one executor spinning in a
daemon thread plus the blocking ``Client.call(request, timeout_sec=...)``; at the end the executor is
shut down and its thread joined *before* the context, which a clean exit needs. Requests and messages
are given as plain dicts (ROS field names) and answers come back as dicts, through pfield's models.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import rclpy
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node as RclpyNode
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

import pfield.interfaces.all  # noqa: F401  (registers every model for lookup_type)
from pfield.interfaces import lookup_type
from pfield.transport._ros2_convert import from_ros, interface_class, to_ros

LATCHED = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class Inbox:
    """Messages received on one topic, as dicts, in arrival order."""

    def __init__(self, type_name: str) -> None:
        self.model = lookup_type(type_name)
        self.messages: list[dict[str, Any]] = []
        self._arrived = threading.Condition()

    def receive(self, message: Any) -> None:
        plain = from_ros(message, self.model).model_dump()
        with self._arrived:
            self.messages.append(plain)
            self._arrived.notify_all()

    def wait_for(self, predicate: Callable[[dict[str, Any]], bool], timeout: float = 20.0) -> dict[str, Any]:
        """The first message (already received or arriving within ``timeout``) that satisfies ``predicate``."""
        deadline = time.monotonic() + timeout
        with self._arrived:
            while True:
                for message in self.messages:
                    if predicate(message):
                        return message
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise TimeoutError(f"no matching {self.model.ros_type} within {timeout} s")
                self._arrived.wait(remaining)


class BlockingClient:
    """An rclpy node with its own context whose methods block until the answer arrives."""

    def __init__(self, name: str = "pfield_test_client") -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = RclpyNode(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self.executor.spin, daemon=True)
        self._thread.start()
        self._clients: dict[str, Any] = {}
        self._publishers: dict[str, Any] = {}

    def _client(self, service: str, service_class: type) -> Any:
        if service not in self._clients:
            self._clients[service] = self.node.create_client(service_class, service)
        return self._clients[service]

    def call_raw(self, service: str, service_class: type, request: Any, timeout: float = 60.0) -> Any:
        client = self._client(service, service_class)
        if not client.wait_for_service(timeout_sec=timeout):
            raise TimeoutError(f"service {service} not available within {timeout} s")
        response = client.call(request, timeout_sec=timeout)
        if response is None:
            raise TimeoutError(f"no answer from {service} within {timeout} s")
        return response

    def call(self, service: str, type_name: str, request: dict[str, Any], timeout: float = 60.0) -> dict[str, Any]:
        """Call ``service`` of ``type_name`` (``pkg/srv/Name``) with ``request``; the response as a dict."""
        service_class = interface_class(type_name)
        model = lookup_type(f"{type_name}_Request").model_validate(request)
        response = self.call_raw(service, service_class, to_ros(model, service_class.Request), timeout)
        return from_ros(response, lookup_type(f"{type_name}_Response")).model_dump()

    def publish(self, topic: str, type_name: str, message: dict[str, Any], timeout: float = 60.0) -> None:
        """Publish once, after a subscriber has been matched (as ``ros2 topic pub --once`` does)."""
        message_class = interface_class(type_name)
        if topic not in self._publishers:
            self._publishers[topic] = self.node.create_publisher(message_class, topic, 10)
        publisher = self._publishers[topic]
        deadline = time.monotonic() + timeout
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise TimeoutError(f"no subscriber on {topic} within {timeout} s")
            time.sleep(0.02)
        publisher.publish(to_ros(lookup_type(type_name).model_validate(message), message_class))

    def subscribe(self, topic: str, type_name: str) -> Inbox:
        inbox = Inbox(type_name)
        self.node.create_subscription(interface_class(type_name), topic, inbox.receive, LATCHED)
        return inbox

    def set_parameters(self, node_name: str, values: dict[str, Any]) -> list[tuple[bool, str]]:
        """``ros2 param set``: one (successful, reason) per parameter."""
        request = SetParameters.Request()
        request.parameters = [Parameter(name, value=value).to_parameter_msg() for name, value in values.items()]
        response = self.call_raw(f"{node_name}/set_parameters", SetParameters, request)
        return [(result.successful, result.reason) for result in response.results]

    def get_parameters(self, node_name: str, names: list[str]) -> dict[str, Any]:
        """``ros2 param get``: the values by name."""
        request = GetParameters.Request(names=names)
        response = self.call_raw(f"{node_name}/get_parameters", GetParameters, request)
        return {name: _parameter_value(value) for name, value in zip(names, response.values, strict=True)}

    def close(self) -> None:
        self.executor.shutdown()
        self._thread.join()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def _parameter_value(value: Any) -> Any:
    """A ``rcl_interfaces/ParameterValue`` as a Python value."""
    from rcl_interfaces.msg import ParameterType

    field = {
        ParameterType.PARAMETER_BOOL: "bool_value", ParameterType.PARAMETER_INTEGER: "integer_value",
        ParameterType.PARAMETER_DOUBLE: "double_value", ParameterType.PARAMETER_STRING: "string_value",
        ParameterType.PARAMETER_BOOL_ARRAY: "bool_array_value",
        ParameterType.PARAMETER_INTEGER_ARRAY: "integer_array_value",
        ParameterType.PARAMETER_DOUBLE_ARRAY: "double_array_value",
        ParameterType.PARAMETER_STRING_ARRAY: "string_array_value",
    }.get(value.type)
    if field is None:
        return None
    result = getattr(value, field)
    return list(result) if not isinstance(result, bool | int | float | str) else result
