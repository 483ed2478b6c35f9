"""The servo-driven two-finger gripper of seed 004 (Dewi, Nurmaini, Risma, Oktarina and Roriz,
*Inverse kinematic analysis of 4 DOF pick and place arm robot manipulator using fuzzy logic
controller*, IJECE 10(2), 2020) as an effector kind, sized for the paper's tomatoes (5-7 cm
across, 70-150 g): an SG90-class servo opens two hinged fingers (each by half the servo angle
theta4, the fingers geared together), rubber pads on the fingers hold the fruit by friction,
and the HC-SR04 (the paper's sensor 2) looks ahead over the fingers.

The bodies are drawn in models/effectors/fuzzy_gripper/fuzzy_gripper.xml; `apply` sets their
numbers from a `FuzzyGripperConfig` (the `[fuzzy_gripper]` keys, file units) and the servo
class. The paper gives none of these numbers (docs/serial_arm.md): each is an estimate, sized
so that the fuzzy controller's Small output (20-25 deg) closes the pads narrower than a 5 cm
tomato (the servo squeezes at its stall torque) and its standby (48 deg, in Big) clears a
7 cm one.

Why the fingers are long: each finger turns theta4 / 2, so between Small (22.5 deg) and the
standby (48 deg) it turns 12.75 deg, and a pad a distance x ahead of its pivot moves sideways
by about x * 0.2225 rad: 30 mm more gap (from under 50 to 80 mm) takes x of about 68-77 mm.

Nothing here glues the object to the fingers: it is held by the pads' friction only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco

from transplanter.errors import TransplanterError
from transplanter.machine.servo import ServoClass, servo_class
from transplanter.scene.handles import GripperParts
from transplanter.scene.hobby_servo import apply_servo

__all__ = [
    "ACTUATORS",
    "ACTUATOR",
    "FINGERS",
    "MOUNT",
    "PADS",
    "PARTS",
    "FuzzyGripperConfig",
    "GripperNotInScene",
    "add_canopy_contact",
    "apply",
    "gripper_config",
    "home_ctrl",
    "home_joints",
    "pad_gap_m",
    "reach_m",
]

MOUNT = "gripper_mount"
FINGERS = ("finger_left", "finger_right")
PADS = ("finger_left_pad", "finger_right_pad")
ACTUATOR = "gripper"
ACTUATORS = (ACTUATOR,)
PARTS = GripperParts(root=MOUNT, pads=PADS, site="grip_center", bridge="palm")
"""Its parts as the pot line's handles name them (`scene.handles.PotLine`): the palm is the
bridge over the grip, the pads what grips."""


@dataclass(frozen=True)
class FuzzyGripperConfig:
    """The `[fuzzy_gripper]` keys (file units in the names) and the servo class (from
    `[serial4] gripper_servo`). The paper gives none of these numbers: estimates
    (docs/serial_arm.md)."""

    pivot_x_mm: float = -10.0
    """The fingers' pivots along the gripper's forward axis from the mount (negative: behind
    it; the gripper's bracket clamps over the forearm's end)."""
    pivot_offset_mm: float = 15.0
    """Each pivot's distance from the gripper's centre line."""
    finger_length_mm: float = 80.0
    """Pivot to the centre of the pad's face, along the finger."""
    pad_inset_mm: float = 8.0
    """The pad's face inward of the line through the finger's pivot."""
    pad_length_mm: float = 24.0
    """The pad along the finger."""
    pad_height_mm: float = 20.0
    """The pad across the finger plane (vertical with the forearm level)."""
    pad_thickness_mm: float = 3.0
    """The rubber pad's thickness."""
    pad_friction: float = 0.9
    """Sliding friction of the pads (rubber, estimate): the contact's against an object of the
    same contact priority (MuJoCo takes the larger of the two) or a lower one; the
    pool_to_belt tomatoes have priority 1, so their drawn skin-pad friction governs."""
    grip_angle_deg: float = 22.5
    """Servo angle at which the pads are parallel and `grip_center` lies midway between them
    (the centroid of the fuzzy controller's Small)."""
    open_angle_deg: float = 48.0
    """Servo angle at power-on (the standby: the centroid of the controller's Big)."""
    sensor_height_mm: float = 20.0
    """The HC-SR04's axis above the finger plane."""
    finger_mass_g: float = 6.0
    """One finger with its pad."""
    palm_mass_g: float = 10.0
    """The bracket and palm plate (the servo and the sensor board counted apart)."""
    sensor_mass_g: float = 8.5
    """The HC-SR04 module."""
    servo: str = "sg90"
    """The gripper servo's class (not a `[fuzzy_gripper]` key: `[serial4] gripper_servo`)."""

    def __post_init__(self) -> None:
        servo_class(self.servo)
        if not 0 <= self.grip_angle_deg < self.open_angle_deg <= 60:
            raise ValueError(
                "FuzzyGripperConfig: needs 0 <= grip_angle_deg < open_angle_deg <= 60 (the "
                "gripper servo's 0-60 deg)"
            )

    @property
    def servo_class(self) -> ServoClass:
        return servo_class(self.servo)

    @property
    def grip_angle_rad(self) -> float:
        return math.radians(self.grip_angle_deg)

    @property
    def open_angle_rad(self) -> float:
        return math.radians(self.open_angle_deg)

    def pad_face_m(self, theta4_rad: float) -> tuple[float, float]:
        """(x, y) of the left pad's face centre in the mount's frame at servo angle theta4
        (the right pad mirrors y)."""
        phi = theta4_rad / 2
        lp, w = self.finger_length_mm * 1e-3, self.pad_inset_mm * 1e-3
        x = self.pivot_x_mm * 1e-3 + lp * math.cos(phi) + w * math.sin(phi)
        y = self.pivot_offset_mm * 1e-3 + lp * math.sin(phi) - w * math.cos(phi)
        return x, y


def pad_gap_m(cfg: FuzzyGripperConfig, theta4_rad: float) -> float:
    """Distance between the pads' face centres at servo angle theta4 (analytic)."""
    return 2 * cfg.pad_face_m(theta4_rad)[1]


def reach_m(cfg: FuzzyGripperConfig) -> float:
    """Mount to `grip_center` along the gripper's forward axis: midway between the pads' face
    centres at the grip angle."""
    return cfg.pad_face_m(cfg.grip_angle_rad)[0]


class GripperNotInScene(TransplanterError, ValueError):
    """The scene has no fuzzy gripper to set: its model was not merged into it."""


def gripper_config(cfg) -> FuzzyGripperConfig:
    """The gripper's config from what a caller holds: a FuzzyGripperConfig, or a scene config
    with `gripper` (and `servos`, whose last name is the gripper servo's); else the
    defaults."""
    if isinstance(cfg, FuzzyGripperConfig):
        return cfg
    gripper = getattr(cfg, "gripper", None) or FuzzyGripperConfig()
    servos = getattr(cfg, "servos", None)
    if servos is not None and len(servos) == 4:
        gripper = replace(gripper, servo=servos[3])
    return gripper


def _quat_z(angle: float) -> list[float]:
    return [math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)]


def apply(spec: mujoco.MjSpec, cfg) -> None:
    """The fingers' pivots, lengths and pads, `grip_center`, the sensor's height, the masses
    and the servo: a position actuator on theta4 (gear 2 on `finger_left`, `finger_sync`
    turning `finger_right` alike) with kp = stall torque / 3 deg and forcerange = the stall
    torque at the servo shaft; each finger's damping and armature are twice the servo's
    (reflected through the 2:1 to two fingers: at full torque the servo turns at its rated
    speed)."""
    c = gripper_config(cfg)
    if spec.body(MOUNT) is None:
        raise GripperNotInScene(
            f"effector.kind fuzzy_gripper: the scene has no body {MOUNT!r}; the gripper's model "
            "(models/effectors/fuzzy_gripper/fuzzy_gripper.xml) must be attached at the serial "
            "arm's tool_mount (transplanter.scene.serial_scene does)"
        )
    mm = 1e-3
    phi = c.grip_angle_rad / 2
    lp, w, t = c.finger_length_mm * mm, c.pad_inset_mm * mm, c.pad_thickness_mm * mm
    half = [c.pad_length_mm * mm / 2, t / 2, c.pad_height_mm * mm / 2]
    for name, side in zip(FINGERS, (1.0, -1.0), strict=True):
        body = spec.body(name)
        body.pos = [c.pivot_x_mm * mm, side * c.pivot_offset_mm * mm, 0.0]
        # the pad's face centre at (lp, -w) in the finger's frame (mirrored on the right),
        # turned by -phi so that the faces are parallel at the grip angle
        pad = spec.geom(f"{name}_pad")
        pad.size = half
        pad.quat = _quat_z(-side * phi)
        pad.pos = [lp + math.sin(phi) * t / 2, side * (-w + math.cos(phi) * t / 2), 0.0]
        pad.friction = [c.pad_friction, pad.friction[1], pad.friction[2]]
        holder = spec.geom(f"{name}_holder")
        back = max(w - t, 0.001)
        holder.size = [half[0], back / 2, half[2] * 0.6]
        holder.quat = pad.quat
        out = t + back / 2  # the holder behind the pad
        holder.pos = [lp + math.sin(phi) * out, side * (-w + math.cos(phi) * out), 0.0]
        beam = spec.geom(f"{name}_beam")
        beam.size = [(lp + half[0] + 0.004) / 2, beam.size[1], beam.size[2]]
        beam.pos = [(lp + half[0] - 0.004) / 2, 0.0, 0.0]
        beam.mass = c.finger_mass_g * 1e-3
    x, _ = c.pad_face_m(c.grip_angle_rad)
    spec.site("grip_center").pos = [x, 0.0, 0.0]
    sensor = spec.site("gripper_sensor")
    sensor.pos = [sensor.pos[0], 0.0, c.sensor_height_mm * mm]
    board = spec.geom("hc_sr04")
    board.pos = [board.pos[0], 0.0, c.sensor_height_mm * mm]
    board.mass = c.sensor_mass_g * 1e-3
    spec.geom("palm").mass = c.palm_mass_g * 1e-3
    servo = c.servo_class
    spec.geom("gripper_servo").mass = servo.mass_kg
    apply_servo(spec, ACTUATOR, FINGERS, servo, share=2)  # each finger through the 2:1 gear


def add_canopy_contact(spec: mujoco.MjSpec, cfg) -> None:
    """Nothing to do: the serial arm's job (tomatoes from a box onto a belt) has no canopy
    whose strikes are counted, and the pads already collide with everything (contype 1)."""


def home_joints(cfg) -> dict[str, float]:
    """Each finger at half the standby servo angle."""
    half = gripper_config(cfg).open_angle_rad / 2
    return {"finger_left": half, "finger_right": half}


def home_ctrl(cfg) -> list[float]:
    """The gripper servo's power-on command: the standby angle theta4 (rad)."""
    return [gripper_config(cfg).open_angle_rad]
