"""The pure-numpy machine a scenario describes: geometry, limits, drives, firmware configs.

No MuJoCo here: this is what the firmware (and `transplanter ik` / `plan`) needs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from transplanter.firmware.eeprom import EepromImage, Pickup
from transplanter.firmware.pgf import PGFConfig
from transplanter.firmware.sgf import SGFConfig
from transplanter.kinematics import FiveBarGeometry, KinematicLimits
from transplanter.motion import MotionConfig
from transplanter.scenario import Scenario, ScenarioError
from transplanter.steppers import StepperDrive

__all__ = [
    "Machine",
    "machine_from_scenario",
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


def machine_from_scenario(s: Scenario) -> Machine:
    """Build the firmware side of the machine; a value the firmware refuses is a
    ScenarioError naming the scenario's sections."""
    try:
        return _machine(s)
    except ValueError as exc:
        if isinstance(exc, ScenarioError):
            raise
        raise ScenarioError(
            f"the scenario's [arm], [limits], [drives], [motion], [gripper] or [taught] values "
            f"do not make a working machine: {exc}"
        ) from None


def _machine(s: Scenario) -> Machine:
    arm, lim, drv, mot, grip = s["arm"], s["limits"], s["drives"], s["motion"], s["gripper"]
    geometry = FiveBarGeometry(l0_m=arm["l0_m"], l1_m=arm["l1_m"], l2_m=arm["l2_m"])
    limits = KinematicLimits(
        motor_min_rad=lim["motor1_min_rad"],
        motor_max_rad=lim["motor1_max_rad"],
        motor2_min_rad=lim["motor2_min_rad"],
        motor2_max_rad=lim["motor2_max_rad"],
        elbow_min_rad=lim["elbow_min_rad"],
        elbow_max_rad=lim["elbow_max_rad"],
        transmission_min_rad=lim["transmission_min_rad"],
        transmission_max_rad=lim["transmission_max_rad"],
        max_condition=lim["max_condition"],
    )
    common = dict(
        steps_per_rev=drv["steps_per_rev"],
        microsteps=drv["microsteps"],
        max_step_rate_hz=drv["max_step_rate_hz"],
        holding_torque_nm=drv["holding_torque_nm"],
    )
    drives = (
        StepperDrive("arm1", ratio=drv["arm_belt_ratio"], **common),
        StepperDrive("arm2", ratio=drv["arm_belt_ratio"], **common),
        StepperDrive("z", ratio=1.0, lead_m=drv["z_lead_m"], **common),
    )
    motion = MotionConfig(
        resolution_m=mot["resolution_m"],
        accel_m_s2=mot["accel_m_s2"],
        profile=mot["profile"],
        compute_time_per_point_s=mot["compute_time_per_point_s"],
    )
    sgf = SGFConfig(
        geometry=geometry,
        limits=limits,
        drives=drives,
        motion=motion,
        z_min_m=lim["z_min_m"],
        z_max_m=lim["z_max_m"],
        home_theta1_rad=drv["home_theta1_rad"],
        home_theta2_rad=drv["home_theta2_rad"],
        home_z_m=drv["home_z_m"],
        homing_locate_rate_hz=(
            drv["homing_locate_rate_arm_hz"],
            drv["homing_locate_rate_arm_hz"],
            drv["homing_locate_rate_z_hz"],
        ),
        homing_rate_hz=(
            drv["homing_rate_arm_hz"],
            drv["homing_rate_arm_hz"],
            drv["homing_rate_z_hz"],
        ),
        conveyor_index_s=s["conveyor"]["index_time_s"],
        mode=arm["working_mode"],
    )
    pgf = PGFConfig(
        gripper_servo=GRIPPER_SERVO,
        wrist_servo=WRIST_SERVO,
        gripper_open_deg=math.degrees(grip["open_rad"]),
        gripper_close_deg=math.degrees(grip["close_rad"]),
        open_dwell_s=grip["open_dwell_s"],
        close_dwell_s=grip["close_dwell_s"],
        release_dwell_s=grip["release_dwell_s"],
        seedlings=s["scenario"]["seedlings"],
        line_numbers=s["bus"]["line_numbers"],
    )
    taught = s["taught"]
    taught_image = EepromImage(
        pickups=tuple(
            Pickup(
                approach_xy_m=p["approach_m"],
                grip_xy_m=p["grip_m"],
                elbow_deg=math.degrees(p["elbow_rad"]),
            )
            for p in taught["pickup"]
        ),
        drop_xy_m=taught["drop_m"],
        drop_elbow_deg=math.degrees(taught["drop_elbow_rad"]),
        z_up_m=taught["z_up_m"],
        z_low_m=taught["z_low_m"],
        s_low_m_s=taught["s_low_m_s"],
        s_high_m_s=taught["s_high_m_s"],
    )
    # The PGF works from the EEPROM's bytes, as on the machine: quantised and CRC-checked.
    eeprom = EepromImage.from_bytes(taught_image.to_bytes())
    return Machine(
        geometry,
        limits,
        arm["working_mode"],
        drives,
        motion,
        sgf,
        pgf,
        eeprom,
        s["bus"]["baud_bps"],
    )
