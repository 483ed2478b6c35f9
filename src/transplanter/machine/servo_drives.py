"""The serial arm's servo outputs (seed 004: Dewi, Nurmaini, Risma, Oktarina and Roriz,
*Inverse kinematic analysis of 4 DOF pick and place arm robot manipulator using fuzzy logic
controller*), pure numpy: the controller's side of four hobby servos.

The motion controller is the project's SGF with `Serial4Kinematics`: it interpolates every
G-code line, solves the arm's IK per point and counts each joint in microseconds of its
servo's pulse width (`kinematics.serial4`). A servo board has no step outputs: its timer
sends one pulse per channel every 20 ms frame (50 Hz), the width of the latest position the
interpolator reached at the frame's start (sample and hold, as `servo.pulse_frames`).
`ServoOutputs.frame` is that timer: the SGF's raw counts at a frame's start in, the four
channels' pulse widths (whole microseconds) out; the gripper's channel carries the angle of
the last `M280 P0 S<deg>`.

`ServoBank` is the servos' side: one `servo.HobbyServo` per channel (rated speed slowed by
load, dead band, gear backlash, stall), each reading its channel's pulse once per frame and
stepping with the physics; its output is the joint angle its link sits at, which the MuJoCo
model's torque-limited position actuator tracks (docs/serial_arm.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from transplanter.machine.servo import FRAME_S, HobbyServo, ServoClass, ServoMount

__all__ = ["GRIPPER_CHANNEL", "ServoBank", "ServoOutputs", "frame_steps"]

GRIPPER_CHANNEL = 0
"""`M280 P0 S<deg>`: the gripper servo's angle theta4 (0 closed, 60 deg fully open)."""


def frame_steps(dt: float) -> int:
    """Physics steps per 20 ms PWM frame; ValueError unless ``dt`` divides the frame."""
    n = round(FRAME_S / dt)
    if n < 1 or not math.isclose(n * dt, FRAME_S, rel_tol=1e-9):
        raise ValueError(
            f"physics.timestep_ms must divide the servos' {FRAME_S * 1e3:g} ms PWM frame "
            f"(1, 0.5, 0.25 ... ms), got {dt * 1e3:g} ms"
        )
    return n


class ServoOutputs:
    """The servo board's PWM timer: the arm's three channels from the SGF's raw counts
    (``q0`` the joint angles at raw count 0, ``rad_per_count`` each axis's count), the
    gripper's from its last M280 angle."""

    def __init__(
        self,
        mounts: Sequence[ServoMount],
        gripper: ServoMount,
        q0,
        rad_per_count,
        gripper_deg: float,
    ) -> None:
        self.mounts = tuple(mounts)
        self.gripper = gripper
        self.q0 = np.asarray(q0, dtype=np.float64)
        self.rad_per_count = np.asarray(rad_per_count, dtype=np.float64)
        self.gripper_rad = math.radians(gripper_deg)

    def set_gripper(self, angle_deg: float) -> None:
        """An ``M280 P0 S<deg>`` reached the board (clamped to the servo's travel)."""
        travel = self.gripper.servo.travel_rad
        self.gripper_rad = min(max(math.radians(float(angle_deg)), 0.0), travel)

    def joints(self, raw_counts) -> np.ndarray:
        """The joint angles (rad) the interpolator has reached at these raw counts."""
        return self.q0 + np.asarray(raw_counts, dtype=np.float64) * self.rad_per_count

    def frame(self, raw_counts) -> np.ndarray:
        """The four channels' pulse widths (whole us, int64): base, shoulder, elbow, gripper."""
        q = self.joints(raw_counts)
        arm = [int(m.pulse_us(q[i])) for i, m in enumerate(self.mounts)]
        return np.array([*arm, int(self.gripper.pulse_us(self.gripper_rad))], dtype=np.int64)


class ServoBank:
    """The four hobby servos: each reads its pulse once per frame and steps with the physics
    (``HobbyServo``), its link angle mapped to the joint through its mount."""

    def __init__(self, mounts: Sequence[ServoMount], joints0) -> None:
        self.mounts = tuple(mounts)
        q0 = np.asarray(joints0, dtype=np.float64)
        self.servos = [HobbyServo(m.servo, float(m.horn(q0[i]))) for i, m in enumerate(mounts)]
        # each mount's joint = zero + direction x horn, in floats (`ServoMount.joint`)
        self._maps = [(s, float(m.direction), float(m.zero_rad))
                      for s, m in zip(self.servos, self.mounts, strict=True)]  # fmt: skip

    @property
    def classes(self) -> tuple[ServoClass, ...]:
        return tuple(m.servo for m in self.mounts)

    def command(self, pulses_us) -> None:
        for servo, width in zip(self.servos, pulses_us, strict=True):
            servo.command(float(width) * 1e-6)

    def step(self, dt: float, joint_loads_nm) -> np.ndarray:
        """Advance ``dt`` under the loads on each joint (N m, positive pushing the joint
        angle up); the joint angles the links sit at."""
        loads = [float(v) for v in joint_loads_nm]
        return np.array([
            zero + direction * servo.step(dt, direction * load)
            for (servo, direction, zero), load in zip(self._maps, loads, strict=True)
        ])  # fmt: skip

    def shafts(self) -> np.ndarray:
        """The joint angles the servos' potentiometers read (the shafts, without the play)."""
        return np.array(
            [float(m.joint(s.shaft_rad)) for s, m in zip(self.servos, self.mounts, strict=True)]
        )
