"""The pure-numpy machine: geometry, limits, drives and the firmware's configs.

No MuJoCo here: this is what the firmware (and `transplanter ik` / `plan`) needs.
`transplanter.scenario.assemble.machine_config` builds it from a scenario.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from transplanter.machine.eeprom import EepromImage
from transplanter.machine.kinematics.fivebar import FiveBarGeometry, KinematicLimits
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
# Where the motors are when the machine is switched on: this far short of limit switches 1,
# 2 and 3 (rad, rad, m), so that G28 has a little way to travel.
POWER_ON_SHORT_OF_SWITCHES = (math.radians(5.0), math.radians(5.0), 0.010)


@dataclass(frozen=True)
class Machine:
    """Everything the firmware side needs, built once from a scenario."""

    geometry: FiveBarGeometry
    limits: KinematicLimits
    mode: str
    drives: tuple[StepperDrive, StepperDrive, StepperDrive]
    motion: MotionConfig
    sgf: SGFConfig
    pgf: PGFConfig
    eeprom: EepromImage
    baud_bps: float


def power_on_joints(sgf: SGFConfig) -> tuple[float, float, float]:
    """theta1, theta2 (rad), Z (m) at power-on: short of the switches, against homing."""
    home = sgf.home_joint_positions
    return tuple(
        float(h - d * short)
        for h, d, short in zip(home, sgf.homing_dirs, POWER_ON_SHORT_OF_SWITCHES, strict=True)
    )
