"""Planar five-bar (5R) kinematics of the transplanter arm (paper eqs 1-7).

Motors sit at O1 = (-L0, 0) and O2 = (+L0, 0). Active links of length L1 end at the elbows
B (arm 1) and D (arm 2); passive links of length L2 from B and D meet at the end effector
C = (x, y). Motor angles theta1, theta2 are measured at the motors from +x, counter-clockwise.

Everything is vectorised over numpy arrays and in SI units (m, rad). Unreachable points give
NaN; :func:`check_points` and :func:`require_reachable` turn that (and the joint, elbow,
transmission and conditioning limits) into per-point verdicts with reasons.

:class:`FiveBarKinematics` is this arm's implementation of the kinematics seam
(:class:`transplanter.machine.kinematics.base.Kinematics`): the two arm motors and the Z lead
screw as its three axes, IK, the FK assembly that IK maps back, the reach check with typed
refusals, Z's travel and its lower limit switch. The functions below are its numeric core.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from transplanter.errors import Refusal, RefusalReason, refusal_text
from transplanter.machine.axes import Axis
from transplanter.machine.homing import HomingConfig
from transplanter.machine.kinematics.base import (
    Kinematics,
    ReachReport,
    UnreachableError,
    as_points,
)
from transplanter.machine.steppers import StepperDrive, default_drives
from transplanter.units import M_PER_MM, show

TWO_PI = 2.0 * math.pi
MODES = ("+-", "-+", "++", "--")
ASSEMBLIES = ("up", "down")


@dataclass(frozen=True)
class FiveBarGeometry:
    """Link lengths of the symmetric five-bar arm (design defaults 50/120/200 mm)."""

    l0_m: float = 0.050
    """Half the motor spacing: motors at (-l0, 0) and (+l0, 0)."""
    l1_m: float = 0.120
    """Active (motor-driven) link length, motor to elbow."""
    l2_m: float = 0.200
    """Passive link length, elbow to end effector."""

    def __post_init__(self) -> None:
        for name in ("l0_m", "l1_m", "l2_m"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(
                    f"FiveBarGeometry.{name} must be a positive length in m, got {value!r}"
                )


@dataclass(frozen=True)
class KinematicLimits:
    """Limits a point must satisfy to be commanded (all angles in rad).

    Motor windows: RepRapFirmware's default of 10-170 deg for both motors does not fit the
    paper's elbows-out mode, in which arm 1 points left and arm 2 points right: over the
    design workspace (x in [-100, 100] mm, y in [120, 240] mm) theta1 spans 94.6-218.8 deg and
    theta2 spans -38.8-85.4 deg. The defaults give motor 1 [80, 235] deg and motor 2 the
    mirror image [-55, 100] deg (about 15 deg of margin on each side).
    """

    motor1_min_rad: float = math.radians(80.0)
    """Lower limit of motor 1 (theta1); also motor 2's upper limit mirrored (pi - it)."""
    motor1_max_rad: float = math.radians(235.0)
    """Upper limit of motor 1 (theta1); also motor 2's lower limit mirrored (pi - it)."""
    motor2_min_rad: float | None = None
    """Lower limit of motor 2 (theta2); None mirrors motor 1: pi - motor1_max_rad."""
    motor2_max_rad: float | None = None
    """Upper limit of motor 2 (theta2); None mirrors motor 1: pi - motor1_min_rad."""
    elbow_min_rad: float = math.radians(15.0)
    """Smallest angle between active and passive link at B and at D (0 = folded: serial
    singularity at the inner workspace boundary)."""
    elbow_max_rad: float = math.radians(165.0)
    """Largest angle between active and passive link at B and at D (180 = stretched: serial
    singularity at the outer workspace boundary)."""
    transmission_min_rad: float = math.radians(30.0)
    """Smallest angle at C between the two passive links (0 = parallel singularity)."""
    transmission_max_rad: float = math.radians(150.0)
    """Largest angle at C between the two passive links (180 = parallel singularity)."""
    max_condition: float = 10.0
    """Largest condition number of the Jacobian dC/dtheta (1 = isotropic)."""

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if value is None:
                continue
            if not (isinstance(value, int | float) and math.isfinite(value)):
                raise ValueError(f"KinematicLimits.{name} must be a finite number, got {value!r}")
        for i in (1, 2):
            lo, hi = self.motor_window(i)
            if not lo < hi or hi - lo > TWO_PI:
                raise ValueError(
                    f"motor {i} window [{math.degrees(lo):.1f}, {math.degrees(hi):.1f}] deg must "
                    "have min < max and span at most 360 deg"
                )
        pairs = (
            ("elbow_min_rad", "elbow_max_rad"),
            ("transmission_min_rad", "transmission_max_rad"),
        )
        for lo_name, hi_name in pairs:
            lo, hi = getattr(self, lo_name), getattr(self, hi_name)
            if not 0.0 <= lo < hi <= math.pi:
                raise ValueError(
                    f"KinematicLimits needs 0 <= {lo_name} < {hi_name} <= pi, got {lo!r}, {hi!r}"
                )
        if self.max_condition < 1.0:
            raise ValueError(
                f"KinematicLimits.max_condition must be >= 1, got {self.max_condition}"
            )

    def motor_window(self, motor: int) -> tuple[float, float]:
        """(min, max) angle of motor 1 or 2 in rad."""
        if motor == 1:
            return self.motor1_min_rad, self.motor1_max_rad
        if motor == 2:
            lo = (
                math.pi - self.motor1_max_rad
                if self.motor2_min_rad is None
                else self.motor2_min_rad
            )
            hi = (
                math.pi - self.motor1_min_rad
                if self.motor2_max_rad is None
                else self.motor2_max_rad
            )
            return lo, hi
        raise ValueError(f"motor must be 1 or 2, got {motor!r}")


def _out(a: np.ndarray):
    """Return numpy scalars for 0-d results, arrays otherwise."""
    return a[()]


def _xy(x, y) -> tuple[np.ndarray, np.ndarray]:
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    return x, y


def _gamma(geom: FiveBarGeometry, dist: np.ndarray) -> np.ndarray:
    """Cosine-rule angle at the motor between motor->C and motor->elbow (eqs 1-2)."""
    l1, l2 = geom.l1_m, geom.l2_m
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_g = (l1 * l1 - l2 * l2 + dist * dist) / (2.0 * l1 * dist)
        # |cos| > 1 means the triangle cannot close: arccos gives NaN there.
        return np.arccos(cos_g)


def ik_region(geom: FiveBarGeometry, x, y):
    """The paper's region-based IK (eqs 1-7) for the elbows-out mode, vectorised.

    Region 1: -L0 < x < L0, region 2: x >= L0, region 3: x <= -L0. Written, like the paper, for
    C above the motor baseline (y > 0); there it equals ``ik(..., mode="+-")``.
    Returns (theta1, theta2) in rad, NaN where unreachable.
    """
    x, y = _xy(x, y)
    l0 = geom.l0_m
    k = np.sqrt((x + l0) ** 2 + y**2)  # eq 1
    s = np.sqrt((x - l0) ** 2 + y**2)  # eq 2
    gamma1 = _gamma(geom, k)
    gamma2 = _gamma(geom, s)
    with np.errstate(divide="ignore", invalid="ignore"):
        atan1 = np.arctan(y / np.abs(l0 + x))
        atan2 = np.arctan(y / np.abs(l0 - x))
    region2 = x >= l0
    region3 = x <= -l0
    beta1 = np.where(region3, np.pi - atan1, atan1)  # eqs 3-5
    beta2 = np.where(region2, atan2, np.pi - atan2)
    theta1 = beta1 + gamma1  # eq 6
    theta2 = beta2 - gamma2  # eq 7
    return _out(theta1), _out(theta2)


def ik(geom: FiveBarGeometry, x, y, mode: str = "+-"):
    """Inverse kinematics for any of the four working modes, vectorised.

    ``mode`` gives the sign of gamma for arm 1 then arm 2: '+-' is the paper's elbows-out mode
    (theta1 = beta1 + gamma1, theta2 = beta2 - gamma2), '-+' elbows in, '++' and '--' both
    elbows to one side. beta_i = atan2 direction of O_i->C, in (-pi, pi].
    Returns (theta1, theta2) in rad, NaN where unreachable.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    x, y = _xy(x, y)
    l0 = geom.l0_m
    sign1 = 1.0 if mode[0] == "+" else -1.0
    sign2 = 1.0 if mode[1] == "+" else -1.0
    k = np.hypot(x + l0, y)
    s = np.hypot(x - l0, y)
    theta1 = np.arctan2(y, x + l0) + sign1 * _gamma(geom, k)
    theta2 = np.arctan2(y, x - l0) + sign2 * _gamma(geom, s)
    return _out(theta1), _out(theta2)


def elbow_points(geom: FiveBarGeometry, theta1, theta2):
    """Elbow positions B (arm 1) and D (arm 2), each of shape (..., 2) in m."""
    t1, t2 = _xy(theta1, theta2)
    l0, l1 = geom.l0_m, geom.l1_m
    b = np.stack([-l0 + l1 * np.cos(t1), l1 * np.sin(t1)], axis=-1)
    d = np.stack([l0 + l1 * np.cos(t2), l1 * np.sin(t2)], axis=-1)
    return b, d


def fk(geom: FiveBarGeometry, theta1, theta2, assembly: str = "up"):
    """Forward kinematics: intersect the passive-link circles about B and D.

    'up' is the intersection to the left of the directed line B->D (cross(D-B, C-B) > 0): the
    one farther from the motor baseline, larger y, whenever D lies right of B, as throughout
    the paper's workspace; 'down' is the other. NaN where the links cannot close.
    """
    if assembly not in ASSEMBLIES:
        raise ValueError(f"assembly must be one of {ASSEMBLIES}, got {assembly!r}")
    b, d = elbow_points(geom, theta1, theta2)
    bd = d - b
    dist = np.hypot(bd[..., 0], bd[..., 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        half = 0.5 * dist
        h = np.sqrt(geom.l2_m**2 - half * half)  # NaN when dist > 2 L2
        h = np.where(dist > 0.0, h, np.nan)  # coincident elbows: C undetermined
        nx, ny = -bd[..., 1] / dist, bd[..., 0] / dist  # unit normal, left of B->D
    side = 1.0 if assembly == "up" else -1.0
    x = b[..., 0] + 0.5 * bd[..., 0] + side * h * nx
    y = b[..., 1] + 0.5 * bd[..., 1] + side * h * ny
    return _out(x), _out(y)


def assembly_of(geom: FiveBarGeometry, theta1, theta2, x, y):
    """Which FK assembly ('up' True, 'down' False) the point C is in, as a bool array."""
    b, d = elbow_points(geom, theta1, theta2)
    x, y = _xy(x, y)
    cross = (d[..., 0] - b[..., 0]) * (y - b[..., 1]) - (d[..., 1] - b[..., 1]) * (x - b[..., 0])
    return _out(cross > 0.0)


def jacobian(geom: FiveBarGeometry, theta1, theta2, x, y) -> np.ndarray:
    """dC/dtheta as an array of shape (..., 2, 2): J[..., i, j] = d C_i / d theta_j.

    From the loop closures |C - B(theta1)|^2 = |C - D(theta2)|^2 = L2^2:
    (C - B) . dC = (C - B) . B'(theta1) dtheta1, likewise for D, so J = A^-1 diag(b) with
    the rows of A being C - B and C - D. Infinite at the parallel singularity (det A = 0).
    """
    t1, t2, x, y = np.broadcast_arrays(
        *(np.asarray(v, dtype=np.float64) for v in (theta1, theta2, x, y))
    )
    b, d = elbow_points(geom, t1, t2)
    l1 = geom.l1_m
    a11, a12 = x - b[..., 0], y - b[..., 1]
    a21, a22 = x - d[..., 0], y - d[..., 1]
    rhs1 = l1 * (-a11 * np.sin(t1) + a12 * np.cos(t1))
    rhs2 = l1 * (-a21 * np.sin(t2) + a22 * np.cos(t2))
    det = a11 * a22 - a12 * a21
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_det = 1.0 / det
    jac = np.empty(t1.shape + (2, 2))
    jac[..., 0, 0] = a22 * rhs1 * inv_det
    jac[..., 0, 1] = -a12 * rhs2 * inv_det
    jac[..., 1, 0] = -a21 * rhs1 * inv_det
    jac[..., 1, 1] = a11 * rhs2 * inv_det
    return jac


def condition_number(jac: np.ndarray):
    """2-norm condition number of (..., 2, 2) matrices; inf where singular or not finite."""
    frob2 = np.sum(jac * jac, axis=(-2, -1))
    det = np.abs(jac[..., 0, 0] * jac[..., 1, 1] - jac[..., 0, 1] * jac[..., 1, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(np.maximum(frob2 * frob2 - 4.0 * det * det, 0.0))
        cond = (frob2 + root) / (2.0 * det)  # sigma_max^2 / (sigma_max * sigma_min)
    return _out(np.where(np.isfinite(cond), cond, np.inf))


def _angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    cross = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    dot = u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1]
    return np.arctan2(np.abs(cross), dot)


def transmission_angle(geom: FiveBarGeometry, theta1, theta2, x, y):
    """Angle at C between the passive links C->B and C->D, in [0, pi] rad."""
    b, d = elbow_points(geom, theta1, theta2)
    c = np.stack(_xy(x, y), axis=-1)
    return _out(_angle_between(b - c, d - c))


def elbow_angles(geom: FiveBarGeometry, theta1, theta2, x, y):
    """Angles between active and passive link at B and at D, each in [0, pi] rad."""
    b, d = elbow_points(geom, theta1, theta2)
    c = np.stack(_xy(x, y), axis=-1)
    o1 = np.array([-geom.l0_m, 0.0])
    o2 = np.array([geom.l0_m, 0.0])
    return _out(_angle_between(o1 - b, c - b)), _out(_angle_between(o2 - d, c - d))


def _wrap_into(theta: np.ndarray, lo: float) -> np.ndarray:
    """Wrap angles into [lo, lo + 2 pi)."""
    return lo + np.mod(theta - lo, TWO_PI)


def _evaluate(geom, limits, x, y, mode):
    x, y = _xy(x, y)
    x, y = x.ravel(), y.ravel()
    theta1, theta2 = ik(geom, x, y, mode)
    theta1, theta2 = np.atleast_1d(theta1), np.atleast_1d(theta2)
    lo1, hi1 = limits.motor_window(1)
    lo2, hi2 = limits.motor_window(2)
    theta1 = _wrap_into(theta1, lo1)
    theta2 = _wrap_into(theta2, lo2)
    elbow1, elbow2 = (np.atleast_1d(a) for a in elbow_angles(geom, theta1, theta2, x, y))
    trans = np.atleast_1d(transmission_angle(geom, theta1, theta2, x, y))
    cond = np.atleast_1d(condition_number(jacobian(geom, theta1, theta2, x, y)))
    reach = np.isfinite(theta1) & np.isfinite(theta2)
    with np.errstate(invalid="ignore"):
        bad = {
            "reach": ~reach,
            "motor1": reach & (theta1 > hi1),
            "motor2": reach & (theta2 > hi2),
            "elbow1": reach & ((elbow1 < limits.elbow_min_rad) | (elbow1 > limits.elbow_max_rad)),
            "elbow2": reach & ((elbow2 < limits.elbow_min_rad) | (elbow2 > limits.elbow_max_rad)),
            "transmission": reach
            & ((trans < limits.transmission_min_rad) | (trans > limits.transmission_max_rad)),
            "condition": reach & ~(cond <= limits.max_condition),
        }
    ok = ~np.logical_or.reduce(list(bad.values()))
    arrays = dict(x=x, y=y, theta1=theta1, theta2=theta2, elbow1=elbow1, elbow2=elbow2)
    arrays.update(transmission=trans, condition=cond)
    return ok, bad, arrays


def _refusals(geom, limits, bad, arrays, i) -> tuple[Refusal, ...]:
    deg = math.degrees
    x, y = arrays["x"][i], arrays["y"][i]
    out: list[Refusal] = []
    if bad["reach"][i]:
        lmax, lmin = geom.l1_m + geom.l2_m, abs(geom.l1_m - geom.l2_m)
        for arm, ox in ((1, -geom.l0_m), (2, geom.l0_m)):
            dist = math.hypot(x - ox, y)
            if not math.isfinite(dist):
                out.append(Refusal(RefusalReason.NOT_FINITE, "coordinates"))
                break
            if dist > lmax or dist < lmin:
                out.append(
                    Refusal(
                        RefusalReason.OUT_OF_WORKSPACE, f"|C-O{arm}|", dist / M_PER_MM,
                        lmin / M_PER_MM, lmax / M_PER_MM, "mm", bound_names=("|L1-L2|", "L1+L2"),
                    )
                )  # fmt: skip
        return tuple(out)
    for motor in (1, 2):
        if bad[f"motor{motor}"][i]:
            lo, hi = limits.motor_window(motor)
            theta = arrays[f"theta{motor}"][i]
            if theta - hi > lo + TWO_PI - theta:  # closer to the lower limit: show it below
                theta -= TWO_PI
            out.append(
                Refusal(
                    RefusalReason.JOINT_LIMIT, f"motor {motor} angle", deg(theta), deg(lo),
                    deg(hi), "deg", label=f"motor{motor}",
                )
            )  # fmt: skip
    for arm, elbow in ((1, "B"), (2, "D")):
        if bad[f"elbow{arm}"][i]:
            out.append(
                Refusal(
                    RefusalReason.SERIAL_SINGULARITY, f"elbow angle at {elbow}",
                    deg(arrays[f"elbow{arm}"][i]), deg(limits.elbow_min_rad),
                    deg(limits.elbow_max_rad), "deg",
                    "near a serial singularity at the workspace boundary", label=f"elbow {elbow}",
                )
            )  # fmt: skip
    if bad["transmission"][i]:
        out.append(
            Refusal(
                RefusalReason.PARALLEL_SINGULARITY, "transmission angle",
                deg(arrays["transmission"][i]), deg(limits.transmission_min_rad),
                deg(limits.transmission_max_rad), "deg", "near parallel singularity",
                label="transm.",
            )
        )  # fmt: skip
    if bad["condition"][i]:
        out.append(
            Refusal(
                RefusalReason.ILL_CONDITIONED, "Jacobian condition",
                float(arrays["condition"][i]), None, limits.max_condition,
            )
        )  # fmt: skip
    return tuple(out)


def check_points(
    geom: FiveBarGeometry, limits: KinematicLimits, x, y, mode: str = "+-"
) -> ReachReport:
    """Check every point (flattened) of the plane against the workspace and all limits:
    joints (N, 2) are (theta1, theta2) wrapped into the motor windows; diagnostics hold the
    elbow angles (``elbow1``, ``elbow2``), the ``transmission`` angle (rad) and the Jacobian's
    ``condition``."""
    ok, bad, arrays = _evaluate(geom, limits, x, y, mode)
    refusals: list[tuple[Refusal, ...]] = [()] * ok.size
    for i in np.flatnonzero(~ok):
        refusals[i] = _refusals(geom, limits, bad, arrays, i)
    names = ("elbow1", "elbow2", "transmission", "condition")
    return ReachReport(
        joints=np.column_stack([arrays["theta1"], arrays["theta2"]]),
        ok=ok,
        refusals=tuple(refusals),
        diagnostics={name: arrays[name] for name in names},
    )


def require_reachable(geom: FiveBarGeometry, limits: KinematicLimits, x, y, mode: str = "+-"):
    """(theta1, theta2) arrays for points that all pass; else UnreachableError for the first."""
    ok, bad, arrays = _evaluate(geom, limits, x, y, mode)
    if not ok.all():
        i = int(np.flatnonzero(~ok)[0])
        refusals = _refusals(geom, limits, bad, arrays, i)
        raise UnreachableError(
            i,
            refusals,
            f"target position not reachable: point {i} at (x, y) = "
            f"({show(arrays['x'][i] / M_PER_MM)}, {show(arrays['y'][i] / M_PER_MM)}) mm: "
            f"{refusal_text(refusals)}",
        )
    return arrays["theta1"], arrays["theta2"]


_SAME_ANGLE_RAD = 1e-6
"""IK of an FK point must give the joints back within this (wrapped) to be that assembly."""


def _wrap_pi(angle):
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - angle, TWO_PI)


SWITCH_NAMES = ("arm 1 home", "arm 2 home", "Z up", "Z down")
"""What each limit switch 1-4 is for (switches 1-3 home the axes; 4 is Z's lower hard limit)."""

JOINT_SPEED_LIMITS = (math.radians(712.5), math.radians(712.5), 0.0475)
"""Default joint speed limits of a ``bspline5`` transfer (arm 1, arm 2 in rad/s; Z in m/s):
95 % of what the SGF's 20 kHz step rate allows the default drives (9600 microsteps per arm
revolution: 750 deg/s; 400 microsteps per mm of Z: 50 mm/s), below the pull-out curve's
corner (8 rev/s at the motor: 960 deg/s at the arm, 64 mm/s on Z). docs/planner.md."""
JOINT_ACCEL_LIMITS = (math.radians(25000.0), math.radians(25000.0), 25.0)
"""Default joint acceleration limits (rad/s^2, rad/s^2, m/s^2), estimates from half the
pull-out torque (0.225 N m at the motor: a load angle of a third of a full step): the arm's
0.675 N m less what an 80 g pot, the jaws and the passive links (0.283 kg at C) take at the
8.83 m/s^2 end-effector limit through the largest Jacobian column of the workspace
(0.127 m/rad: 0.316 N m), over an arm's own inertia (rotor through the belt 4.9e-5, active
link 2.9e-4, half a passive link at the elbow 4.3e-4: 7.7e-4 kg m^2): 467 rad/s^2 = 26 700
deg/s^2; Z: 177 N at the slide less 14 N of weight and 25 N of screw friction over 4.8 kg
(the slide's 1.46 kg and the rotor's 3.33 kg through the screw): 28.6 m/s^2. Rounded down.
docs/planner.md."""


@dataclass(frozen=True)
class FiveBarMasses:
    """The inertia of the arm's lumped dynamics (:meth:`FiveBarKinematics.inverse_dynamics`),
    in SI units. The twin's values are the MuJoCo model's, read from the compiled model
    (``transplanter.scene.robots.fivebar.arm_masses``): the firmware side only holds numbers."""

    rotor_inertia_kgm2: float
    """One arm motor's rotor, at its shaft (the model's armature over the belt ratio
    squared)."""
    active_link_kgm2: float
    """One active link about its motor's axis (at the arm)."""
    passive_link_kg: float
    """One passive link; half of it is lumped at its elbow, half at C (a uniform rod's weight
    splits so; its own turning is left out)."""
    end_effector_kg: float
    """What C carries besides the passive links: the wrist, gripper and jaws, and the load
    (the heaviest pot the scenario draws with its shoot), a point mass at C."""

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(
                    f"FiveBarMasses.{name} must be a finite number >= 0, got {value!r}"
                )


@dataclass(frozen=True)
class FiveBarKinematics(Kinematics):
    """The five-bar arm in one working mode on its Z slide: axes arm 1, arm 2 (rotary, rad)
    and Z (lead screw, m); IK, FK, step counters and limits, vectorised.

    ``point`` is the FK assembly that ``joints`` maps back to the same motor angles, so
    ``point(joints(p)) == p`` for a reachable point and the firmware's position after homing
    is the one its next move's IK starts from.
    """

    kind = "fivebar"

    geometry: FiveBarGeometry = field(default_factory=FiveBarGeometry)
    limits: KinematicLimits = field(default_factory=KinematicLimits)
    mode: str = "+-"
    """Working mode of the IK (see :func:`ik`); the paper's is '+-', elbows out."""
    drives: tuple[StepperDrive, ...] = default_drives()
    """(arm 1, arm 2, Z) drives (a plain default: it shadows the base class's property)."""
    home_theta1_rad: float = math.radians(200.0)
    """Motor 1 angle at which limit switch 1 trips (arms folded back, C at (0, 75) mm)."""
    home_theta2_rad: float = math.radians(-20.0)
    """Motor 2 angle at which limit switch 2 trips."""
    home_z_m: float = 0.160
    """Z at which limit switch 3 (Z up) trips."""
    z_min_m: float = 0.005
    """Lowest Z a move may target (limit switch 4, Z down, trips there)."""
    z_max_m: float = 0.160
    """Highest Z a move may target."""
    joint_speed_limits: tuple[float, float, float] = JOINT_SPEED_LIMITS
    """Joint speed limits of a ``bspline5`` transfer (arm 1, arm 2 in rad/s, Z in m/s); a
    ``bspline5`` machine refuses one above what its drive's step rate allows
    (``spline_motion.spline_limits``)."""
    joint_accel_limits: tuple[float, float, float] = JOINT_ACCEL_LIMITS
    """Joint acceleration limits of a ``bspline5`` transfer (rad/s^2, rad/s^2, m/s^2)."""
    masses: FiveBarMasses | None = None
    """The lumped dynamics' inertia (:meth:`inverse_dynamics`); None: no dynamics model (the
    scenario's machine has the MuJoCo model's, ``scenario.assemble``)."""
    arm_torque_limit_nm: float | None = None
    """Each arm motor's torque limit of a ``bspline5`` transfer, N m at the motor shaft (the
    belt multiplies it by its ratio at the arm); None: no torque limit. Needs :attr:`masses`
    to be planned against."""

    transfer_path = "via"
    """How ``motion.planner = "bspline5"`` moves this arm: a ``G0`` is a spline through the
    via points the host sent before it (``M720``), not the delta's pick path."""

    def __post_init__(self) -> None:
        if not isinstance(self.geometry, FiveBarGeometry):
            raise ValueError(f"geometry must be a FiveBarGeometry, got {self.geometry!r}")
        if not isinstance(self.limits, KinematicLimits):
            raise ValueError(f"limits must be KinematicLimits, got {self.limits!r}")
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
        drives = tuple(self.drives)
        if len(drives) != 3 or not all(isinstance(d, StepperDrive) for d in drives):
            raise ValueError("the five-bar's drives must be 3 StepperDrive (arm 1, arm 2, Z)")
        if drives[0].linear or drives[1].linear:
            raise ValueError("the five-bar's arm drives (drives[0], drives[1]) must be rotary")
        if not drives[2].linear:
            raise ValueError("the five-bar's Z drive (drives[2]) must be a lead screw (lead_m)")
        if not (math.isfinite(self.z_min_m) and self.z_min_m < self.z_max_m):
            raise ValueError(
                f"the five-bar needs z_min_m < z_max_m, got {self.z_min_m}, {self.z_max_m}"
            )
        object.__setattr__(self, "drives", drives)
        self._check_joint_limits()
        if self.masses is not None and not isinstance(self.masses, FiveBarMasses):
            raise ValueError(f"masses must be FiveBarMasses or None, got {self.masses!r}")
        tau = self.arm_torque_limit_nm
        if tau is not None and not (
            isinstance(tau, int | float) and math.isfinite(tau) and tau > 0
        ):
            raise ValueError(
                f"the five-bar's arm_torque_limit_nm must be a positive torque (N m at the "
                f"motor) or None, got {tau!r}"
            )
        homes = (self.home_theta1_rad, self.home_theta2_rad, self.home_z_m)
        windows = (*(self.limits.motor_window(m) for m in (1, 2)), (self.z_min_m, self.z_max_m))
        axes = tuple(
            Axis(d.name, d, float(h), w, s)
            for d, h, w, s in zip(drives, homes, windows, SWITCH_NAMES, strict=False)
        )
        object.__setattr__(self, "_axes", axes)

    def _check_joint_limits(self) -> None:
        for label in ("joint_speed_limits", "joint_accel_limits"):
            values = tuple(getattr(self, label))
            if len(values) != 3 or not all(
                isinstance(v, int | float) and math.isfinite(v) and v > 0 for v in values
            ):
                raise ValueError(
                    f"the five-bar's {label} must be 3 positive numbers (arm 1, arm 2, Z), "
                    f"got {values!r}"
                )
            object.__setattr__(self, label, tuple(float(v) for v in values))

    _shown_coordinates = 2  # the plane's x and y: Z has its own range check

    @property
    def axes(self) -> tuple[Axis, ...]:
        return self._axes

    @property
    def assemblies(self) -> tuple[str, str]:
        """FK assemblies, the one this mode's IK usually maps back first ('-+' lands in
        'down', the other modes mostly in 'up')."""
        return ("down", "up") if self.mode == "-+" else ("up", "down")

    # -- the seam --------------------------------------------------------------------
    def joints(self, xyz) -> np.ndarray:
        """(..., 3) theta1, theta2 (rad, IK in this mode; NaN if unreachable) and Z (m)."""
        xyz = np.asarray(xyz, dtype=np.float64)
        theta1, theta2 = self.planar_joints(xyz[..., 0], xyz[..., 1])
        return np.stack(np.broadcast_arrays(theta1, theta2, xyz[..., 2]), axis=-1)

    def point(self, joints) -> np.ndarray:
        """(..., 3) x, y (the FK assembly that maps back, see :meth:`planar_point`) and Z."""
        joints = np.asarray(joints, dtype=np.float64)
        x, y = self.planar_point(joints[..., 0], joints[..., 1])
        return np.stack(np.broadcast_arrays(x, y, joints[..., 2]), axis=-1).astype(np.float64)

    def check(self, xyz) -> ReachReport:
        """Per-point verdicts in the plane (Z's travel is :meth:`limit_target`'s): joints
        (N, 3) with the motor angles wrapped into their windows."""
        pts = as_points(xyz)
        report = check_points(self.geometry, self.limits, pts[:, 0], pts[:, 1], self.mode)
        return ReachReport(
            joints=np.column_stack([report.joints, pts[:, 2]]),
            ok=report.ok,
            refusals=report.refusals,
            diagnostics=report.diagnostics,
        )

    def limit_target(self, xyz) -> Refusal | None:
        """Z outside [z_min_m, z_max_m] by more than half a microstep of Z's drive (so a
        target that relative moves bring onto a limit in floating point is on it)."""
        z = float(np.asarray(xyz, dtype=np.float64)[2])
        tolerance = 0.5 * self.drives[2].unit_per_step
        if self.z_min_m - tolerance <= z <= self.z_max_m + tolerance:
            return None
        return Refusal(
            RefusalReason.AXIS_RANGE, "Z", z / M_PER_MM, self.z_min_m / M_PER_MM,
            self.z_max_m / M_PER_MM, "mm",
        )  # fmt: skip

    @property
    def lower_hard_limits(self) -> tuple[tuple[int, int], ...]:
        return ((2, 3),)  # limit switch 4 (Z down) stops Z going down

    def point_lines(self, report: ReachReport, i: int) -> list[str]:
        """The motor angles as the paper names them and the passive links' angle at C (Z
        passes straight to its lead screw)."""
        theta1, theta2, _ = (float(v) for v in report.joints[i])
        transmission = float(report.diagnostics["transmission"][i])
        return [
            f"theta1 = {math.degrees(theta1):.4f} deg",
            f"theta2 = {math.degrees(theta2):.4f} deg",
            f"passive-link (transmission) angle = {math.degrees(transmission):.4f} deg",
        ]

    @classmethod
    def from_scenario(cls, scenario) -> FiveBarKinematics:
        """The five-bar of a scenario's [arm], [limits] and [drives] sections."""
        arm, lim, drv = scenario.arm, scenario.limits, scenario.drives
        common = dict(
            steps_per_rev=drv.steps_per_rev,
            microsteps=drv.microsteps,
            max_step_rate_hz=drv.max_step_rate_hz,
            holding_torque_nm=drv.holding_torque_nm,
        )
        drives = (
            StepperDrive("arm1", ratio=drv.arm_belt_ratio, **common),
            StepperDrive("arm2", ratio=drv.arm_belt_ratio, **common),
            StepperDrive("z", ratio=1.0, lead_m=drv.z_lead_m, **common),
        )
        limits = KinematicLimits(
            motor1_min_rad=lim.motor1_min_rad,
            motor1_max_rad=lim.motor1_max_rad,
            motor2_min_rad=lim.motor2_min_rad,
            motor2_max_rad=lim.motor2_max_rad,
            elbow_min_rad=lim.elbow_min_rad,
            elbow_max_rad=lim.elbow_max_rad,
            transmission_min_rad=lim.transmission_min_rad,
            transmission_max_rad=lim.transmission_max_rad,
            max_condition=lim.max_condition,
        )
        return cls(
            geometry=FiveBarGeometry(l0_m=arm.l0_m, l1_m=arm.l1_m, l2_m=arm.l2_m),
            limits=limits,
            mode=arm.working_mode,
            drives=drives,
            home_theta1_rad=drv.switch1_theta1_rad,
            home_theta2_rad=drv.switch2_theta2_rad,
            home_z_m=drv.switch3_z_m,
            z_min_m=lim.z_min_m,
            z_max_m=lim.z_max_m,
            joint_speed_limits=(drv.arm_speed_limit_rad_s,) * 2 + (drv.z_speed_limit_m_s,),
            joint_accel_limits=(drv.arm_accel_limit_rad_s2,) * 2 + (drv.z_accel_limit_m_s2,),
            arm_torque_limit_nm=drv.arm_torque_limit_nm,
        )

    @classmethod
    def homing_from_scenario(cls, scenario) -> HomingConfig:
        """Z first, then both arms; the arms' and Z's seek and locate rates and the debounce
        of [drives]."""
        drv = scenario.drives
        return HomingConfig(
            rate_hz=(drv.homing_rate_arm_hz, drv.homing_rate_arm_hz, drv.homing_rate_z_hz),
            locate_rate_hz=(
                drv.homing_locate_rate_arm_hz,
                drv.homing_locate_rate_arm_hz,
                drv.homing_locate_rate_z_hz,
            ),
            dirs=(+1, -1, +1),
            first_cycle=(2,),
            debounce_s=drv.homing_debounce_s,
        )

    def describe(self) -> dict[str, float | str]:
        g = self.geometry
        return {"kind": self.kind, "l0_m": g.l0_m, "l1_m": g.l1_m, "l2_m": g.l2_m,
                "mode": self.mode}  # fmt: skip

    # -- the plane -------------------------------------------------------------------
    def planar_joints(self, x, y):
        """(theta1, theta2) in rad of points (x, y) in m: IK in this mode; NaN if unreachable."""
        return ik(self.geometry, x, y, self.mode)

    def _maps_back(self, theta1, theta2, x, y) -> np.ndarray:
        back1, back2 = (np.asarray(a) for a in self.planar_joints(x, y))
        with np.errstate(invalid="ignore"):
            return (np.abs(_wrap_pi(back1 - theta1)) < _SAME_ANGLE_RAD) & (
                np.abs(_wrap_pi(back2 - theta2)) < _SAME_ANGLE_RAD
            )

    def planar_point(self, theta1, theta2):
        """(x, y) in m at motor angles (rad): the FK assembly that :meth:`planar_joints` maps
        back to these angles; the first of :attr:`assemblies` where neither does (a pose of no
        single mode) or where both do. NaN where the links cannot close."""
        t1, t2 = _xy(theta1, theta2)
        first, second = self.assemblies
        x, y = (np.asarray(a) for a in fk(self.geometry, t1, t2, first))
        x2, y2 = (np.asarray(a) for a in fk(self.geometry, t1, t2, second))
        use_second = ~self._maps_back(t1, t2, x, y) & self._maps_back(t1, t2, x2, y2)
        return _out(np.where(use_second, x2, x)), _out(np.where(use_second, y2, y))

    def passive_angles(self, theta1, theta2):
        """Passive joint angles (phi1, phi2) in rad at motor angles (theta1, theta2).

        phi_i = direction of passive link i (elbow -> C, C from :meth:`planar_point`) minus
        theta_i, wrapped to (-pi, pi]. ValueError where the chain cannot close.
        """
        x, y = (np.asarray(a) for a in self.planar_point(theta1, theta2))
        if not (np.isfinite(x).all() and np.isfinite(y).all()):
            i = int(np.flatnonzero(~(np.isfinite(x) & np.isfinite(y)).ravel())[0])
            t1, t2 = (np.broadcast_to(a, x.shape).ravel()[i] for a in _xy(theta1, theta2))
            raise ValueError(
                f"five-bar cannot close at theta=({t1}, {t2}) rad: the elbows are more "
                f"than 2*l2 = {2 * self.geometry.l2_m} m apart (or coincide)"
            )
        t1, t2 = _xy(theta1, theta2)
        b, d = elbow_points(self.geometry, t1, t2)
        psi1 = np.arctan2(y - b[..., 1], x - b[..., 0])
        psi2 = np.arctan2(y - d[..., 1], x - d[..., 0])
        return _out(_wrap_pi(psi1 - t1)), _out(_wrap_pi(psi2 - t2))

    # -- the lumped dynamics -----------------------------------------------------------
    def belt_ratios(self) -> np.ndarray:
        """(2,) motor revolutions per arm revolution of arm 1 and arm 2 (the belts)."""
        return np.array([self.drives[0].ratio, self.drives[1].ratio], dtype=np.float64)

    def _require_masses(self) -> FiveBarMasses:
        if self.masses is None:
            raise ValueError(
                "this five-bar has no dynamics model (FiveBarKinematics.masses is None); the "
                "scenario's machine takes the MuJoCo model's (scenario.assemble)"
            )
        return self.masses

    def arm_inertia_kgm2(self) -> np.ndarray:
        """(2,) each arm's own inertia about its motor's axis, at the arm (kg m^2): the rotor
        through the belt (I_m N^2), the active link, and half a passive link at the elbow
        (m_p/2 l1^2)."""
        m = self._require_masses()
        n = self.belt_ratios()
        l1 = self.geometry.l1_m
        return m.rotor_inertia_kgm2 * n * n + m.active_link_kgm2 + 0.5 * m.passive_link_kg * l1 * l1

    def end_effector_kg(self) -> float:
        """The mass lumped at C (kg): what the jaws carry (:attr:`FiveBarMasses.end_effector_kg`)
        and half of each passive link."""
        m = self._require_masses()
        return m.end_effector_kg + m.passive_link_kg

    def end_effector_motion(self, joints, speeds, accels):
        """(C, Cdot, Cddot), each (..., 2) in m, m/s, m/s^2, of the end effector C at arm
        angles (theta1, theta2) (rad), speeds (rad/s) and accelerations (rad/s^2), exactly:
        Cdot = J qdot, and from the second derivative of |C - B|^2 = |C - D|^2 = l2^2,
        (C - B) . Cddot = (C - B) . Bddot - |Cdot - Bdot|^2 (likewise for D), with
        Bddot = l1 (-sin, cos) qddot_1 - l1 (cos, sin) qdot_1^2: J qddot + Jdot qdot without a
        finite difference. NaN where the chain cannot close."""
        c, cd, cdd, _ = self._end_effector_motion(joints, speeds, accels)
        return c, cd, cdd

    def _end_effector_motion(self, joints, speeds, accels):
        q, qd, qdd = np.broadcast_arrays(
            *(np.asarray(v, dtype=np.float64) for v in (joints, speeds, accels))
        )
        t1, t2 = q[..., 0], q[..., 1]
        x, y = (np.asarray(a, dtype=np.float64) for a in self.planar_point(t1, t2))
        c = np.stack(np.broadcast_arrays(x, y), axis=-1)
        jac = jacobian(self.geometry, t1, t2, x, y)
        cd = np.einsum("...ij,...j->...i", jac, qd)
        l1 = self.geometry.l1_m
        rows, rhs = [], []
        for k, elbow in enumerate(elbow_points(self.geometry, t1, t2)):
            th, w, a = q[..., k], qd[..., k], qdd[..., k]
            radial = np.stack([np.cos(th), np.sin(th)], axis=-1) * l1  # elbow - motor
            tangent = np.stack([-np.sin(th), np.cos(th)], axis=-1) * l1
            elbow_a = tangent * a[..., None] - radial * (w * w)[..., None]
            r = c - elbow
            rel = cd - tangent * w[..., None]
            rows.append(r)
            rhs.append(np.sum(r * elbow_a, axis=-1) - np.sum(rel * rel, axis=-1))
        (a11, a12), (a21, a22) = (np.moveaxis(r, -1, 0) for r in rows)
        with np.errstate(divide="ignore", invalid="ignore"):
            det = a11 * a22 - a12 * a21
            cdd = np.stack(
                [(a22 * rhs[0] - a12 * rhs[1]) / det, (a11 * rhs[1] - a21 * rhs[0]) / det],
                axis=-1,
            )
        return c, cd, cdd, jac

    def inverse_dynamics(self, joints, speeds, accels) -> np.ndarray:
        """(..., 2) each arm motor's torque (N m at the motor shaft, positive turning its arm
        counter-clockwise) that drives the arms along (theta1, theta2) at these speeds and
        accelerations: the lumped model tau_arm = I_a qddot + J^T m_C Cddot (I_a:
        :meth:`arm_inertia_kgm2`; m_C: :meth:`end_effector_kg` at C; Cddot:
        :meth:`end_effector_motion`), at the motor tau_arm / N (N the belt ratio). The arms
        turn in a horizontal plane (the motors' axes are vertical, as in the MuJoCo model),
        so gravity loads Z only: no static term, and a motion stretched in time by s needs
        exactly 1/s^2 of the torque. Its work over a move from rest to rest is 0 (Lagrange's
        equation of the lumped model: no potential energy in the plane)."""
        _, _, cdd, jac = self._end_effector_motion(joints, speeds, accels)
        qdd = np.broadcast_to(np.asarray(accels, dtype=np.float64), cdd.shape)
        arm = self.arm_inertia_kgm2() * qdd + self.end_effector_kg() * np.einsum(
            "...ji,...j->...i", jac, cdd
        )
        return arm / self.belt_ratios()
