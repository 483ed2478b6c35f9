"""Seed 004's two-finger gripper on a hobby servo, set by its fuzzy controller."""

from dataclasses import dataclass

from transplanter.kinds.interfaces import ALL
from transplanter.kinds.sections import Section, key

NAME = "fuzzy_gripper"
SUMMARY = "two-finger servo gripper with an ultrasonic sensor (seed 004)"
SCENE = "transplanter.scene.effectors.fuzzy_gripper"
MODEL = "fuzzy_gripper"
READS = {
    "fuzzy_gripper": ALL,
    "serial4": ("gripper_servo",),  # its servo's class, kept with the arm's servos
}


@dataclass(frozen=True)
class FuzzyGripperSection:
    """[fuzzy_gripper]: the serial arm's two-finger gripper sized for tomatoes
    (`transplanter.scene.effectors.fuzzy_gripper.FuzzyGripperConfig`, whose fields are the file
    keys; its servo class is `[serial4] gripper_servo`), read by the serial arm's scene.
    Optional: the defaults are FuzzyGripperConfig's estimates (docs/serial_arm.md)."""

    pivot_x_m: float = key("float", -100, 100, doc="finger pivots ahead of the mount (<0 behind)")
    pivot_offset_m: float = key("float", 1, 100, doc="each pivot from the centre line")
    finger_length_m: float = key("float", 10, 300, doc="pivot to the pad face's centre")
    pad_inset_m: float = key("float", 0, 50, doc="pad face inward of the finger's pivot line")
    pad_length_m: float = key("float", 2, 100, doc="pad along the finger")
    pad_height_m: float = key("float", 2, 100, doc="pad across the finger plane")
    pad_thickness_m: float = key("float", 0.5, 20, doc="rubber pad thickness")
    pad_friction: float = key("float", 0.05, 3, doc="pads' sliding friction (theirs governs)")
    grip_angle_rad: float = key("float", 0, 60, doc="servo angle: pads parallel, grip_center")
    open_angle_rad: float = key("float", 0, 60, doc="servo angle at power-on (standby)")
    sensor_height_m: float = key("float", 0, 100, doc="HC-SR04 axis above the finger plane")
    finger_mass_kg: float = key("float", 0.1, 500, doc="one finger with its pad")
    palm_mass_kg: float = key("float", 0.1, 500, doc="bracket and palm (no servo, no sensor)")
    sensor_mass_kg: float = key("float", 0.1, 500, doc="HC-SR04 module")


_FUZZY_GRIPPER_DEFAULTS = {
    "pivot_x_mm": -10.0,
    "pivot_offset_mm": 15.0,
    "finger_length_mm": 80.0,
    "pad_inset_mm": 8.0,
    "pad_length_mm": 24.0,
    "pad_height_mm": 20.0,
    "pad_thickness_mm": 3.0,
    "pad_friction": 0.9,
    "grip_angle_deg": 22.5,
    "open_angle_deg": 48.0,
    "sensor_height_mm": 20.0,
    "finger_mass_g": 6.0,
    "palm_mass_g": 10.0,
    "sensor_mass_g": 8.5,
}


def _check(fg: dict) -> str | None:
    if fg["grip_angle_rad"] >= fg["open_angle_rad"]:
        return (
            "fuzzy_gripper.grip_angle_deg must be below fuzzy_gripper.open_angle_deg (the "
            "standby opens wider than the grip)."
        )
    return None


SECTIONS = {
    "fuzzy_gripper": Section(
        FuzzyGripperSection,
        defaults=_FUZZY_GRIPPER_DEFAULTS,
        check=_check,
        file_keys={
            "finger_mass_kg": "finger_mass_g",
            "palm_mass_kg": "palm_mass_g",
            "sensor_mass_kg": "sensor_mass_g",
        },
    ),
}
"""Its own sections (transplanter.kinds.sections)."""
