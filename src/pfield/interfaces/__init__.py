"""Pydantic models mirroring the ROS 2 messages and services pfield speaks (the wire format).

Import a package module (``pfield.interfaces.geometry_msgs``) to register its types, or use
:func:`lookup_type` after importing :mod:`pfield.interfaces.all`.
"""

from pfield.interfaces._base import RosMessage, lookup_type, registered_types

__all__ = ["RosMessage", "lookup_type", "registered_types"]
