"""The pure-numpy machine: the firmware's configs, built once from a scenario.

No MuJoCo here: this is what the firmware (and `transplanter ik` / `plan`) needs.
`transplanter.scenario.assemble.machine_config` builds it from a scenario. The arm (its
kinematics, with the axes' drives), its motion and homing are held once, by the SGF's config;
the properties below only name them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from transplanter.machine.eeprom import EepromImage
from transplanter.machine.kinematics import Kinematics
from transplanter.machine.motion import MotionConfig
from transplanter.machine.pgf import PGFConfig
from transplanter.machine.sgf import SGFConfig
from transplanter.machine.steppers import StepperDrive

__all__ = [
    "Machine",
    "power_on_joints",
    "GRIPPER_SERVO",
    "WRIST_SERVO",
    "POWER_ON_SHORT_OF_SWITCHES",
]

GRIPPER_SERVO = 0
WRIST_SERVO = 1
POWER_ON_SHORT_OF_SWITCHES = (math.radians(5.0), 0.010)
"""Where the motors are when the machine is switched on: this far short of their homing
switches (a rotary axis in rad, a slide in m), so that G28 has a little way to travel."""


@dataclass(frozen=True)
class Machine:
    """Everything the firmware side needs, built once from a scenario."""

    sgf: SGFConfig
    pgf: PGFConfig
    eeprom: EepromImage
    baud_bps: float

    @property
    def kinematics(self) -> Kinematics:
        """The arm (the SGF's)."""
        return self.sgf.kinematics

    @property
    def drives(self) -> tuple[StepperDrive, ...]:
        """The arm's drives, in motor order."""
        return self.sgf.kinematics.drives

    @property
    def motion(self) -> MotionConfig:
        """The SGF's interpolation and speed profile."""
        return self.sgf.motion


def power_on_joints(sgf: SGFConfig) -> tuple[float, ...]:
    """Joint positions (rad or m) at power-on: short of the switches, against homing."""
    axes = sgf.kinematics.axes
    return tuple(
        float(axis.home_position - d * POWER_ON_SHORT_OF_SWITCHES[axis.linear])
        for axis, d in zip(axes, sgf.homing.dirs, strict=True)
    )
