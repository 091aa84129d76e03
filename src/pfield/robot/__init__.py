"""Robots: URDF models (pinocchio), compiled kinematics, link capsules, collision checks and IK."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pfield.robot.description import RobotDescription
from pfield.robot.model import RobotModel

if TYPE_CHECKING:
    from pfield.robot._fit import fit_cache_directory

__all__ = ["RobotDescription", "RobotModel", "fit_cache_directory"]


def __getattr__(name: str) -> Any:
    """:func:`fit_cache_directory` (where link-model fits are kept on disk), imported on first use with the fitting."""
    if name == "fit_cache_directory":
        from pfield.robot._fit import fit_cache_directory

        return fit_cache_directory
    raise AttributeError(f"module 'pfield.robot' has no attribute {name!r}")
