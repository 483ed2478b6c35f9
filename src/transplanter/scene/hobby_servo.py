"""A hobby servo in MuJoCo (the serial arm's and its gripper's): a position actuator limited
to the stall torque (`forcerange`), `kp` = stall torque at its saturation error, the joint's
damping = stall torque / no-load speed (a servo at full torque turns at its rated speed) and
its armature the gear train's reflected rotor inertia (`machine.servo.ServoClass`;
docs/serial_arm.md)."""

from __future__ import annotations

import mujoco

from transplanter.machine.servo import ServoClass

__all__ = ["apply_servo"]


def apply_servo(
    spec: mujoco.MjSpec, actuator: str, joints: tuple[str, ...], servo: ServoClass, share: float = 1
) -> None:
    """Set one servo's actuator and the joints it drives from its class. ``share``: how many
    times the servo's damping and armature each joint carries (2 for each of two fingers
    driven through a 2:1 gear)."""
    damping = share * servo.stall_torque_nm / servo.speed_rad_s
    for name in joints:
        joint = spec.joint(name)
        joint.damping = [damping, 0.0, 0.0]
        joint.armature = share * servo.armature_kgm2
    act = spec.actuator(actuator)
    kp = servo.position_gain()
    act.gainprm = [kp] + [0] * 9
    act.biasprm = [0, -kp, act.biasprm[2]] + [0] * 7
    act.forcerange = [-servo.stall_torque_nm, servo.stall_torque_nm]
