"""Transports expose the transport-free nodes of :mod:`pfield.node`: HTTP/WebSocket
(:mod:`pfield.transport.http`, no ROS needed) and ROS 2 (:mod:`pfield.transport.ros2`, rclpy).

A transport decodes a request into the node's pydantic model, calls the handler and encodes the answer;
it owns no state of its own beyond connections.
"""

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8357
DEFAULT_URL = f"http://{DEFAULT_HOST}:{DEFAULT_PORT}"

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "DEFAULT_URL"]
