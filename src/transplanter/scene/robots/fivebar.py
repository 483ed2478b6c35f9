"""The five-bar robot's part of the scene (models/fivebar/): its links, column, stepper drives
and limit switches follow the SceneConfig, its inertials are derived from its geoms, and its
joints and motors have a power-on pose. Its effector attaches at the frame `tool_mount` (MOUNT)
at passive link 1's tip: the parallel jaws of models/effectors/parallel_jaw/
(scene/effectors/parallel_jaw.py), whose column runs down to the grip centre.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from transplanter.machine.kinematics.fivebar import FiveBarMasses
from transplanter.scene.config import PASSIVE_DROP, SceneConfig
from transplanter.scene.stepper import drive_joint

MODEL = "fivebar"
"""The robot's Menagerie folder: models/fivebar/fivebar.xml."""

MOUNT = "tool_mount"
"""The frame at passive link 1's tip (the end effector C) where an effector attaches."""
ACTUATORS = ("theta1", "theta2", "z")
"""The robot's drives (the kinds' interface: first in the model, the effector's next)."""
MOTORS = ACTUATORS
"""The stepper-driven joints, each driven by the actuator of the same name (motor order)."""
ROOT = "platform"
"""The robot's moving root body (what the twin counts as the machine in a contact)."""
SWITCH_MOTORS = (0, 1, 2, 2)
"""The motor whose joint each of limit switches 1-4 watches: theta1, theta2, Z up, Z down."""

# Hard stops of the joints sit this far beyond the motor windows the firmware enforces (rad),
# and the Z slide's top stop this far above switch 3 (m).
HARD_STOP_BEYOND_WINDOW_RAD = math.radians(5.0)
Z_STOP_ABOVE_SWITCH_M = 0.005

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
    spec.frame(MOUNT).pos = [cfg.l2_m, 0, PASSIVE_DROP]  # the effector's mount at C
    spec.geom("platform").mass = cfg.platform_mass_kg
    # the arm plane at column_height_m above the grip centre (the effector's column below C)
    spec.body("platform").pos = [0, 0, cfg.column_height_m]

    # Stepper drives (scene.stepper.drive_joint): the rotor through the arms' belt and the Z
    # screw. The lead screw's friction is the Z slide's (apply_inertials, which knows the
    # weight it carries).
    arm_gear, screw_gear = cfg.arm_belt_ratio, cfg.screw_gear_rad_m
    for (joint_name, gear, travel), params in zip(
        (
            ("theta1", arm_gear, cfg.theta1_range_rad),
            ("theta2", arm_gear, cfg.theta2_range_rad),
            ("z", screw_gear, cfg.z_range_m),
        ),
        cfg.stepper_params(),
        strict=True,
    ):
        drive_joint(spec, joint_name, gear, travel, params, cfg.rotor_inertia_kgm2)

    spec.numeric("limit_switch_trip").data = [
        cfg.switch1_theta1_rad,
        cfg.switch2_theta2_rad,
        cfg.switch3_z_m,
        cfg.switch4_z_m,
    ]


def apply_inertials(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """Explicit inertials of the arm's bodies, computed by MuJoCo from their geoms (masses
    and shapes follow the config), exactly as the compiler would without an <inertial>; and
    the lead screw's friction on the Z slide, from the weight it carries."""
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
    weight = model.body_subtreemass[model.body("platform").id] * -model.opt.gravity[2]
    spec.joint("z").frictionloss = screw_friction_n(weight, cfg.screw_efficiency)


def screw_friction_n(weight_n: float, efficiency: float) -> float:
    """The lead screw's friction (N at the slide) lifting weight_n: a screw of efficiency e
    needs weight * lead / (2 pi e) of torque, weight * lead / 2 pi of it the lift's own, the
    rest friction (Coulomb; the same lowering, as the nut's load is the same weight)."""
    return weight_n * (1.0 / efficiency - 1.0)


def scene_fields(s, machine) -> dict:
    """The SceneConfig fields of a scenario's five-bar ([arm], [limits], [drives]' belt and
    switches) and its power-on pose (the SGF's: `machine.config.power_on_joints`)."""
    from transplanter.machine.config import power_on_joints

    arm, drv, lim = s.arm, s.drives, s.limits
    theta1_on, theta2_on, z_on = power_on_joints(machine.sgf)
    stop = HARD_STOP_BEYOND_WINDOW_RAD
    return dict(
        l0_m=arm.l0_m,
        l1_m=arm.l1_m,
        l2_m=arm.l2_m,
        arm_belt_ratio=drv.arm_belt_ratio,
        switch1_theta1_rad=drv.switch1_theta1_rad,
        switch2_theta2_rad=drv.switch2_theta2_rad,
        switch3_z_m=drv.switch3_z_m,
        switch4_z_m=lim.z_min_m,
        theta1_range_rad=(lim.motor1_min_rad - stop, lim.motor1_max_rad + stop),
        theta2_range_rad=(lim.motor2_min_rad - stop, lim.motor2_max_rad + stop),
        z_range_m=(0.0, max(lim.z_max_m, drv.switch3_z_m) + Z_STOP_ABOVE_SWITCH_M),
        power_on_theta1_rad=theta1_on,
        power_on_theta2_rad=theta2_on,
        power_on_z_m=z_on,
    )


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


def power_on(cfg: SceneConfig) -> list[float]:
    """The motors' joints at power-on (theta1, theta2 in rad, Z in m), in motor order."""
    return [cfg.power_on_theta1_rad, cfg.power_on_theta2_rad, cfg.power_on_z_m]


def home_ctrl(cfg: SceneConfig) -> list[float]:
    """The motors' commands at power-on (theta1, theta2, Z): no torque until the twin's drives
    compute it from the load angle (transplanter.scene.stepper)."""
    return [0.0, 0.0, 0.0]


def _inertia_about_axis(model: mujoco.MjModel, body: str, axis) -> float:
    """A body's moment of inertia (kg m^2) about the axis through its frame's origin along
    ``axis`` (its frame): the principal inertia turned by ``body_iquat``, plus m d^2 of its
    centre of mass off that axis."""
    b = model.body(body)
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, b.iquat)
    rot = rot.reshape(3, 3)
    a = np.asarray(axis, dtype=np.float64)
    inertia = rot @ np.diag(b.inertia) @ rot.T
    com = np.asarray(b.ipos, dtype=np.float64)
    off = com - a * (com @ a)
    return float(a @ inertia @ a + b.mass[0] * (off @ off))


def arm_masses(model: mujoco.MjModel, carried_kg: float) -> FiveBarMasses:
    """The lumped dynamics' inertia of the compiled robot model (``build.robot_model``): the
    rotor (theta1's armature over its actuator's gear squared), the active link about its
    joint, a passive link's mass, and at C the gripper's subtree (wrist, palm, jaws) plus
    ``carried_kg`` (the load in the jaws: the heaviest pot and its shoot). Arm 2's links
    must be arm 1's (the model is symmetric; ValueError otherwise)."""
    axis = np.asarray(model.jnt_axis[model.joint("theta1").id], dtype=np.float64)
    values = {}
    for i in (1, 2):
        joint = model.joint(f"theta{i}")
        gear = float(model.actuator(f"theta{i}").gear[0])
        values[i] = (
            float(model.dof_armature[joint.dofadr[0]]) / (gear * gear),
            _inertia_about_axis(model, f"link{i}", axis),
            float(model.body(f"passive{i}").mass[0]),
        )
    if not np.allclose(values[1], values[2], rtol=1e-12, atol=0.0):
        raise ValueError(f"the five-bar's arms differ in the model: {values[1]} != {values[2]}")
    rotor, active, passive = values[1]
    gripper = float(model.body_subtreemass[model.body("gripper").id])
    return FiveBarMasses(
        rotor_inertia_kgm2=rotor,
        active_link_kgm2=active,
        passive_link_kg=passive,
        end_effector_kg=gripper + float(carried_kg),
    )
