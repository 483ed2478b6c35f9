"""A Cartesian gantry of linear modules: belt-driven X and Y axes and a lead-screw Z, each a
stepper (`[robot] kind = "gantry"`, scenario section ``[gantry]``; docs/gantry.md).

The IK is the identity: each axis's joint is its coordinate, in metres (RepRapFirmware's
``CartesianKinematics``, Klipper's ``cartesian.py``). The machine frame is the workcell's
frame (the grip centre's x, y and its height z), as the five-bar's is, so that a job's taught
points are the same numbers for either robot; a real gantry's G-code origin sits at its
switches, a fixed offset of this frame (G92). What the axes cannot do is a refusal with its
numbers: a coordinate outside its axis's travel (`check`, `limit_target`).

X and Y move on toothed belts (GT2, a 20-tooth pulley: 40 mm a motor revolution), Z on a lead
screw; a belt axis is a linear drive whose "lead" is the belt's travel per motor revolution,
so the step counts, the step rates and the stepper torque law of the scene are the five-bar's
Z slide's. Homing: Z up first (grbl's HOMING_CYCLE_0: jaws among the pots rise clear), then X
and Y together, each to its switch at the low end of its travel; switch 4 stops Z going down
(a hard limit), as on the five-bar.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from transplanter.errors import Refusal, RefusalReason
from transplanter.machine.axes import Axis
from transplanter.machine.homing import HomingConfig
from transplanter.machine.kinematics.base import Kinematics, ReachReport, as_points
from transplanter.machine.steppers import StepperDrive
from transplanter.units import M_PER_MM

__all__ = ["GantryKinematics", "HOMING_DIRS"]

HOMING_DIRS = (-1, -1, +1)
"""The direction each axis seeks its switch: X and Y to the low end of their travel, Z up."""


def _drive(name: str, lead_m: float, common: dict) -> StepperDrive:
    return StepperDrive(name, ratio=1.0, lead_m=lead_m, **common)


@dataclass(frozen=True)
class GantryKinematics(Kinematics):
    """X, Y and Z slides; the joints are the grip centre's coordinates (m)."""

    kind = "gantry"
    x_window_m: tuple[float, float] = (-0.150, 0.150)
    y_window_m: tuple[float, float] = (0.040, 0.300)
    z_window_m: tuple[float, float] = (0.005, 0.160)
    drives_xyz: tuple[StepperDrive, StepperDrive, StepperDrive] = (
        StepperDrive("x", ratio=1.0, lead_m=0.040, microsteps=8),
        StepperDrive("y", ratio=1.0, lead_m=0.040, microsteps=8),
        StepperDrive("z", ratio=1.0, lead_m=0.008),
    )

    def __post_init__(self) -> None:
        for name, (lo, hi) in zip("xyz", self.windows, strict=True):
            if not lo < hi:
                raise ValueError(
                    f"the gantry's {name} travel must have min < max, got "
                    f"[{lo / M_PER_MM:g}, {hi / M_PER_MM:g}] mm"
                )
        for drive in self.drives_xyz:
            if not drive.linear:
                raise ValueError(f"the gantry's {drive.name} drive must be linear (lead_m set)")

    @property
    def windows(self) -> tuple[tuple[float, float], ...]:
        """(min, max) of x, y and z (m): each axis's travel."""
        return (self.x_window_m, self.y_window_m, self.z_window_m)

    @property
    def axes(self) -> tuple[Axis, ...]:
        out = []
        for name, drive, (lo, hi), d in zip(
            "xyz", self.drives_xyz, self.windows, HOMING_DIRS, strict=True
        ):
            home = hi if d > 0 else lo
            out.append(Axis(name, drive, home, (lo, hi), switch_name=f"{name.upper()} home"))
        return tuple(out)

    # -- the kind's maths ------------------------------------------------------------------
    def joints(self, xyz) -> np.ndarray:
        return np.array(xyz, dtype=np.float64)

    def point(self, joints) -> np.ndarray:
        return np.array(joints, dtype=np.float64)

    def _refusals(self, p: np.ndarray) -> tuple[Refusal, ...]:
        out = []
        for name, value, (lo, hi) in zip("xyz", p, self.windows, strict=True):
            if not lo <= value <= hi:  # NaN too
                out.append(
                    Refusal(
                        RefusalReason.JOINT_LIMIT, f"{name} axis", value / M_PER_MM,
                        lo / M_PER_MM, hi / M_PER_MM, "mm",
                    )
                )  # fmt: skip
        return tuple(out)

    def check(self, xyz) -> ReachReport:
        pts = as_points(xyz)
        lo = np.array([w[0] for w in self.windows])
        hi = np.array([w[1] for w in self.windows])
        ok = ((pts >= lo) & (pts <= hi)).all(axis=1)
        refusals = tuple(() if good else self._refusals(p) for p, good in zip(pts, ok, strict=True))
        joints = np.where(ok[:, None], pts, np.nan)
        return ReachReport(joints=joints, ok=ok, refusals=refusals)

    def limit_target(self, xyz) -> Refusal | None:
        """A move's target outside an axis's travel (RRF's LimitPosition)."""
        found = self._refusals(np.asarray(xyz, dtype=np.float64).reshape(3))
        return found[0] if found else None

    @property
    def lower_hard_limits(self) -> tuple[tuple[int, int], ...]:
        """Switch 4 (Z down) stops Z going down while it reads closed."""
        return ((2, 3),)

    # -- from a scenario -----------------------------------------------------------------
    @classmethod
    def from_scenario(cls, scenario) -> GantryKinematics:
        """The gantry of a scenario's [gantry] section and the motors of its [drives]."""
        g, drv = scenario.gantry, scenario.drives
        common = dict(
            steps_per_rev=drv.steps_per_rev,
            max_step_rate_hz=drv.max_step_rate_hz,
            holding_torque_nm=drv.holding_torque_nm,
        )
        return cls(
            x_window_m=(g.x_min_m, g.x_max_m),
            y_window_m=(g.y_min_m, g.y_max_m),
            z_window_m=(g.z_min_m, g.z_max_m),
            drives_xyz=(
                _drive("x", g.belt_lead_m, {**common, "microsteps": g.belt_microsteps}),
                _drive("y", g.belt_lead_m, {**common, "microsteps": g.belt_microsteps}),
                _drive("z", drv.z_lead_m, {**common, "microsteps": drv.microsteps}),
            ),
        )

    @classmethod
    def homing_from_scenario(cls, scenario) -> HomingConfig:
        """Z first, then X and Y together; the seek and locate rates of [gantry], the
        debounce of [drives]."""
        g = scenario.gantry
        return HomingConfig(
            rate_hz=(g.homing_rate_xy_hz, g.homing_rate_xy_hz, g.homing_rate_z_hz),
            locate_rate_hz=(
                g.homing_locate_rate_xy_hz,
                g.homing_locate_rate_xy_hz,
                g.homing_locate_rate_z_hz,
            ),
            dirs=HOMING_DIRS,
            first_cycle=(2,),
            # a seek may cross the whole travel and 20 mm more
            max_steps=tuple(
                int(round((a.window[1] - a.window[0] + 0.02) * a.drive.steps_per_unit))
                for a in cls.from_scenario(scenario).axes
            ),
            debounce_s=scenario.drives.homing_debounce_s,
        )

    def describe(self) -> dict[str, float | str]:
        out: dict[str, float | str] = {"kind": self.kind}
        for name, (lo, hi) in zip("xyz", self.windows, strict=True):
            out[f"{name}_min_m"], out[f"{name}_max_m"] = lo, hi
        return out
