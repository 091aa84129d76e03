"""Robots: URDF models (pinocchio), compiled kinematics, link capsules, collision checks and IK."""

from __future__ import annotations

from typing import TYPE_CHECKING

from pfield._lazy import lazy_exports
from pfield.robot.description import RobotDescription
from pfield.robot.model import RobotModel

if TYPE_CHECKING:
    from pfield.robot._fit import fit_cache_directory

__all__ = ["RobotDescription", "RobotModel", "fit_cache_directory"]

__getattr__, __dir__ = lazy_exports(__name__, {"fit_cache_directory": "pfield.robot._fit"}, globals())
""":func:`fit_cache_directory` (where link-model fits are kept on disk), imported on first use with the fitting."""
