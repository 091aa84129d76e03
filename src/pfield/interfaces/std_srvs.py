"""``std_srvs`` services (Trigger, SetBool, Empty)."""

from __future__ import annotations

from pfield.interfaces._base import Bool, RosMessage, String


class Trigger_Request(RosMessage):
    ros_type = "std_srvs/srv/Trigger_Request"


class Trigger_Response(RosMessage):
    ros_type = "std_srvs/srv/Trigger_Response"
    success: Bool = False
    message: String = ""


class SetBool_Request(RosMessage):
    ros_type = "std_srvs/srv/SetBool_Request"
    data: Bool = False


class SetBool_Response(RosMessage):
    ros_type = "std_srvs/srv/SetBool_Response"
    success: Bool = False
    message: String = ""


class Empty_Request(RosMessage):
    ros_type = "std_srvs/srv/Empty_Request"


class Empty_Response(RosMessage):
    ros_type = "std_srvs/srv/Empty_Response"
