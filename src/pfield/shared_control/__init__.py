"""Shared control: the field's recommended motion (the autonomy vector) and its blend with an operator's command.

* :mod:`~pfield.shared_control.autonomy` — the task-space and whole-body autonomy vectors (ComputeAutonomyVector).
* :mod:`~pfield.shared_control.assistance` — the operator's twist (or, whole body, joint velocities) arbitrated
  with the field's, the dampers on the blend, the nearest obstacle, time to collision and flags (ComputeAssistance);
  docs/assistance.md.
* :mod:`~pfield.shared_control.servo` — the servo loop: the latest operator twist or joint jog turned into joint
  commands at a fixed rate through the assistance, under MoveIt Servo's parameter names
  (:mod:`~pfield.shared_control.servo_config`); docs/servo.md.

Every command these return keeps the output contract of :mod:`pfield.safety` (finite, within the limits).
"""

from pfield.shared_control.assistance import (
    ARBITRATIONS,
    Assistance,
    AssistanceOptions,
    AssistanceScene,
    Flag,
    task_space_assistance,
    whole_body_assistance,
)
from pfield.shared_control.autonomy import (
    WholeBodyAutonomy,
    task_space_autonomy_vector,
    whole_body_autonomy,
    whole_body_autonomy_vector,
)
from pfield.shared_control.servo import Servo, ServoCommand, ServoStatus
from pfield.shared_control.servo_config import ServoConfig

__all__ = [
    "ARBITRATIONS",
    "Assistance",
    "AssistanceOptions",
    "AssistanceScene",
    "Flag",
    "Servo",
    "ServoCommand",
    "ServoConfig",
    "ServoStatus",
    "WholeBodyAutonomy",
    "task_space_assistance",
    "task_space_autonomy_vector",
    "whole_body_assistance",
    "whole_body_autonomy",
    "whole_body_autonomy_vector",
]
