"""The built-in robots the robot tests use (one load per test module, as before)."""

from __future__ import annotations

import pytest

from pfield.robot import RobotModel


@pytest.fixture(scope="module")
def xarm() -> RobotModel:
    return RobotModel.builtin("xarm7")


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel.builtin("panda")
