"""The 4-DOF hobby-servo arm of seed 004 (Dewi, Nurmaini, Risma, Oktarina and Roriz 2020):
analytic IK, four PWM servos, a host that reads two ultrasonic sensors."""

from dataclasses import dataclass

from transplanter.kinds.interfaces import ALL
from transplanter.kinds.sections import Section, key

NAME = "serial4"
SUMMARY = "4-DOF serial arm on hobby PWM servos, analytic IK (seed 004)"
KINEMATICS = "transplanter.machine.kinematics.serial4:Serial4Kinematics"
SCENE = "transplanter.scene.robots.serial4"
MODEL = "serial4"
CONTROLLER = "servo"
READS = {
    "serial4": ALL,  # links, servos, windows
    # its controller's motion and its host's grasp and release (in every job it does)
    "serial_arm": (
        "travel_speed_mm_s",
        "approach_speed_mm_s",
        "path_accel_mm_s2",
        "segment_mm",
        "point_time_us",
        "hover_mm",
        "grip_settle_ms",
        "release_settle_ms",
        "sensor_resolution_mm",
    ),
}


@dataclass(frozen=True)
class Serial4Section:
    """[serial4]: the serial 4-DOF servo arm of seed 004 (`[robot] kind = "serial4"`), read
    only by its kinematics; optional, default the MeArm-class arm (docs/serial_arm.md)."""

    l1_m: float = key("float", 1, 1000, doc="shoulder axis to elbow axis")
    l2_m: float = key("float", 1, 1000, doc="elbow axis to the grip centre")
    elbow: str = key("str", choices=("up", "down"), doc="IK branch")
    base_min_rad: float = key("float", -180, 180, doc="base yaw window (a servo's 180 deg)")
    base_max_rad: float = key("float", -180, 180, doc="upper end of the base yaw window")
    shoulder_min_rad: float = key("float", -180, 180, doc="shoulder elevation window")
    shoulder_max_rad: float = key(
        "float", -180, 180, doc="upper end of the shoulder elevation window"
    )
    elbow_min_rad: float = key("float", -180, 180, doc="elbow window (relative angle)")
    elbow_max_rad: float = key("float", -180, 180, doc="upper end of the elbow window")
    min_radius_m: float = key("float", 0, 1000, doc="closest target to the base axis")
    y_min_m: float = key("float", -1000, 1000, doc="lowest target height above the shoulder")
    y_max_m: float = key("float", -1000, 1000, doc="highest target height")
    park_base_rad: float = key("float", -180, 180, doc="park pose, where G28 sends the arm")
    park_shoulder_rad: float = key("float", -180, 180, doc="shoulder elevation of the park pose")
    park_elbow_rad: float = key(
        "float", -180, 180, doc="elbow angle of the park pose (relative to the upper arm)"
    )
    base_servo: str = key("str", choices=("sg90", "mg996r"), doc="hobby servo class")
    shoulder_servo: str = key(
        "str",
        choices=("sg90", "mg996r"),
        doc="the shoulder's hobby servo class: its speed and stall torque",
    )
    elbow_servo: str = key(
        "str",
        choices=("sg90", "mg996r"),
        doc="the elbow's hobby servo class: its speed and stall torque",
    )
    gripper_servo: str = key(
        "str",
        choices=("sg90", "mg996r"),
        doc="hobby servo class of the fuzzy gripper's finger servo",
    )


_SERIAL4_DEFAULTS = {
    "l1_mm": 80.0,
    "l2_mm": 80.0,
    "elbow": "up",
    "base_min_deg": -90.0,
    "base_max_deg": 90.0,
    "shoulder_min_deg": 0.0,
    "shoulder_max_deg": 180.0,
    "elbow_min_deg": -165.0,
    "elbow_max_deg": 15.0,
    "min_radius_mm": 20.0,
    "y_min_mm": -50.0,
    "y_max_mm": 160.0,
    "park_base_deg": 0.0,
    "park_shoulder_deg": 90.0,
    "park_elbow_deg": -90.0,
    "base_servo": "sg90",
    "shoulder_servo": "mg996r",
    "elbow_servo": "mg996r",
    "gripper_servo": "sg90",
}


SECTIONS = {
    "serial4": Section(Serial4Section, defaults=_SERIAL4_DEFAULTS),
}
"""Its own sections (transplanter.kinds.sections)."""
