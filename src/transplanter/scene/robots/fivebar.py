"""The five-bar robot's part of the scene (models/fivebar/): its links, column, stepper drives
and limit switches follow the SceneConfig, its inertials are derived from its geoms, and its
joints and motors have a power-on pose. The parallel jaws hanging under its column are the
effector's (scene/effectors/parallel_jaw.py), though drawn in the same model file.
"""

from __future__ import annotations

import mujoco

from transplanter.scene.config import PASSIVE_DROP, SceneConfig
from transplanter.scene.geometry import bridge_box, column_box

MODEL = "fivebar"
"""The robot's Menagerie folder: models/fivebar/fivebar.xml."""

INERTIAL_BODIES = (
    "platform", "link1", "passive1", "gripper", "jaw_left", "jaw_right", "link2", "passive2",
)  # fmt: skip


def apply(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """Five-bar links, column and palm, stepper drives and limit switches."""
    spec.body("link1").pos = [-cfg.l0_m, 0, 0]
    spec.body("link2").pos = [cfg.l0_m, 0, 0]
    spec.geom("motor1").pos = [-cfg.l0_m, 0, spec.geom("motor1").pos[2]]
    spec.geom("motor2").pos = [cfg.l0_m, 0, spec.geom("motor2").pos[2]]
    for i in (1, 2):
        spec.geom(f"link{i}").fromto = [0, 0, 0, cfg.l1_m, 0, 0]
        spec.geom(f"link{i}").mass = cfg.active_link_mass_kg
        spec.body(f"passive{i}").pos = [cfg.l1_m, 0, -PASSIVE_DROP]
        spec.geom(f"passive{i}").fromto = [0, 0, 0, cfg.l2_m, 0, 0]
        spec.geom(f"passive{i}").mass = cfg.passive_link_mass_kg
        spec.site(f"c{i}").pos = [cfg.l2_m, 0, 0]
    spec.body("gripper").pos = [cfg.l2_m, 0, PASSIVE_DROP]
    spec.geom("platform").mass = cfg.platform_mass_kg
    # Column: arm plane at column_height_m above the grip centre. The palm is the gripper's
    # bridge: its underside bridge_clearance_m above the grip centre.
    spec.body("platform").pos = [0, 0, cfg.column_height_m]
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

    # Stepper drives: position servos on the motor shaft through the gear, torque-limited,
    # with the pull-out curve as joint damping (models/fivebar/README.md).
    arm_gear, screw_gear = cfg.arm_belt_ratio, cfg.screw_gear_rad_m
    screw_torque = cfg.holding_torque_nm * cfg.screw_efficiency
    for joint_name, gear, torque, scale, travel in (
        ("theta1", arm_gear, cfg.holding_torque_nm, cfg.arm_stiffness_scale, cfg.theta1_range_rad),
        ("theta2", arm_gear, cfg.holding_torque_nm, cfg.arm_stiffness_scale, cfg.theta2_range_rad),
        ("z", screw_gear, screw_torque, cfg.z_stiffness_scale, cfg.z_range_m),
    ):
        act = spec.actuator(joint_name)
        kp = scale * torque / cfg.full_step_rad
        act.gear = [gear, 0, 0, 0, 0, 0]
        act.gainprm = [kp] + [0] * 9
        act.biasprm = [0, -kp, cfg.stepper_dampratio] + [0] * 7
        act.forcerange = [-torque, torque]
        joint = spec.joint(joint_name)
        joint.range = list(travel)
        joint.damping = [torque / cfg.pullout_zero_speed_rad_s * gear**2, 0, 0]
        joint.armature = cfg.rotor_inertia_kgm2 * gear**2

    spec.numeric("limit_switch_trip").data = [
        cfg.switch1_theta1_rad,
        cfg.switch2_theta2_rad,
        cfg.switch3_z_m,
        cfg.switch4_z_m,
    ]


def apply_inertials(spec: mujoco.MjSpec) -> None:
    """Explicit inertials of the arm's bodies, computed by MuJoCo from their geoms (masses
    and shapes follow the config), exactly as the compiler would without an <inertial>."""
    probe = spec.copy()
    probe.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
    model = probe.compile()
    for body in INERTIAL_BODIES:
        b, i = spec.body(body), model.body(body).id
        b.mass = model.body_mass[i]
        b.ipos = model.body_ipos[i]
        b.iquat = model.body_iquat[i]
        b.inertia = model.body_inertia[i]
        b.explicitinertial = True


def home_joints(cfg: SceneConfig) -> dict[str, float]:
    """The power-on pose of the robot's joints: the passive angles close the chain."""
    phi1, phi2 = (
        float(a)
        for a in cfg.kinematics().passive_angles(cfg.power_on_theta1_rad, cfg.power_on_theta2_rad)
    )
    return {
        "z": cfg.power_on_z_m,
        "theta1": cfg.power_on_theta1_rad,
        "theta2": cfg.power_on_theta2_rad,
        "phi1": phi1,
        "phi2": phi2,
    }


def home_ctrl(cfg: SceneConfig) -> list[float]:
    """The motors' commands at power-on (theta1, theta2, Z): gear * joint position."""
    return [
        cfg.arm_belt_ratio * cfg.power_on_theta1_rad,
        cfg.arm_belt_ratio * cfg.power_on_theta2_rad,
        cfg.screw_gear_rad_m * cfg.power_on_z_m,
    ]
