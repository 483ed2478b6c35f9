"""The serial 4-DOF servo arm's part of the scene (models/serial4/, seed 004: Dewi et al.
2020): the links made the scenario's lengths, each joint's hobby servo made its servo class's
(`transplanter.machine.servo`), the effector attached at the forearm's `tool_mount` by MjSpec
attach (no weld: the gripper's mount becomes a child body of the forearm) and the park pose.

The kinematics' l2 runs from the elbow axis to the grip centre (`[serial4] l2_mm`), which the
effector carries: the forearm is l2 less the effector's reach (its mount to `grip_center`),
so that `grip_center` lies exactly l2 from the elbow axis (docs/serial_arm.md).
"""

from __future__ import annotations

import math
from pathlib import Path

import mujoco

from transplanter.machine.servo import ServoClass, servo_class
from transplanter.scene.hobby_servo import apply_servo
from transplanter.scene.robots.delta import quiet_prefix_note

__all__ = [
    "ACTUATORS",
    "EFFECTOR_MODEL",
    "INERTIAL_BODIES",
    "JOINTS",
    "LINK_KG_PER_M",
    "MODEL",
    "apply",
    "apply_inertials",
    "attach_effector",
    "effector_reach_m",
    "home_ctrl",
    "home_joints",
    "quiet_prefix_note",
]

MODEL = "serial4"
"""The robot's folder: models/serial4/serial4.xml."""

INERTIAL_BODIES = ("turntable", "upper_arm", "forearm")
JOINTS = ("base", "shoulder", "elbow")
ACTUATORS = JOINTS
"""The robot's drives, one hobby servo per joint (named as its joint)."""
EFFECTOR_MODEL = "effectors/fuzzy_gripper/fuzzy_gripper.xml"
EFFECTOR_MOUNT = "gripper_mount"
MIN_FOREARM_M = 0.0
"""The forearm may be as short as nothing (the gripper then sits on the elbow servo's horn);
an l2 shorter than the effector's reach is refused."""
LINK_KG_PER_M = 0.25
"""The acrylic links' mass per length (the model's 20 g for an 80 mm upper arm)."""
ELBOW_SERVO_Y_M = 0.02
"""The elbow servo's body beside the arm (as drawn in serial4.xml)."""


def _servos(cfg) -> tuple[ServoClass, ...]:
    names = tuple(cfg.servos)
    return tuple(servo_class(n) for n in names[:3])


def attach_effector(spec: mujoco.MjSpec, models: Path, model: str = EFFECTOR_MODEL) -> None:
    """Merge the effector at the forearm's `tool_mount` site: its mount attached there (its
    bodies, joints, actuators, sensors, equalities and assets come along). Both keyframes
    go: the scene writes its own power-on pose."""
    effector = mujoco.MjSpec.from_file(str(models / model))
    for spec_ in (spec, effector):
        for key in list(spec_.keys):
            spec_.delete(key)
    with quiet_prefix_note():
        spec.site("tool_mount").attach_body(effector.body(EFFECTOR_MOUNT), "", "")


def effector_reach_m(spec: mujoco.MjSpec) -> float:
    """The attached effector's mount to its `grip_center` along the forearm (0 without an
    effector: the tool point is `tool_mount`)."""
    if spec.body(EFFECTOR_MOUNT) is None or spec.site("grip_center") is None:
        return 0.0
    return float(spec.site("grip_center").pos[0])


def apply(spec: mujoco.MjSpec, cfg) -> None:
    """The links: upper arm l1, forearm l2 less the effector's reach (call after the
    effector's own apply, which sets where its grip centre is); each servo's kp, forcerange,
    damping and armature from its class. ValueError naming the keys where l2 is shorter than
    the effector's reach."""
    l1, l2 = float(cfg.l1_m), float(cfg.l2_m)
    reach = effector_reach_m(spec)
    forearm = l2 - reach
    if forearm < MIN_FOREARM_M:
        raise ValueError(
            f"serial4.l2_mm = {l2 * 1e3:.6g} mm is shorter than the effector's reach "
            f"({reach * 1e3:.6g} mm from its mount to grip_center; fuzzy_gripper.pivot_x_mm, "
            "finger_length_mm, pad_inset_mm, grip_angle_deg set it): the grip centre must lie "
            "l2 from the elbow axis"
        )
    spec.body("base").pos = [float(v) for v in getattr(cfg, "base_pos_m", (0.0, 0.0, 0.0))]
    yaw = float(getattr(cfg, "base_yaw_rad", 0.0))
    spec.body("base").quat = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    spec.geom("upper_arm").fromto = [0, 0, 0, l1, 0, 0]
    spec.geom("elbow_servo").pos = [l1, ELBOW_SERVO_Y_M, 0]
    spec.body("forearm").pos = [l1, 0, 0]
    spec.geom("forearm").fromto = [0, 0, 0, max(forearm, 1e-4), 0, 0]
    spec.site("tool_mount").pos = [forearm, 0, 0]
    mount = spec.body(EFFECTOR_MOUNT)
    if mount is not None and mount.frame is not None:  # attached at the site's pose then
        mount.frame.pos = [forearm, 0, 0]
    for joint, servo in zip(JOINTS, _servos(cfg), strict=True):
        apply_servo(spec, joint, (joint,), servo)


def apply_inertials(spec: mujoco.MjSpec, cfg) -> None:
    """The links' masses follow their lengths; the shoulder and elbow servos' bodies weigh
    what their classes do."""
    l1, l2 = float(cfg.l1_m), float(cfg.l2_m)
    forearm = max(l2 - effector_reach_m(spec), 1e-4)
    spec.geom("upper_arm").mass = LINK_KG_PER_M * l1
    spec.geom("forearm").mass = LINK_KG_PER_M * forearm
    _, shoulder, elbow = _servos(cfg)
    spec.geom("shoulder_servo").mass = shoulder.mass_kg
    spec.geom("elbow_servo").mass = elbow.mass_kg


def home_joints(cfg) -> dict[str, float]:
    """The park pose (rad): `[serial4] park_*`."""
    return dict(zip(JOINTS, (float(q) for q in cfg.park_rad), strict=True))


def home_ctrl(cfg) -> list[float]:
    """The servos' commands at power-on: the park pose's joint angles (rad)."""
    return [float(q) for q in cfg.park_rad]
