"""Transport-free nodes: state plus message handlers, served by :mod:`pfield.transport` (HTTP or rclpy).

:class:`Bus` is the in-process publish/subscribe a node talks through; :class:`Node` is the base class of
``pfield.node.manager.ManagerNode``, ``pfield.node.base_controller.BaseControllerNode`` and
``pfield.node.costmap_server.CostmapServer``.
"""

from pfield.node._base import Bus, Node

__all__ = ["Bus", "Node"]
