"""Launch pfield as a ROS 2 node in a full ROS 2 Jazzy install (``ros2 launch ros/launch/pfield.launch.py``).

Starts ``pfield ros2 node`` (the ``/pfield_manager`` node, plus ``/costmap`` with ``map:=`` and the
base controller with its options) with the given parameters file, and RViz when ``rviz:=true``.
Needs, in the environment the launch runs in: pfield installed with its ``ros2`` requirements
satisfied by the system's ROS 2 (``pip install pfield`` into a venv created with
``--system-site-packages`` after ``source /opt/ros/jazzy/setup.bash``) and the interface package built
in a sourced colcon workspace (docs/ros2.md, "colcon").

Not tested by ``make test``: the machine it runs on has no ROS 2 install and no ``launch`` package
(only the rclpy wheels). ``make test`` exercises the same node through ``pfield ros2 node`` instead.

Arguments: ``robot`` (xarm7, panda or a URDF path), ``params`` (a ``ros__parameters`` YAML file, may
be empty), ``package_path`` (``NAME=DIR`` for ``package://`` meshes, may be empty), ``map`` (a
map_server YAML for the costmap node, may be empty), ``rviz`` (true/false), ``log_level``.
"""

from __future__ import annotations

from launch import LaunchContext, LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

ARGUMENTS = {
    "robot": ("xarm7", "xarm7, panda or a URDF file"),
    "params": ("", "ROS 2 parameters YAML (node: ros__parameters: ...), empty for defaults"),
    "package_path": ("", "NAME=DIR resolving package://NAME/ mesh URIs, empty for none"),
    "map": ("", "map_server YAML for the costmap node, empty: it waits for /map"),
    "rviz": ("false", "also start RViz"),
    "log_level": ("info", "debug, info, warning or error"),
}


def _pfield_command(context: LaunchContext) -> list[ExecuteProcess]:
    """``pfield ros2 node`` with only the options that were given."""
    value = {name: LaunchConfiguration(name).perform(context) for name in ARGUMENTS}
    command = ["pfield", "ros2", "node", "--robot", value["robot"], "--log-level", value["log_level"]]
    for option in ("params", "package_path", "map"):
        if value[option]:
            command += [f"--{option.replace('_', '-')}", value[option]]
    return [ExecuteProcess(cmd=command, name="pfield", output="screen", sigterm_timeout="15")]


def generate_launch_description() -> LaunchDescription:
    declared = [DeclareLaunchArgument(name, default_value=default, description=text)
                for name, (default, text) in ARGUMENTS.items()]
    rviz = Node(package="rviz2", executable="rviz2", name="rviz2", output="screen",
                condition=IfCondition(LaunchConfiguration("rviz")))
    return LaunchDescription([*declared, OpaqueFunction(function=_pfield_command), rviz])
