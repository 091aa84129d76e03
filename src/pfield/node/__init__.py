"""Transport-free nodes: state plus message handlers, served by :mod:`pfield.transport` (HTTP or rclpy).

:class:`Bus` is the in-process publish/subscribe a node talks through; :class:`Node` is the base class of
``pfield.node.manager.ManagerNode``, ``pfield.node.base_controller.BaseControllerNode`` and
``pfield.node.costmap_server.CostmapServer``; a node declares what it serves as :class:`ServiceSpec`,
:class:`SubscriptionSpec` and :class:`PublicationSpec` rows, which a transport exposes. :func:`make_resolver` (the
mesh resolver of a node's allowed roots) and :func:`parse_transform_option` (``--transform``) serve the CLI and
the demo as they serve the nodes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pfield._lazy import lazy_exports
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec, distinct_buses

__all__ = ["Bus", "Node", "PublicationSpec", "ServiceSpec", "SubscriptionSpec", "distinct_buses", "make_resolver",
           "parse_transform_option"]

if TYPE_CHECKING:
    from pfield.node._frames import parse_transform_option
    from pfield.node._planning import make_resolver

__getattr__, __dir__ = lazy_exports(__name__, {"make_resolver": "pfield.node._planning",
                                              "parse_transform_option": "pfield.node._frames"}, globals())
"""Names whose modules load the planners or the message conversions: imported on first use, so ``import
pfield.node`` (every transport does) stays light."""
