"""``sensor_msgs`` messages used by the mobile base: ``LaserScan``.

Fields exactly as ``sensor_msgs/msg/LaserScan`` (ROS 2 Jazzy). Beam ``i`` points at
``angle_min + i * angle_increment`` (rad, counter-clockwise from the sensor frame's +x axis). Ranges outside
``[range_min, range_max]`` or non-finite (``inf`` = no return, ``nan`` = invalid) are to be ignored by consumers;
the model therefore accepts ``inf``/``nan`` in ``ranges`` (pydantic's default), as the ROS type does.
"""

from __future__ import annotations

from pydantic import ConfigDict, Field

from pfield.interfaces._base import Float32, RosMessage
from pfield.interfaces.std_msgs import Header

__all__ = ["LaserScan"]


class LaserScan(RosMessage):
    """A planar laser scan (angles in rad, ranges in m, times in s)."""

    # ``inf`` ranges are normal ("no return"): keep them through JSON as ``Infinity``/``NaN`` literals
    # (what Python's json module and pydantic read back) instead of pydantic's default ``null``.
    model_config = ConfigDict(**{**RosMessage.model_config, "ser_json_inf_nan": "constants"})  # type: ignore[typeddict-item]

    ros_type = "sensor_msgs/msg/LaserScan"
    header: Header = Field(default_factory=Header)
    angle_min: Float32 = 0.0
    angle_max: Float32 = 0.0
    angle_increment: Float32 = 0.0
    time_increment: Float32 = 0.0
    scan_time: Float32 = 0.0
    range_min: Float32 = 0.0
    range_max: Float32 = 0.0
    ranges: list[Float32] = Field(default_factory=list)
    intensities: list[Float32] = Field(default_factory=list)
