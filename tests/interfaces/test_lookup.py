"""Type lookups work whatever the caller imported before (run in a fresh interpreter)."""

from __future__ import annotations

import subprocess
import sys


def test_lookup_service_without_importing_the_interface_modules_first() -> None:
    code = ("from pfield.interfaces import lookup_service, lookup_type, registered_services\n"
            "print(lookup_service('potential_fields_interfaces/srv/PlanPath').request.ros_type)\n"
            "print(lookup_type('visualization_msgs/msg/MarkerArray').ros_type)\n"
            "print('std_srvs/srv/Trigger' in registered_services())\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["potential_fields_interfaces/srv/PlanPath_Request",
                                   "visualization_msgs/msg/MarkerArray", "True"]
