"""Serial 4-DOF servo arm of seed paper 004 (Dewi et al. 2020): base yaw, shoulder, elbow and a
gripper servo that opens the fingers without moving the point.

The paper's frame: x forward, y up, z sideways; its Table 3 fixes theta1 = atan2(z, x) for
every target. Taken as a right-handed frame (z = x cross y) z points to the right of the arm
seen from behind it, so a positive theta1 swings the arm to the right (clockwise seen from
above). The origin is the shoulder axis on the base's yaw axis (the paper's DH table has
d1 = 0). The arm is a base yaw theta1 carrying a planar 2R chain in its vertical plane:
theta2 is the upper arm's elevation above the horizontal, theta3 the forearm's angle relative
to the upper arm, l1 shoulder-elbow and l2 elbow-grip centre:

    r = l1 cos th2 + l2 cos(th2 + th3),  h = l1 sin th2 + l2 sin(th2 + th3),
    (x, y, z) = (r cos th1, h, r sin th1).

IK: th1 = atan2(z, x), r = sqrt(x^2 + z^2), c3 = (r^2 + y^2 - l1^2 - l2^2) / (2 l1 l2),
th3 = -+acos(c3) (elbow up: th3 <= 0, the elbow above the line shoulder-target; elbow down:
th3 >= 0), th2 = atan2(y, r) - atan2(l2 sin th3, l1 + l2 cos th3).

The printed Eq. 3 of the paper puts the 90 deg twist alpha1 in T01 (about the base's own
axis), where Craig's modified DH convention needs it in T12 (between the vertical base axis
and the horizontal shoulder axis); taken literally, joints 1-3 would be parallel and the arm
planar. This module is the corrected chain (docs/serial_arm.md).

Hobby servos drive the joints (:mod:`transplanter.machine.servo`): each joint's window is its
horn's 180 deg travel through its mount. An :class:`Axis` of the kinematics seam wants a
stepper drive; a servo's counterpart is its command resolution, one microsecond of pulse
width (0.09 deg for 2000 us over 180 deg), so each axis's drive counts those: 4000 counts per
revolution, its rate limit the servo's rated speed in counts per second, its holding torque
the stall torque. Homing: see :meth:`Serial4Kinematics.homing_from_scenario`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from transplanter.errors import Refusal, RefusalReason
from transplanter.machine.axes import Axis
from transplanter.machine.homing import HomingConfig
from transplanter.machine.kinematics.base import Kinematics, ReachReport, as_points
from transplanter.machine.servo import MG996R, SG90, ServoClass, ServoMount, servo_class
from transplanter.machine.steppers import StepperDrive
from transplanter.units import M_PER_MM

__all__ = ["ELBOWS", "Serial4Geometry", "Serial4Kinematics", "Serial4Limits", "fk", "ik"]

ELBOWS = ("up", "down")
AXIS_NAMES = ("base", "shoulder", "elbow")
JOINT_SUBJECTS = ("base angle theta1", "shoulder angle theta2", "elbow angle theta3")
_DEG = math.pi / 180.0


@dataclass(frozen=True)
class Serial4Geometry:
    """Link lengths (defaults: the MeArm class, 80 and 80 mm; the paper gives none)."""

    l1_m: float = 0.080
    """Shoulder axis to elbow axis."""
    l2_m: float = 0.080
    """Elbow axis to the grip centre (the point the kinematics places)."""

    def __post_init__(self) -> None:
        for name in ("l1_m", "l2_m"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"Serial4Geometry.{name} must be a positive length in m")


@dataclass(frozen=True)
class Serial4Limits:
    """Joint windows (rad; each at most a servo's 180 deg travel), the smallest distance of
    a target from the base axis and the range of target heights (m)."""

    base_rad: tuple[float, float] = (-90.0 * _DEG, 90.0 * _DEG)
    shoulder_rad: tuple[float, float] = (0.0, 180.0 * _DEG)
    elbow_rad: tuple[float, float] = (-165.0 * _DEG, 15.0 * _DEG)
    min_radius_m: float = 0.020
    """Targets closer to the base's yaw axis are refused: the base angle is undefined on the
    axis and the base servo's body is there."""
    y_min_m: float = -0.050
    """Lowest target height (below the shoulder): the table under the arm."""
    y_max_m: float = 0.160
    """Highest target height."""

    @classmethod
    def for_elbow(cls, elbow: str) -> Serial4Limits:
        """Default windows for an elbow-up or elbow-down mount (the elbow servo's 180 deg on
        the negative or the positive side of a straight arm)."""
        if elbow == "up":
            return cls()
        if elbow == "down":
            return cls(shoulder_rad=(-90.0 * _DEG, 90.0 * _DEG), elbow_rad=(-15 * _DEG, 165 * _DEG))
        raise ValueError(f"elbow must be one of {ELBOWS}, got {elbow!r}")

    def __post_init__(self) -> None:
        for name in ("base_rad", "shoulder_rad", "elbow_rad"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi and hi - lo <= math.pi):
                raise ValueError(
                    f"Serial4Limits.{name} must be finite with min < max, spanning at most a "
                    f"servo's 180 deg; got ({lo!r}, {hi!r})"
                )
        if not (math.isfinite(self.min_radius_m) and self.min_radius_m >= 0):
            raise ValueError("Serial4Limits.min_radius_m must be >= 0")
        if not (math.isfinite(self.y_min_m) and self.y_min_m < self.y_max_m):
            raise ValueError("Serial4Limits needs a finite y_min_m < y_max_m")

    @property
    def windows(self) -> tuple[tuple[float, float], ...]:
        return (self.base_rad, self.shoulder_rad, self.elbow_rad)


def _out(a: np.ndarray):
    return a[()]


def ik(geom: Serial4Geometry, xyz, elbow: str = "up") -> np.ndarray:
    """(..., 3) theta1, theta2, theta3 (rad) of (..., 3) points; NaN where out of reach."""
    if elbow not in ELBOWS:
        raise ValueError(f"elbow must be one of {ELBOWS}, got {elbow!r}")
    p = np.asarray(xyz, dtype=np.float64)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    l1, l2 = geom.l1_m, geom.l2_m
    theta1 = np.arctan2(z, x)
    r = np.hypot(x, z)
    with np.errstate(invalid="ignore"):
        c3 = (r * r + y * y - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
        reach = np.abs(c3) <= 1.0
        s3 = np.sqrt(np.clip(1.0 - c3 * c3, 0.0, 1.0))
    if elbow == "up":
        s3 = -s3
    theta3 = np.arctan2(s3, np.clip(c3, -1.0, 1.0))
    theta2 = np.arctan2(y, r) - np.arctan2(l2 * s3, l1 + l2 * c3)
    out = np.stack([theta1, theta2, theta3], axis=-1)
    out[~reach | ~np.isfinite(p).all(axis=-1)] = np.nan
    return out


def fk(geom: Serial4Geometry, joints) -> np.ndarray:
    """(..., 3) grip-centre point of (..., 3) theta1, theta2, theta3 (rad)."""
    q = np.asarray(joints, dtype=np.float64)
    t1, t2, t3 = q[..., 0], q[..., 1], q[..., 2]
    r = geom.l1_m * np.cos(t2) + geom.l2_m * np.cos(t2 + t3)
    h = geom.l1_m * np.sin(t2) + geom.l2_m * np.sin(t2 + t3)
    return np.stack([r * np.cos(t1), h, r * np.sin(t1)], axis=-1)


def _servo_drive(name: str, servo: ServoClass) -> StepperDrive:
    """The seam's drive of a servo-driven joint: one count per microsecond of pulse width."""
    counts = servo.counts_per_rev
    return StepperDrive(
        name,
        steps_per_rev=counts,
        microsteps=1,
        ratio=1.0,
        max_step_rate_hz=servo.speed_rad_s * counts / (2.0 * math.pi),
        holding_torque_nm=servo.stall_torque_nm,
    )


LOCATE_RATE_HZ = 200.0
"""Counts per second of the homing cycle's slow second approach: the simulated switch is read
once a physics step, so the locate stops within a fifth of a count (0.02 deg) of the park
angle at a 1 ms step, as a servo's own potentiometer would put it (at the rated speed it
would overshoot by 4-7 counts, half a degree, an error of the stand-in, not of the arm)."""

PARK_RAD = {"up": (0.0, 90.0 * _DEG, -90.0 * _DEG), "down": (0.0, 0.0, 90.0 * _DEG)}
"""The default park (standby) pose of each elbow branch, the grip centre l2 ahead of and l1
above the shoulder: elbow up, upper arm vertical and forearm level; elbow down, its mirror
(upper arm level, forearm vertical)."""


@dataclass(frozen=True)
class Serial4Kinematics(Kinematics):
    """The serial servo arm: axes base, shoulder, elbow (rotary, rad), each a hobby servo
    whose 180 deg travel is the joint's window; IK in the chosen elbow branch, FK, reach
    check with typed refusals, the targets' height range. The gripper servo is not an axis:
    it opens the fingers without moving the point (``gripper_servo`` names its class)."""

    kind = "serial4"

    geometry: Serial4Geometry = field(default_factory=Serial4Geometry)
    elbow: str = "up"
    """IK branch: 'up' (theta3 <= 0) or 'down' (theta3 >= 0)."""
    limits: Serial4Limits | None = None
    """None: :meth:`Serial4Limits.for_elbow` of ``elbow``."""
    servos: tuple[ServoClass, ServoClass, ServoClass] = (SG90, MG996R, MG996R)
    """The servo class of the base, shoulder and elbow."""
    gripper_servo: ServoClass = SG90
    park_rad: tuple[float, float, float] | None = None
    """Joint angles of the park pose, where a homing command sends the arm; None:
    ``PARK_RAD[elbow]``."""

    coordinates = ("X", "Y", "Z")

    def __post_init__(self) -> None:
        if not isinstance(self.geometry, Serial4Geometry):
            raise ValueError(f"geometry must be a Serial4Geometry, got {self.geometry!r}")
        if self.elbow not in ELBOWS:
            raise ValueError(f"elbow must be one of {ELBOWS}, got {self.elbow!r}")
        limits = Serial4Limits.for_elbow(self.elbow) if self.limits is None else self.limits
        if not isinstance(limits, Serial4Limits):
            raise ValueError(f"limits must be Serial4Limits, got {limits!r}")
        object.__setattr__(self, "limits", limits)
        servos = tuple(self.servos)
        if len(servos) != 3 or not all(isinstance(s, ServoClass) for s in servos):
            raise ValueError("the serial arm needs 3 ServoClass (base, shoulder, elbow)")
        object.__setattr__(self, "servos", servos)
        park = tuple(float(a) for a in (self.park_rad or PARK_RAD[self.elbow]))
        for name, value, (lo, hi) in zip(AXIS_NAMES, park, limits.windows, strict=True):
            if not lo <= value <= hi:
                raise ValueError(
                    f"park angle of the {name} ({math.degrees(value):g} deg) lies outside its "
                    f"window [{math.degrees(lo):g}, {math.degrees(hi):g}] deg"
                )
        object.__setattr__(self, "park_rad", park)
        axes = tuple(
            Axis(name, _servo_drive(name, servo), h, w, f"{name} park (absolute servo, no switch)")
            for name, servo, h, w in zip(AXIS_NAMES, servos, park, limits.windows, strict=True)
        )
        object.__setattr__(self, "_axes", axes)

    @property
    def axes(self) -> tuple[Axis, ...]:
        return self._axes

    @property
    def mounts(self) -> tuple[ServoMount, ...]:
        """Each joint's servo mount: horn angle 0 at the window's lower end."""
        return tuple(
            ServoMount(servo, lo) for servo, (lo, _) in zip(self.servos, self.limits.windows,
                                                            strict=True)
        )  # fmt: skip

    def pulse_us(self, joints) -> np.ndarray:
        """(..., 3) pulse widths (whole us, int64) the firmware sends for (..., 3) joints."""
        q = np.asarray(joints, dtype=np.float64)
        return np.stack([m.pulse_us(q[..., i]) for i, m in enumerate(self.mounts)], axis=-1)

    # -- the seam --------------------------------------------------------------------
    def joints(self, xyz) -> np.ndarray:
        """(..., 3) theta1, theta2, theta3 (rad) in this elbow branch; NaN if unreachable."""
        return ik(self.geometry, xyz, self.elbow)

    def point(self, joints) -> np.ndarray:
        return fk(self.geometry, joints)

    def check(self, xyz) -> ReachReport:
        """Per-point verdicts: reach (|l1 - l2| <= distance from the shoulder <= l1 + l2),
        the base-axis radius and every joint window; joints (N, 3), NaN where out of reach;
        diagnostics: ``radius`` (m from the base axis), ``distance`` (m from the shoulder)."""
        pts = as_points(xyz)
        joints = self.joints(pts)
        radius = np.hypot(pts[:, 0], pts[:, 2])
        distance = np.hypot(radius, pts[:, 1])
        lim = self.limits
        finite = np.isfinite(pts).all(axis=1)
        reach = np.isfinite(joints).all(axis=1)
        with np.errstate(invalid="ignore"):
            bad = reach & (radius < lim.min_radius_m)
            for m, (lo, hi) in enumerate(lim.windows):
                bad |= reach & ~((joints[:, m] >= lo) & (joints[:, m] <= hi))
        ok = reach & ~bad
        refusals: list[tuple[Refusal, ...]] = [()] * len(pts)
        for i in np.flatnonzero(~ok):  # words only for the refused points
            refusals[i] = self._refusals(pts[i], joints[i], radius[i], distance[i], finite[i])
        return ReachReport(
            joints=joints,
            ok=ok,
            refusals=tuple(refusals),
            diagnostics={"radius": radius, "distance": distance},
        )

    def _refusals(self, point, joints, radius, distance, finite) -> tuple[Refusal, ...]:
        """Every limit one refused point violates, with its numbers."""
        g, lim = self.geometry, self.limits
        if not finite:
            return (Refusal(RefusalReason.NOT_FINITE, "coordinates"),)
        if not np.isfinite(joints).all():
            lmin, lmax = abs(g.l1_m - g.l2_m), g.l1_m + g.l2_m
            return (
                Refusal(
                    RefusalReason.OUT_OF_WORKSPACE, "|P-S|", distance / M_PER_MM,
                    lmin / M_PER_MM, lmax / M_PER_MM, "mm", bound_names=("|l1-l2|", "l1+l2"),
                ),
            )  # fmt: skip
        out: list[Refusal] = []
        if radius < lim.min_radius_m:
            out.append(
                Refusal(
                    RefusalReason.SERIAL_SINGULARITY, "distance from the base axis",
                    radius / M_PER_MM, lim.min_radius_m / M_PER_MM, math.inf, "mm",
                    "the base angle is undefined on the axis", label="base axis",
                )
            )  # fmt: skip
        for m, (lo, hi) in enumerate(lim.windows):
            if not lo <= joints[m] <= hi:
                out.append(
                    Refusal(
                        RefusalReason.JOINT_LIMIT, JOINT_SUBJECTS[m], math.degrees(joints[m]),
                        math.degrees(lo), math.degrees(hi), "deg", label=AXIS_NAMES[m],
                    )
                )  # fmt: skip
        return tuple(out)

    def limit_target(self, xyz) -> Refusal | None:
        """A target's height y outside [y_min_m, y_max_m]."""
        y = float(np.asarray(xyz, dtype=np.float64)[1])
        lim = self.limits
        if lim.y_min_m <= y <= lim.y_max_m:
            return None
        return Refusal(
            RefusalReason.AXIS_RANGE, "Y", y / M_PER_MM, lim.y_min_m / M_PER_MM,
            lim.y_max_m / M_PER_MM, "mm",
        )  # fmt: skip

    def point_lines(self, report: ReachReport, i: int) -> list[str]:
        """theta1..theta3 as the paper names them, and the servo pulses that command them."""
        q = report.joints[i]
        lines = [f"theta{m + 1} = {math.degrees(float(q[m])):.4f} deg" for m in range(3)]
        pulses = self.pulse_us(q)
        shown = ", ".join(f"{n} {p} us" for n, p in zip(AXIS_NAMES, pulses, strict=True))
        lines.append(f"servo pulses: {shown}")
        return lines

    @classmethod
    def from_scenario(cls, scenario) -> Serial4Kinematics:
        """The arm of a scenario's [serial4] section."""
        s = scenario.serial4
        limits = Serial4Limits(
            base_rad=(s.base_min_rad, s.base_max_rad),
            shoulder_rad=(s.shoulder_min_rad, s.shoulder_max_rad),
            elbow_rad=(s.elbow_min_rad, s.elbow_max_rad),
            min_radius_m=s.min_radius_m,
            y_min_m=s.y_min_m,
            y_max_m=s.y_max_m,
        )
        return cls(
            geometry=Serial4Geometry(l1_m=s.l1_m, l2_m=s.l2_m),
            elbow=s.elbow,
            limits=limits,
            servos=(servo_class(s.base_servo), servo_class(s.shoulder_servo),
                    servo_class(s.elbow_servo)),
            gripper_servo=servo_class(s.gripper_servo),
            park_rad=(s.park_base_rad, s.park_shoulder_rad, s.park_elbow_rad),
        )  # fmt: skip

    @classmethod
    def homing_from_scenario(cls, scenario) -> HomingConfig:
        """Hobby servos need no homing: each reads its own angle on a potentiometer from
        power-on, so a servo firmware's G28 is one move to the park pose. The seam's
        HomingConfig is a switch-seeking cycle (the SGF is the five-bar's stepper firmware);
        for this arm it seeks the park pose on every axis at once, at each servo's rated
        speed, where a simulated switch (``Axis.home_position`` = the park angle) stands in
        for the servo's own position sense. The arm keeps no switches in its model."""
        arm = cls.from_scenario(scenario)
        return HomingConfig(
            rate_hz=tuple(axis.drive.max_step_rate_hz for axis in arm.axes),
            locate_rate_hz=tuple(LOCATE_RATE_HZ for _ in arm.axes),
            dirs=(+1, +1, +1),
            first_cycle=None,
        )

    def describe(self) -> dict[str, float | str]:
        g = self.geometry
        return {"kind": self.kind, "l1_m": g.l1_m, "l2_m": g.l2_m, "elbow": self.elbow}
