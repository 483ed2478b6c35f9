"""The parallel-jaw effector's part of the scene: two jaws on slides under the robot's column,
closed by a hobby servo whose force limit is the grip force (a pot is held by friction only),
and the wrist servo that turns them. Each jaw hangs on a side plate from the bridge (the
palm), high enough over the grip centre that the seedling's shoot stands free between them.
Its Menagerie folder is models/effectors/parallel_jaw/ (attached at the robot's mount frame by
transplanter.scene.build); this module sets its numbers from the SceneConfig.
"""

from __future__ import annotations

import mujoco

from transplanter.scene.config import BIT_CANOPY, JAW_HALF_THICKNESS, SceneConfig
from transplanter.scene.geometry import bridge_box, column_box, side_plate_box

MODEL = "parallel_jaw"
"""The effector's Menagerie folder: models/effectors/parallel_jaw/parallel_jaw.xml."""
ROOT = "gripper"
"""Its root body, attached at the robot's mount (transplanter.scene.build.mounts)."""
JAWS = ("jaw_left", "jaw_right")
ACTUATORS = ("gripper", "wrist")
"""The effector's drives: the jaws' servo and the wrist's."""
SIDE_PLATES = ("side_plate_left", "side_plate_right")  # visual: they carry the jaws


def apply(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """The column down to the grip centre and the palm (the bridge: its underside
    bridge_clearance_m above the grip centre), jaw positions under the column, the gripper
    and wrist servos, jaw travel and damping."""
    bridge_half, bridge_z = bridge_box(cfg)
    for geom_name in ("palm", "palm_visual"):
        g = spec.geom(geom_name)
        g.pos = [g.pos[0], g.pos[1], bridge_z]
        g.size = [g.size[0], g.size[1], bridge_half]
    column = spec.geom("column")
    half_length, centre_z = column_box(cfg)
    column.size = [column.size[0], half_length, 0]
    column.pos = [0, 0, centre_z]
    spec.site("grip_center").pos = [0, 0, -cfg.column_height_m]
    spec.body("jaw_left").pos = [-JAW_HALF_THICKNESS, 0, -cfg.column_height_m]
    spec.body("jaw_right").pos = [JAW_HALF_THICKNESS, 0, -cfg.column_height_m]
    plate_half, plate_z = side_plate_box(cfg)  # up to the bridge, riding with the jaw
    for plate in SIDE_PLATES:
        g = spec.geom(plate)
        g.size = [g.size[0], g.size[1], plate_half]
        g.pos = [g.pos[0], g.pos[1], plate_z]
    grip = spec.actuator("gripper")
    grip.gainprm = [cfg.gripper_kp_n_m] + [0] * 9
    grip.biasprm = [0, -cfg.gripper_kp_n_m, 0] + [0] * 7
    grip.forcerange = [-cfg.grip_force_n, cfg.grip_force_n]
    grip.ctrlrange = [0, cfg.gripper_max_opening_m]
    for jaw in ("jaw_left", "jaw_right"):
        spec.joint(jaw).range = [0, cfg.gripper_max_opening_m / 2]
        spec.joint(jaw).damping = [cfg.jaw_damping_n_s_m, 0, 0]
    wrist = spec.actuator("wrist")
    wrist.gainprm = [cfg.wrist_kp_nm_rad] + [0] * 9
    wrist.biasprm = [0, -cfg.wrist_kp_nm_rad, 0] + [0] * 7
    wrist.forcerange = [-cfg.wrist_torque_nm, cfg.wrist_torque_nm]


def add_canopy_contact(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """With canopy contact the jaws collide with the leaves' proxies (collision bit 8)."""
    if cfg.canopy_contact:
        for jaw in JAWS:
            spec.geom(jaw).conaffinity |= BIT_CANOPY


def home_joints(cfg: SceneConfig) -> dict[str, float]:
    """The jaws fully open, the wrist at 0."""
    return {
        "wrist": 0.0,
        "jaw_left": cfg.gripper_max_opening_m / 2,
        "jaw_right": cfg.gripper_max_opening_m / 2,
    }


def home_ctrl(cfg: SceneConfig) -> list[float]:
    """The servos' commands at power-on (gripper opening, wrist angle)."""
    return [cfg.gripper_max_opening_m, 0.0]
