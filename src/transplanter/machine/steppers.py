"""Stepper drives: joint position <-> absolute microstep counts, and step counts over time.

Step counters are absolute: steps = round(joint_position * steps_per_unit), the joint position
being an angle (rad) for the belt-driven arm motors and a height (m) for the Z lead screw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StepperDrive:
    """One stepper motor and its transmission to the joint (design defaults: NEMA17, 1/16)."""

    name: str
    steps_per_rev: int = 200
    """Full steps per motor revolution."""
    microsteps: int = 16
    """Driver microstepping: microsteps per full step."""
    ratio: float = 3.0
    """Motor revolutions per joint revolution (GT2 20T:60T belt = 3). Must be 1 for a screw."""
    lead_m: float | None = None
    """Lead screw only: joint metres per motor revolution (T8 screw: 0.008). None = rotary."""
    max_step_rate_hz: float = 20000.0
    """Highest step pulse rate the planner may ask of this motor."""
    holding_torque_nm: float = 0.45
    """Motor holding torque (N*m); the pull-out curve falls from it with speed."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"StepperDrive.name must be a non-empty string, got {self.name!r}")
        for field in ("steps_per_rev", "microsteps"):
            value = getattr(self, field)
            if not (isinstance(value, int | np.integer) and value > 0):
                raise ValueError(
                    f"StepperDrive {self.name!r}: {field} must be a positive integer, got {value!r}"
                )
        for field in ("ratio", "max_step_rate_hz", "holding_torque_nm"):
            value = getattr(self, field)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(
                    f"StepperDrive {self.name!r}: {field} must be a positive number, got {value!r}"
                )
        if self.lead_m is not None:
            if not (
                isinstance(self.lead_m, int | float)
                and math.isfinite(self.lead_m)
                and self.lead_m > 0
            ):
                raise ValueError(
                    f"StepperDrive {self.name!r}: lead_m must be a positive length in m or None, "
                    f"got {self.lead_m!r}"
                )
            if self.ratio != 1.0:
                raise ValueError(
                    f"StepperDrive {self.name!r}: a lead-screw drive takes its whole gearing in "
                    f"lead_m (joint metres per motor revolution); set ratio=1.0, got {self.ratio!r}"
                )

    @property
    def linear(self) -> bool:
        """True for a lead-screw drive (joint in m), False for a rotary joint (rad)."""
        return self.lead_m is not None

    @property
    def microsteps_per_motor_rev(self) -> int:
        return self.steps_per_rev * self.microsteps

    @property
    def steps_per_unit(self) -> float:
        """Microsteps per joint rad (rotary) or per joint m (lead screw)."""
        if self.lead_m is not None:
            return self.microsteps_per_motor_rev / self.lead_m
        return self.microsteps_per_motor_rev * self.ratio / (2.0 * math.pi)

    @property
    def unit_per_step(self) -> float:
        """Joint rad (or m) per microstep."""
        return 1.0 / self.steps_per_unit

    def to_steps(self, position) -> np.ndarray:
        """Absolute step count(s) nearest to joint position(s), as int64."""
        position = np.asarray(position, dtype=np.float64)
        if not np.isfinite(position).all():
            raise ValueError(f"StepperDrive {self.name!r}: joint positions must be finite")
        steps = np.rint(position * self.steps_per_unit)
        if np.abs(steps).max(initial=0.0) >= 2.0**62:
            raise ValueError(
                f"StepperDrive {self.name!r}: joint position too large for int64 steps"
            )
        return steps.astype(np.int64)

    def to_position(self, steps) -> np.ndarray:
        """Joint position(s) (rad or m) of absolute step count(s)."""
        steps = np.asarray(steps)
        if not np.issubdtype(steps.dtype, np.integer):
            raise ValueError(
                f"StepperDrive {self.name!r}: step counts must be integers, got {steps.dtype}"
            )
        return steps.astype(np.float64) * self.unit_per_step

    def motor_angle(self, position) -> np.ndarray:
        """Motor shaft angle (rad) at joint position(s)."""
        position = np.asarray(position, dtype=np.float64)
        if self.lead_m is not None:
            return position / self.lead_m * (2.0 * math.pi)
        return position * self.ratio


def arm_drive(name: str, **overrides) -> StepperDrive:
    """NEMA17, 1/16 microstep, GT2 20T:60T belt: 9600 microsteps per arm revolution."""
    return StepperDrive(name=name, **overrides)


def z_drive(name: str = "z", **overrides) -> StepperDrive:
    """NEMA17, 1/16 microstep, direct T8 lead screw with 8 mm lead: 400 microsteps per mm."""
    params = dict(ratio=1.0, lead_m=0.008)
    params.update(overrides)
    return StepperDrive(name=name, **params)


def default_drives() -> tuple[StepperDrive, StepperDrive, StepperDrive]:
    """(arm 1, arm 2, Z) drives with the design defaults."""
    return arm_drive("arm1"), arm_drive("arm2"), z_drive("z")


def steps_at(times, step_times, step_dirs, start_steps: int) -> np.ndarray:
    """Step count reached at each query time (a step counts once t >= its event time).

    step_times must be sorted; step_dirs holds +1/-1 per event. Times before the first event
    give start_steps, times after the last give the final count.
    """
    step_times = np.asarray(step_times, dtype=np.float64)
    step_dirs = np.asarray(step_dirs)
    if step_times.ndim != 1 or step_dirs.shape != step_times.shape:
        raise ValueError(
            f"step_times and step_dirs must be 1-D of equal length, got {step_times.shape} "
            f"and {step_dirs.shape}"
        )
    if step_times.size > 1 and np.any(np.diff(step_times) < 0):
        raise ValueError("step_times must be sorted in time")
    if step_dirs.size and not np.all(np.abs(step_dirs) == 1):
        raise ValueError("step_dirs must hold only +1 and -1")
    return count_at(times, step_times, step_counts(step_dirs, start_steps))


def step_counts(step_dirs, start_steps: int) -> np.ndarray:
    """Counter before and after each event: ``counts[k] = start_steps + sum(step_dirs[:k])``,
    int64 of length ``len(step_dirs) + 1`` (the table ``count_at`` looks up)."""
    step_dirs = np.asarray(step_dirs)
    counts = np.empty(step_dirs.size + 1, dtype=np.int64)
    counts[0] = 0
    np.cumsum(step_dirs, dtype=np.int64, out=counts[1:])
    counts += np.int64(start_steps)
    return counts


def count_at(times, step_times, counts: np.ndarray) -> np.ndarray:
    """Step count at each time from ``step_counts``' table: one binary search per query, a
    step counting once t >= its time (unchecked: ``steps_at`` validates the events)."""
    index = np.searchsorted(step_times, np.asarray(times, dtype=np.float64), side="right")
    return counts[index]
