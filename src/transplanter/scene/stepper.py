"""Hybrid stepper motors as their physics has them: torque against load angle.

A two-phase hybrid stepper with N_r rotor teeth (N_r = steps_per_rev / 4: 50 for a 1.8 deg
motor) pulls its rotor towards the stator field with a torque that is about sinusoidal in
the load angle, the rotor's lag behind the field (Acarnley, *Stepping Motors: a guide to
theory and practice*, 4th ed., IET 2002, ch. 2; Kenjo & Sugawara, *Stepping Motors and
their Microprocessor Controls*, 2nd ed., Oxford 1994):

    T = A(n) sin(N_r (theta_field - theta_rotor))
        - T_detent sin(4 N_r (theta_rotor - theta_0))
        + c (omega_field - omega_rotor)

- one electrical cycle is 4 full steps; the torque peaks, at A, one full step behind the
  field and falls to zero two full steps behind it, where the rotor's equilibrium turns
  unstable: a rotor pushed further slips to the next stable position, four full steps on,
  and those steps are lost (the firmware never learns of it);
- A(n) is the pull-out torque at the field's speed n (rev/s): the holding torque up to the
  corner speed, where the winding's inductance stops the driver's current reaching its
  rated value within a step, and falling as 1/n above it (constant power);
- the detent torque, with one cycle per full step, is the permanent magnet's pull on the
  stator teeth, with or without current (its zero at the power-on position, where the motor
  was energised on a full step);
- c damps the rotor's motion relative to the field (eddy currents and the driver's current
  loop act on that relative motion), never its motion over the ground.

The field is where the driver's microstep counter has put it: the step pulses the firmware
has sent by the start of each physics step (`transplanter.twin.sim`). The force acts over
that step from the state at its start, so the command and the torque are consistent in time
whatever the step. The damping term is MuJoCo's (the actuator's velocity bias, integrated
implicitly by ``implicitfast``); the rest is written to the actuator's ``ctrl`` (N m at the
motor shaft, through the actuator's gear) before every step by :meth:`StepperDrives.apply`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

__all__ = ["StepperDrives", "StepperParams"]


@dataclass(frozen=True)
class StepperParams:
    """One stepper motor: holding torque (N m), detent torque (N m), full steps per rev, the
    pull-out curve's corner speed (rev/s) and the rotor-on-field damping (N m s/rad)."""

    holding_torque_nm: float
    detent_torque_nm: float
    steps_per_rev: int
    corner_rev_s: float
    damping_nms_rad: float

    @property
    def electrical_per_rad(self) -> float:
        """Electrical radians per motor radian: the rotor's teeth, steps_per_rev / 4."""
        return self.steps_per_rev / 4.0

    @property
    def stiffness_nm_rad(self) -> float:
        """Small-signal stiffness at the motor shaft (N m/rad): the torque curve's slope at
        zero load angle."""
        return self.holding_torque_nm * self.electrical_per_rad

    def pullout_nm(self, speed_rad_s) -> np.ndarray:
        """The torque curve's peak at a field speed (motor rad/s): holding torque up to the
        corner speed, falling as corner / speed above it."""
        rev_s = np.abs(np.asarray(speed_rad_s, dtype=float)) / (2.0 * math.pi)
        return self.holding_torque_nm * np.minimum(
            1.0, self.corner_rev_s / np.maximum(rev_s, 1e-300)
        )

    def torque_nm(self, load_angle_rad, speed_rad_s=0.0, rotor_rad=0.0) -> np.ndarray:
        """The motor's torque (N m) with the rotor load_angle_rad (motor rad) behind its field
        moving at speed_rad_s, the rotor at rotor_rad from its power-on position, both at
        the same speed (no damping torque)."""
        n_r = self.electrical_per_rad
        load = np.asarray(load_angle_rad, dtype=float)
        return self.pullout_nm(speed_rad_s) * np.sin(n_r * load) - self.detent_torque_nm * np.sin(
            4.0 * n_r * np.asarray(rotor_rad, dtype=float)
        )


class StepperDrives:
    """The motors of a robot in a MuJoCo model: each a general actuator on its joint through
    a gear (ctrl = torque at the motor shaft, N m; its velocity bias -c the damping), driven
    by :meth:`apply` before every physics step."""

    def __init__(
        self,
        params: list[StepperParams],
        actuators,
        qpos_adr,
        gears,
        q_power_on,
    ) -> None:
        self.params = list(params)
        self.actuators = np.asarray(actuators, dtype=int)
        self.gears = np.asarray(gears, dtype=float)
        self.qpos_adr = np.asarray(qpos_adr, dtype=int)
        # motor-shaft angle at power-on: the detent's zero
        self.rotor0 = np.asarray(q_power_on, dtype=float) * self.gears
        self.n_r = np.array([p.electrical_per_rad for p in self.params])
        self.damping = np.array([p.damping_nms_rad for p in self.params])
        self.detent = np.array([p.detent_torque_nm for p in self.params])
        # per motor, as Python numbers for the per-step path
        self._terms = [
            (int(a), float(g), int(q), float(n), float(det), float(n * r0 * 4.0))
            for a, g, q, n, det, r0 in zip(
                self.actuators, self.gears, self.qpos_adr, self.n_r, self.detent, self.rotor0,
                strict=True,
            )
        ]  # fmt: skip

    def pullout_nm(self, field_speed_rad_s: np.ndarray) -> np.ndarray:
        """(n, motors) pull-out torques at (n, motors) field speeds (motor rad/s)."""
        speed = np.atleast_2d(field_speed_rad_s)
        return np.stack(
            [p.pullout_nm(speed[:, j]) for j, p in enumerate(self.params)], axis=1
        ).reshape(np.shape(field_speed_rad_s))

    def apply(self, ctrl, qpos, field_rad, amplitude_nm, feed_nm) -> None:
        """Write each motor's torque (N m at its shaft) for the step about to be taken:
        field_rad the field's motor angles (rad), amplitude_nm the pull-out torques and
        feed_nm the damping's field-speed term c * omega_field (sequences of motors)."""
        for (act, gear, adr, n_r, det, phase0), f, a, ff in zip(
            self._terms, field_rad, amplitude_nm, feed_nm, strict=True
        ):
            rotor = gear * qpos[adr]
            torque = a * math.sin(n_r * (f - rotor)) + ff
            if det:
                torque -= det * math.sin(4.0 * n_r * rotor - phase0)
            ctrl[act] = torque

    def hold(self, data, joint_positions, joint_speeds=None) -> None:
        """Drive the motors towards joint positions (rad, rad, m) moving at joint speeds (per
        s; default at rest), full pull-out torque at that speed: one step's command."""
        field = self.gears * np.asarray(joint_positions, dtype=float)
        speed = (
            np.zeros_like(field)
            if joint_speeds is None
            else self.gears * np.asarray(joint_speeds, dtype=float)
        )
        self.apply(data.ctrl, data.qpos, field, self.pullout_nm(speed), self.damping * speed)


def drive_joint(
    spec: mujoco.MjSpec,
    name: str,
    gear: float,
    travel: tuple[float, float],
    motor: StepperParams,
    rotor_inertia_kgm2: float,
) -> None:
    """A stepper on joint `name` through its transmission (`gear`: motor rad per joint unit):
    the general actuator of the same name, whose ctrl is the torque at the motor shaft (N m)
    the twin computes from the load angle before every step (`StepperDrives`), whose velocity
    bias is the rotor's damping against its field (the field-speed half rides in ctrl); no
    force limit (the torque law itself peaks at the pull-out torque); the joint's `travel`
    (its hard stops), no joint damping, the rotor's inertia as its armature."""
    act = spec.actuator(name)
    act.gear = [gear, 0, 0, 0, 0, 0]
    act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    act.gainprm = [1.0] + [0] * 9
    act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    act.biasprm = [0, 0, -motor.damping_nms_rad] + [0] * 7
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
    joint = spec.joint(name)
    joint.range = list(travel)
    joint.damping = [0.0, 0, 0]
    joint.armature = rotor_inertia_kgm2 * gear**2
