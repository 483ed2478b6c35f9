"""The delta's controller and servo drives, pure numpy (the firmware side).

- :class:`DeltaController`: the SGF running :class:`DeltaKinematics` (every interpolated point
  through its IK and joint window, error 33 naming the arm and its limit), with the check a
  servo machine's motion controller makes before it accepts a move: the planned move's joint
  speeds, accelerations and the torques of the delta's inverse dynamics (Eq. 9) against
  V_max, A_max and tau_max (Sec. 2.4 of Zhao et al. 2022). A move that asks too much is
  refused with ``error:33`` naming the arm, the quantity and the limit before any pulse.
- :class:`PulseServos`: the three position servo drives (Panasonic MINAS A6 class) read
  the pulse counts the controller emits and turn them into a joint position command
  (2000 pulses per motor revolution through the reducer); each drive watches its following
  error (command - encoder) and raises its alarm (the A6's Err 24.0, position deviation
  excess) when it exceeds the limit: the drives stop and the alarm is latched.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from transplanter.errors import ErrorCode
from transplanter.machine.gcode import GcodeError, parse_line
from transplanter.machine.kinematics.delta import DeltaKinematics
from transplanter.machine.motion import PlannedMove, plan_line
from transplanter.machine.sgf import SGF, SGFConfig
from transplanter.units import M_PER_MM, MM_PER_MIN_TO_M_S

__all__ = ["DeltaController", "DriveAlarm", "PulseServos", "joint_limits_refusal"]

PROFILE_DT_S = 0.005
"""Time grid on which a planned move's joint profile is differentiated for the check."""


def joint_limits_refusal(kin: DeltaKinematics, move: PlannedMove) -> str | None:
    """Why a planned move exceeds the joints' V_max, A_max or tau_max (the first arm and
    quantity over its limit, with the value), or None. The joint positions of the move's
    points are resampled every PROFILE_DT_S and differentiated; the torques are the delta's
    inverse dynamics along that profile."""
    times = np.asarray(move.point_times_s, dtype=np.float64)
    q = np.asarray(move.joint_positions, dtype=np.float64)
    if times.size < 2 or move.duration_s <= 0:
        return None
    grid = np.arange(0.0, move.duration_s + PROFILE_DT_S, PROFILE_DT_S)
    grid[-1] = min(grid[-1], move.duration_s)
    qs = np.stack([np.interp(grid, times, q[:, i]) for i in range(q.shape[1])], axis=1)
    if grid.size < 3:
        return None
    speed = np.gradient(qs, grid, axis=0)
    accel = np.gradient(speed, grid, axis=0)
    torque = kin.inverse_dynamics(qs, speed, accel)
    checks = (
        ("speed", np.abs(speed), kin.max_joint_speed_rad_s, "deg/s", math.degrees(1.0), "V_max"),
        ("acceleration", np.abs(accel), kin.max_joint_accel_rad_s2, "deg/s^2",
         math.degrees(1.0), "A_max"),
        ("torque", np.abs(torque), kin.joint_torque_limit_nm, "N m", 1.0, "tau_max"),
    )  # fmt: skip
    for name, values, limit, unit, scale, label in checks:
        peak = values.max(axis=0)
        over = np.flatnonzero(peak > limit)
        if over.size:
            i = int(over[0])
            return (
                f"arm {i + 1} joint {name} q{i + 1} {peak[i] * scale:.1f} {unit} > "
                f"{label} {limit * scale:.1f} {unit}"
            )
    return None


class DeltaController:
    """The delta's motion controller: an SGF with the pre-move joint check (module
    docstring). Same interface as the SGF for a host on a bus: ``receive(line, now)``,
    ``poll(now, endstops)``, ``pulses_at``, ``drain_servo_commands``."""

    def __init__(self, config: SGFConfig) -> None:
        if not isinstance(config.kinematics, DeltaKinematics):
            raise ValueError("DeltaController drives a DeltaKinematics")
        self.sgf = SGF(config)
        self.kin: DeltaKinematics = config.kinematics
        self._replies: list[str] = []
        self._speed_m_s = config.default_speed_m_s
        self._target: np.ndarray | None = None
        self.refused: list[str] = []

    def receive(self, line: str, now: float) -> None:
        refusal = self._check(line)
        if refusal is None:
            self.sgf.receive(line, now)
        else:
            self.refused.append(refusal)
            self._replies.append(ErrorCode.INVALID_TARGET.reply(refusal))

    def _check(self, line: str) -> str | None:
        try:
            parsed = parse_line(line)
        except GcodeError:
            return None  # the SGF answers it
        if parsed is None or parsed.command not in ("G0", "G1") or not self.sgf.homed:
            if parsed is not None and parsed.command == "G28":
                self._target = None
            return None
        words = parsed.words
        start = self._target if self._target is not None else self.sgf.position_xyz
        target = np.array(start, dtype=np.float64)
        for axis, letter in enumerate(self.kin.coordinates):
            if letter in words:
                target[axis] = words[letter] * M_PER_MM
        if parsed.command == "G0" and self.sgf.spline_transfer(start, target):
            # a spline transfer: planned under these same limits (and the end effector's)
            # when it starts; the SGF refuses it then if no timing meets them
            self._target = target
            return None
        speed = self._speed_m_s
        if "S" in words:
            speed = words["S"] * M_PER_MM
        elif "F" in words:
            speed = words["F"] * MM_PER_MIN_TO_M_S
        try:
            move = plan_line(
                self.sgf.config.kinematics.steps_of_point(start),
                start,
                target,
                speed,
                self.kin,
                self.sgf.config.motion,
            )
        except ValueError:
            return None  # the SGF refuses it with its own reason
        refusal = joint_limits_refusal(self.kin, move)
        if refusal is None:
            self._speed_m_s, self._target = speed, target
            return None
        return f"move refused before it starts: {refusal}"

    def poll(self, now: float, endstops=None) -> list[str]:
        out, self._replies = self._replies, []
        return out + self.sgf.poll(now, endstops)

    def pulses_at(self, times) -> np.ndarray:
        return self.sgf.pulses_at(times)

    def next_event_time(self) -> float | None:
        """When the SGF next finishes or starts a line (`SGF.next_event_time`): a refusal
        of its own is answered at once, at the exchange that received the line."""
        return self.sgf.next_event_time()

    @property
    def homing(self) -> bool:
        return self.sgf.homing

    @property
    def motion_version(self) -> int | None:
        return self.sgf.motion_version

    def drain_servo_commands(self) -> list[tuple[float, int, float]]:
        return self.sgf.drain_servo_commands()


@dataclass(frozen=True)
class DriveAlarm:
    """A drive's alarm: when, which arm, the following error and its limit (rad)."""

    time_s: float
    arm: int
    error_rad: float
    limit_rad: float

    def text(self) -> str:
        return (
            f"Err24.0 position deviation excess on arm {self.arm}: following error "
            f"{math.degrees(self.error_rad):.3f} deg > {math.degrees(self.limit_rad):.3f} deg "
            f"at {self.time_s:.3f} s"
        )


class PulseServos:
    """Three pulse-train position servo drives (module docstring). ``q0``: the joint angles
    at power-on (raw pulse count 0); ``limit_rad``: the following-error alarm level at the
    joint."""

    def __init__(self, kin: DeltaKinematics, q0, limit_rad: float) -> None:
        self.q0 = np.asarray(q0, dtype=np.float64)
        self.rad_per_pulse = np.array([d.unit_per_step for d in kin.drives])
        self.limit_rad = float(limit_rad)
        self.alarm: DriveAlarm | None = None
        self.peak_error_rad = np.zeros(3)

    def command(self, raw_pulses) -> np.ndarray:
        """The joint position command (rad) of the pulses received."""
        return self.q0 + np.asarray(raw_pulses, dtype=np.float64) * self.rad_per_pulse

    def watch(self, t: float, command, measured) -> DriveAlarm | None:
        """Compare command and encoder; latch and return the first alarm."""
        err = np.abs(np.asarray(command) - np.asarray(measured))
        self.peak_error_rad = np.maximum(self.peak_error_rad, err)
        if self.alarm is None and (err > self.limit_rad).any():
            arm = int(np.argmax(err))
            self.alarm = DriveAlarm(t, arm + 1, float(err[arm]), self.limit_rad)
        return self.alarm
