"""Rotary delta (3-RSS with parallelogram followers) kinematics of the seedling-replenishing
robot of Zhao, Cheng, Dong, Ma, Xiong and Tong, "Research on the End Effector and Optimal
Motion Control Strategy for a Plug Seedling Transplanting Parallel Robot" (Agriculture 2022,
12(10), 1661), Sec. 2.3, Eq. 2-6, with the minus signs the published text lost restored.

Frame (the paper's): origin O at the centre of the static platform (the base), Z up, the moving
platform below the base (Z < 0). Arm i's actuated joint A_i sits at radius R on the direction
phi_i = 0, 120, 240 deg from +X; its hinge axis is horizontal and tangential. The active arm
A_iB_i (length l1) makes the angle q_i with the base plane, **positive downwards**; the follower
B_iC_i (length l2, a parallelogram the paper simplifies to one rod) ends at C_i on the moving
platform at radius r on the same direction phi_i. The parallelograms keep the platform parallel
to the base, so its centre (X, Y, Z) is the whole pose:

    B_i = ((R + l1 cos q_i) cos phi_i, (R + l1 cos q_i) sin phi_i, -l1 sin q_i)
    C_i = (X + r cos phi_i, Y + r sin phi_i, Z),   |B_i - C_i| = l2          (Eq. 3)

IK (Eq. 4): a sin q + b cos q = c with
    a = 2 l1 Z,
    b = 2 (R - r) l1 - 2 X l1 cos phi - 2 Y l1 sin phi,
    c = l2^2 + 2 (R - r)(X cos phi + Y sin phi) - (R - r)^2 - l1^2 - X^2 - Y^2 - Z^2,
so with t = tan(q/2): (b + c) t^2 - 2 a t + (c - b) = 0 and
    q = 2 arctan[(a +- sqrt(a^2 + b^2 - c^2)) / (b + c)];
the root taken is the knee-out one (elbow B outside, larger cos q, smaller |t|), evaluated in
the cancellation-free form of the quadratic formula. Reachable iff a^2 + b^2 - c^2 >= 0.

FK (not in the paper): C_i - r e_i = (X, Y, Z) lies on the sphere of radius l2 about
P_i = B_i - r e_i; the three spheres are intersected in closed form (trilateration) and the
lower of the two points is the platform.

Jacobian (Eq. 5-6): with s_i = C_i - B_i and b_i = dB_i/dq_i,
s_i . Xdot = (s_i . b_i) qdot_i, so Xdot = J qdot, J = [s_1; s_2; s_3]^-1 diag(s_i . b_i).

Everything is vectorised over numpy arrays and in SI units (m, rad). The dimensions, joint
window, masses and drive numbers the paper does not give are estimates (docs/delta.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from transplanter.errors import Refusal, RefusalReason
from transplanter.machine.axes import Axis
from transplanter.machine.homing import HomingConfig
from transplanter.machine.kinematics.base import Kinematics, ReachReport, as_points
from transplanter.machine.steppers import StepperDrive
from transplanter.units import M_PER_MM

__all__ = [
    "ARM_ANGLES_RAD",
    "DeltaGeometry",
    "DeltaKinematics",
    "DeltaLimits",
    "DeltaMasses",
    "elbow_points",
    "fk",
    "ik",
    "jacobian",
]

ARM_ANGLES_RAD = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)
"""phi_i: the direction of arm i's actuated joint from +X (0, 120, 240 deg)."""


def _positive(owner: str, name: str, value) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise ValueError(f"{owner}.{name} must be a positive number, got {value!r}")


@dataclass(frozen=True)
class DeltaGeometry:
    """The delta's four lengths (estimates: the paper gives none, see docs/delta.md)."""

    base_radius_m: float = 0.200
    """R: circumradius of the static platform, centre O to each actuated joint A_i."""
    platform_radius_m: float = 0.050
    """r: circumradius of the moving platform, its centre to each follower's end C_i."""
    upper_arm_m: float = 0.350
    """l1: active arm A_iB_i."""
    forearm_m: float = 0.800
    """l2: follower (parallelogram) B_iC_i."""

    def __post_init__(self) -> None:
        for name in ("base_radius_m", "platform_radius_m", "upper_arm_m", "forearm_m"):
            _positive("DeltaGeometry", name, getattr(self, name))
        if self.platform_radius_m >= self.base_radius_m:
            raise ValueError(
                "DeltaGeometry needs platform_radius_m < base_radius_m (the followers slope "
                f"inwards), got r = {self.platform_radius_m} m, R = {self.base_radius_m} m"
            )

    @property
    def offset_m(self) -> float:
        """R - r: how far each arm's joint lies outside the platform's follower end."""
        return self.base_radius_m - self.platform_radius_m


@dataclass(frozen=True)
class DeltaLimits:
    """What a commanded point must satisfy besides closing the chains."""

    q_min_rad: float = math.radians(-40.0)
    """Lowest arm angle (arm raised 40 deg above the base plane); the IRB 360 class window."""
    q_max_rad: float = math.radians(80.0)
    """Highest arm angle (80 deg below the base plane)."""
    max_condition: float = 20.0
    """Largest 2-norm condition number of the Jacobian (1 = isotropic)."""
    z_min_m: float = -1.050
    """Lowest platform-centre Z a move may target (the machine's Cartesian range)."""
    z_max_m: float = -0.500
    """Highest platform-centre Z a move may target."""

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if not (isinstance(value, int | float) and math.isfinite(value)):
                raise ValueError(f"DeltaLimits.{name} must be a finite number, got {value!r}")
        if not -math.pi / 2 <= self.q_min_rad < self.q_max_rad <= math.pi / 2:
            raise ValueError(
                "DeltaLimits needs -90 deg <= q_min < q_max <= 90 deg, got "
                f"[{math.degrees(self.q_min_rad):g}, {math.degrees(self.q_max_rad):g}] deg"
            )
        if self.max_condition < 1.0:
            raise ValueError(f"DeltaLimits.max_condition must be >= 1, got {self.max_condition}")
        if not self.z_min_m < self.z_max_m:
            raise ValueError(
                f"DeltaLimits needs z_min_m < z_max_m, got {self.z_min_m}, {self.z_max_m}"
            )


@dataclass(frozen=True)
class DeltaMasses:
    """The lumped masses of the paper's dynamic model (Eq. 7-9); the paper gives no values,
    these are estimates (docs/delta.md)."""

    upper_arm_kg: float = 0.30
    """m_a: one active arm (carbon tube with its hub)."""
    elbow_kg: float = 0.05
    """m_b: the spherical hinges at one elbow."""
    forearm_kg: float = 0.20
    """m_c: one follower parallelogram (both rods and their cross pieces)."""
    platform_kg: float = 1.00
    """m_move: moving platform with the end effector, its cylinders and a seedling."""
    rotor_inertia_kgm2: float = 1.5e-4
    """I_m: servo motor rotor inertia, at the motor shaft."""

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            _positive("DeltaMasses", name, value)


def _xyz(xyz) -> np.ndarray:
    return np.asarray(xyz, dtype=np.float64)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis (3), without np.cross's overhead on small batches."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _directions() -> tuple[np.ndarray, np.ndarray]:
    """(cos phi_i, sin phi_i) of the three arms."""
    phi = np.asarray(ARM_ANGLES_RAD)
    return np.cos(phi), np.sin(phi)


def ik(geom: DeltaGeometry, xyz) -> np.ndarray:
    """(..., 3) arm angles q_i (rad, knee-out branch) of (..., 3) platform centres (m) by the
    paper's Eq. 4; NaN for an arm whose chain cannot close."""
    p = _xyz(xyz)
    x, y, z = (p[..., k, None] for k in range(3))
    cos_phi, sin_phi = _directions()
    l1, l2, d = geom.upper_arm_m, geom.forearm_m, geom.offset_m
    radial = x * cos_phi + y * sin_phi
    a = 2.0 * l1 * z + 0.0 * radial
    b = 2.0 * d * l1 - 2.0 * l1 * radial
    c = l2 * l2 + 2.0 * d * radial - d * d - l1 * l1 - x * x - y * y - z * z
    with np.errstate(invalid="ignore", divide="ignore"):
        root = np.sqrt(a * a + b * b - c * c)  # NaN where the chain cannot close
        # The roots are t = (a +- root) / (b + c) = (c - b) / (a -+ root) (their product is
        # (c - b) / (b + c)). The knee-out one has the smaller |t|: (a - s root) / (b + c) with
        # s the sign of a, written (c - b) / (a + s root), whose denominator never cancels.
        # a + s root = 0 only where a = root = 0, c = b: then t = 0 is the double root.
        s = np.where(a >= 0.0, 1.0, -1.0)
        big = a + s * root
        t = np.where(big != 0.0, (c - b) / np.where(big != 0.0, big, 1.0), 0.0)
        q = 2.0 * np.arctan(t)
    return np.where(np.isfinite(root), q, np.nan)


def ik_both(geom: DeltaGeometry, xyz) -> tuple[np.ndarray, np.ndarray]:
    """Both roots of Eq. 4 as printed, q = 2 arctan[(a +- sqrt(a^2 + b^2 - c^2)) / (b + c)]:
    (plus, minus), each (..., 3) in rad, NaN where unreachable (or where b + c = 0)."""
    p = _xyz(xyz)
    x, y, z = (p[..., k, None] for k in range(3))
    cos_phi, sin_phi = _directions()
    l1, l2, d = geom.upper_arm_m, geom.forearm_m, geom.offset_m
    radial = x * cos_phi + y * sin_phi
    a = 2.0 * l1 * z
    b = 2.0 * d * l1 - 2.0 * l1 * radial
    c = l2 * l2 + 2.0 * d * radial - d * d - l1 * l1 - x * x - y * y - z * z
    with np.errstate(invalid="ignore", divide="ignore"):
        root = np.sqrt(a * a + b * b - c * c)
        plus = 2.0 * np.arctan((a + root) / (b + c))
        minus = 2.0 * np.arctan((a - root) / (b + c))
    return plus, minus


def elbow_points(geom: DeltaGeometry, q) -> np.ndarray:
    """(..., 3, 3) elbows B_i (rows i) of (..., 3) arm angles, in m."""
    q = _xyz(q)
    cos_phi, sin_phi = _directions()
    reach = geom.base_radius_m + geom.upper_arm_m * np.cos(q)
    return np.stack([reach * cos_phi, reach * sin_phi, -geom.upper_arm_m * np.sin(q)], axis=-1)


def _follower_terms(geom: DeltaGeometry, q, xyz) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(s, b, b'), each (..., 3, 3) over the arms i: the follower s_i = C_i - B_i (platform
    joint minus elbow) at arm angles q and platform centre xyz, and the elbow's first and
    second derivatives b_i = dB_i/dq_i, b'_i = d^2B_i/dq_i^2 (what the platform's motion and
    the dynamics are written in)."""
    cos_phi, sin_phi = _directions()
    e = np.stack([cos_phi, sin_phi, np.zeros(3)], axis=-1)
    s = xyz[..., None, :] + geom.platform_radius_m * e - elbow_points(geom, q)
    l1, sq, cq = geom.upper_arm_m, np.sin(q), np.cos(q)
    b = np.stack([-l1 * sq * cos_phi, -l1 * sq * sin_phi, -l1 * cq], axis=-1)
    b2 = np.stack([-l1 * cq * cos_phi, -l1 * cq * sin_phi, l1 * sq], axis=-1)
    return s, b, b2


def fk(geom: DeltaGeometry, q) -> np.ndarray:
    """(..., 3) platform centre (m) of (..., 3) arm angles (rad): the lower intersection of
    the three spheres of radius l2 about B_i - r e_i; NaN where they do not meet."""
    cos_phi, sin_phi = _directions()
    e = np.stack([cos_phi, sin_phi, np.zeros(3)], axis=-1)
    centres = elbow_points(geom, q) - geom.platform_radius_m * e
    p1, p2, p3 = centres[..., 0, :], centres[..., 1, :], centres[..., 2, :]
    r2 = geom.forearm_m**2
    with np.errstate(invalid="ignore", divide="ignore"):
        d12 = p2 - p1
        dist = np.linalg.norm(d12, axis=-1, keepdims=True)
        ex = d12 / dist
        d13 = p3 - p1
        i = np.sum(ex * d13, axis=-1, keepdims=True)
        ey_raw = d13 - i * ex
        ey = ey_raw / np.linalg.norm(ey_raw, axis=-1, keepdims=True)
        ez = np.cross(ex, ey)
        j = np.sum(ey * d13, axis=-1, keepdims=True)
        # equal radii: the radical planes give u = d/2 and v = (i^2 + j^2 - 2 i u) / (2 j)
        u = 0.5 * dist
        v = (i * i + j * j - 2.0 * i * u) / (2.0 * j)
        h = np.sqrt(r2 - u * u - v * v)  # NaN where the spheres do not meet
        foot = p1 + u * ex + v * ey
        low = np.where(ez[..., 2:3] > 0.0, -1.0, 1.0)  # the intersection below
        return foot + low * h * ez


def jacobian(geom: DeltaGeometry, q, xyz) -> np.ndarray:
    """(..., 3, 3) J = dX/dq at arm angles q (rad) and platform centre xyz (m) (Eq. 5-6):
    J = S^-1 diag(s_i . b_i), rows of S the followers s_i = C_i - B_i, b_i = dB_i/dq_i.
    Infinite or NaN at a parallel singularity (S singular)."""
    q, p = np.broadcast_arrays(_xyz(q), _xyz(xyz))
    cos_phi, sin_phi = _directions()
    e = np.stack([cos_phi, sin_phi, np.zeros(3)], axis=-1)
    s = p[..., None, :] + geom.platform_radius_m * e - elbow_points(geom, q)
    l1 = geom.upper_arm_m
    db = np.stack([-l1 * np.sin(q) * cos_phi, -l1 * np.sin(q) * sin_phi, -l1 * np.cos(q)], axis=-1)
    diag = np.sum(s * db, axis=-1)  # (..., 3)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        det = np.linalg.det(s)
        safe = np.where((np.abs(det) > 0.0)[..., None, None], s, np.eye(3))
        inv = np.linalg.inv(safe)
        jac = inv * diag[..., None, :]
        return np.where((np.abs(det) > 0.0)[..., None, None], jac, np.inf)


def condition_number(jac: np.ndarray) -> np.ndarray:
    """2-norm condition number of (..., 3, 3) matrices; inf where singular or not finite."""
    jac = np.asarray(jac, dtype=np.float64)
    finite = np.isfinite(jac).all(axis=(-2, -1))
    safe = np.where(finite[..., None, None], jac, np.eye(3))
    sv = np.linalg.svd(safe, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        cond = sv[..., 0] / sv[..., -1]
    return np.where(finite & np.isfinite(cond), cond, np.inf)


def arm_reach(geom: DeltaGeometry, xyz) -> tuple[np.ndarray, np.ndarray]:
    """(nearest, farthest) distance (..., 3) in m from each follower's platform end C_i to
    the circle its elbow B_i can sweep (radius l1 about A_i in the arm's vertical plane). Arm
    i closes iff nearest <= l2 <= farthest."""
    p = _xyz(xyz)
    cos_phi, sin_phi = _directions()
    x, y, z = (p[..., k, None] for k in range(3))
    radial = x * cos_phi + y * sin_phi - geom.offset_m  # C_i - A_i along e_i
    tangential = -x * sin_phi + y * cos_phi
    in_plane = np.hypot(radial, z + 0.0 * radial)
    l1 = geom.upper_arm_m
    return np.hypot(tangential, in_plane - l1), np.hypot(tangential, in_plane + l1)


_FINITE = np.finfo(np.float64).max


@dataclass(frozen=True)
class DeltaKinematics(Kinematics):
    """The rotary delta: three servo-driven arms (rotary axes q1, q2, q3, rad) and a platform
    kept parallel to the base; IK, FK, Jacobian, pulse counters and limits, vectorised.
    Points are platform centres in m in the base frame (Z up, the platform at Z < 0)."""

    kind = "delta"
    coordinates = ("X", "Y", "Z")

    geometry: DeltaGeometry = field(default_factory=DeltaGeometry)
    limits: DeltaLimits = field(default_factory=DeltaLimits)
    masses: DeltaMasses = field(default_factory=DeltaMasses)
    drives: tuple[StepperDrive, ...] = (
        StepperDrive("q1", steps_per_rev=2000, microsteps=1, ratio=25.0,
                     max_step_rate_hz=100000.0, holding_torque_nm=0.48),
        StepperDrive("q2", steps_per_rev=2000, microsteps=1, ratio=25.0,
                     max_step_rate_hz=100000.0, holding_torque_nm=0.48),
        StepperDrive("q3", steps_per_rev=2000, microsteps=1, ratio=25.0,
                     max_step_rate_hz=100000.0, holding_torque_nm=0.48),
    )  # fmt: skip
    """(q1, q2, q3) servo drives as pulse-train axes: 2000 command pulses per motor
    revolution (the drive's electronic gear) through a 25:1 reducer; 100 kHz of pulses is
    720 deg/s at the joint; the drive's torque limit 0.48 N m at the motor is 12 N m at the
    joint (a plain default: it shadows the base class's property)."""
    home_q_rad: float = math.radians(-30.0)
    """Arm angle at which each arm's homing switch trips (arms raised)."""
    max_joint_speed_rad_s: float = math.radians(720.0)
    """V_max of the paper (Sec. 2.4)."""
    max_joint_accel_rad_s2: float = math.radians(2500.0)
    """A_max of the paper (Sec. 2.4)."""
    joint_torque_limit_nm: float = 12.0
    """tau_max of the paper (Sec. 2.4), at the joint."""

    def __post_init__(self) -> None:
        for name, cls in (("geometry", DeltaGeometry), ("limits", DeltaLimits),
                          ("masses", DeltaMasses)):  # fmt: skip
            if not isinstance(getattr(self, name), cls):
                raise ValueError(f"{name} must be a {cls.__name__}, got {getattr(self, name)!r}")
        drives = tuple(self.drives)
        if len(drives) != 3 or not all(isinstance(d, StepperDrive) for d in drives):
            raise ValueError("the delta's drives must be 3 StepperDrive (q1, q2, q3)")
        if any(d.linear for d in drives):
            raise ValueError("the delta's drives must all be rotary (lead_m None)")
        for name in ("max_joint_speed_rad_s", "max_joint_accel_rad_s2", "joint_torque_limit_nm"):
            _positive("DeltaKinematics", name, getattr(self, name))
        lim = self.limits
        if not lim.q_min_rad <= self.home_q_rad <= lim.q_max_rad:
            raise ValueError(
                f"the delta's homing angle {math.degrees(self.home_q_rad):g} deg lies outside "
                f"its joint window [{math.degrees(lim.q_min_rad):g}, "
                f"{math.degrees(lim.q_max_rad):g}] deg"
            )
        object.__setattr__(self, "drives", drives)
        window = (lim.q_min_rad, lim.q_max_rad)
        axes = tuple(
            Axis(d.name, d, float(self.home_q_rad), window, f"arm {i} home")
            for i, d in enumerate(drives, start=1)
        )
        object.__setattr__(self, "_axes", axes)

    @property
    def axes(self) -> tuple[Axis, ...]:
        return self._axes

    # -- the seam --------------------------------------------------------------------
    def joints(self, xyz) -> np.ndarray:
        """(..., 3) arm angles q1..q3 (rad, knee-out, Eq. 4); NaN where a chain cannot close
        (joint limits are :meth:`check`'s)."""
        return ik(self.geometry, xyz)

    def point(self, joints) -> np.ndarray:
        """(..., 3) platform centre (m) of arm angles (rad), by trilateration; NaN where the
        followers cannot meet."""
        return fk(self.geometry, joints)

    def jacobian(self, joints, xyz=None) -> np.ndarray:
        """(..., 3, 3) dX/dq at arm angles (rad) (and the platform centre there, FK if None)."""
        joints = _xyz(joints)
        if xyz is None:
            xyz = self.point(joints)
        return jacobian(self.geometry, joints, xyz)

    def _lumped_kg(self) -> tuple[float, float, float]:
        """Eq. 9's lumped masses (kg): m_movet = m_move + m_c (what the platform's
        acceleration moves), m_moveg = m_move + 3/2 m_c (the weight on it) and the arm's
        share of G_ag, m_a/2 + m_b + m_c/2."""
        m = self.masses
        return (
            m.platform_kg + m.forearm_kg,
            m.platform_kg + 1.5 * m.forearm_kg,
            0.5 * m.upper_arm_kg + m.elbow_kg + 0.5 * m.forearm_kg,
        )

    def gravity_torques(self, joints, g_m_s2: float = 9.81) -> np.ndarray:
        """(..., 3) joint torques (N m, positive lowering the arm) that hold the arms still
        against gravity at arm angles q: the static part of the paper's Eq. 9,
        tau = J^T m_moveg [0 0 g]^T - G_ag, G_ag = l1 (m_a/2 + m_b + m_c/2) g cos q,
        m_moveg = m_move + 3/2 m_c (half of each follower's weight at its elbow, half at the
        platform, which is exact for a uniform rod)."""
        q = _xyz(joints)
        _, m_moveg, arm = self._lumped_kg()
        dz_dq = self.jacobian(q)[..., 2, :]  # row Z of J
        g_ag = self.geometry.upper_arm_m * arm * g_m_s2 * np.cos(q)
        return m_moveg * g_m_s2 * dz_dq - g_ag

    def platform_motion(self, joints, speeds, accels) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(X, Xdot, Xddot), each (..., 3) in m, m/s, m/s^2, of the platform centre at arm
        angles q (rad), speeds qdot (rad/s) and accelerations qddot (rad/s^2), exactly:
        Xdot = J qdot, and from the second derivative of |s_i|^2 = l2^2 (s_i = C_i - B_i),
        s_i . Xddot = (s_i . b_i) qddot_i + (s_i . b'_i) qdot_i^2 - |Xdot - b_i qdot_i|^2,
        with b_i = dB_i/dq_i and b'_i = d^2B_i/dq_i^2 (the paper's J qddot + Jdot qdot)."""
        q, qd, qdd = np.broadcast_arrays(_xyz(joints), _xyz(speeds), _xyz(accels))
        g = self.geometry
        xyz = fk(g, q)
        s, b, b2 = _follower_terms(g, q, xyz)
        jac = jacobian(g, q, xyz)
        xd = np.einsum("...ij,...j->...i", jac, qd)
        rel = xd[..., None, :] - b * qd[..., None]
        rhs = (
            np.sum(s * b, axis=-1) * qdd
            + np.sum(s * b2, axis=-1) * qd * qd
            - np.sum(rel * rel, axis=-1)
        )
        xdd = np.linalg.solve(s, rhs[..., None])[..., 0]
        return xyz, xd, xdd

    def arm_inertia_kgm2(self) -> np.ndarray:
        """(3,) I_at,i of Eq. 9 at the joint: the rotor's inertia through the reducer,
        I_m N^2, plus l1^2 (m_a/3 + m_b + 2/3 m_c) (the arm as a uniform rod about its joint,
        the elbow's hinges and two-thirds of the follower at the elbow)."""
        m, l1 = self.masses, self.geometry.upper_arm_m
        arm = l1 * l1 * (m.upper_arm_kg / 3.0 + m.elbow_kg + 2.0 * m.forearm_kg / 3.0)
        ratios = np.array([d.ratio for d in self.drives], dtype=np.float64)
        return m.rotor_inertia_kgm2 * ratios * ratios + arm

    def inverse_dynamics(self, joints, speeds, accels, g_m_s2: float = 9.81) -> np.ndarray:
        """(..., 3) joint torques (N m, positive lowering the arm) of the paper's Eq. 7-9
        (the simplified virtual-work model, signs restored as docs/delta.md gives them):
        tau = I_at qddot + J^T (m_movet Xddot + m_moveg g e_z) - G_ag,
        m_movet = m_move + m_c, m_moveg = m_move + 3/2 m_c, G_ag = l1 (m_a/2 + m_b + m_c/2)
        g cos q; J^T m_movet Xddot is Eq. 9's (J^T m_movet J) qddot + J^T m_movet Jdot qdot.
        At rest it is :meth:`gravity_torques`."""
        q = _xyz(joints)
        xyz, _, xdd = self.platform_motion(q, speeds, accels)
        jac = jacobian(self.geometry, q, xyz)
        m_movet, m_moveg, arm = self._lumped_kg()
        force = m_movet * xdd
        force[..., 2] += m_moveg * g_m_s2
        g_ag = self.geometry.upper_arm_m * arm * g_m_s2 * np.cos(q)
        qdd = np.broadcast_to(_xyz(accels), force.shape)
        return self.arm_inertia_kgm2() * qdd + np.einsum("...ji,...j->...i", jac, force) - g_ag

    def torque_split(
        self, joints, speeds, accels, g_m_s2: float = 9.81
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(dynamic, gravity, Xddot), each (..., 3), in one pass over FK and the Jacobian:
        :meth:`inverse_dynamics` = dynamic + gravity, gravity = :meth:`gravity_torques`
        (the J^T m_moveg g e_z - G_ag part), dynamic = I_at qddot + J^T m_movet Xddot
        (scales as 1/s^2 when a motion is stretched by s), Xddot as :meth:`platform_motion`.
        What the planner's search evaluates (the same formulas, about a third of the work of
        calling the three methods)."""
        q, qd, qdd = np.broadcast_arrays(_xyz(joints), _xyz(speeds), _xyz(accels))
        g = self.geometry
        xyz = fk(g, q)
        s, b, b2 = _follower_terms(g, q, xyz)
        l1, cq = g.upper_arm_m, np.cos(q)
        sb = np.sum(s * b, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            # S^-1 by cofactors: its columns are s_1 x s_2, s_2 x s_0, s_0 x s_1 over det S
            s0, s1, s2 = s[..., 0, :], s[..., 1, :], s[..., 2, :]
            cof = np.stack([_cross(s1, s2), _cross(s2, s0), _cross(s0, s1)], axis=-1)
            det = np.sum(s0 * cof[..., 0], axis=-1)
            regular = (np.abs(det) > 0.0)[..., None, None]
            inv = cof / np.where(regular, det[..., None, None], 1.0)
            jac = np.where(regular, inv * sb[..., None, :], np.inf)
            xd = np.einsum("...ij,...j->...i", jac, qd)
            rel = xd[..., None, :] - b * qd[..., None]
            rhs = sb * qdd + np.sum(s * b2, axis=-1) * qd * qd - np.sum(rel * rel, axis=-1)
            xdd = np.where(regular[..., 0], np.einsum("...ij,...j->...i", inv, rhs), np.nan)
            m_movet, m_moveg, arm = self._lumped_kg()
            gravity = m_moveg * g_m_s2 * jac[..., 2, :] - l1 * arm * g_m_s2 * cq
            dynamic = self.arm_inertia_kgm2() * qdd + m_movet * np.einsum(
                "...ji,...j->...i", jac, xdd
            )
        return dynamic, gravity, xdd

    def check(self, xyz) -> ReachReport:
        """Per-point verdicts: each arm's chain closes (typed OUT_OF_WORKSPACE with the
        follower's reach), each arm angle in [q_min, q_max] (JOINT_LIMIT naming q_i), the
        Jacobian's condition (ILL_CONDITIONED). Diagnostics: ``condition``."""
        pts = as_points(xyz)
        finite = np.isfinite(pts).all(axis=1)
        safe = np.where(finite[:, None], pts, 0.0)
        q = ik(self.geometry, safe)
        reach = np.isfinite(q).all(axis=1) & finite
        q = np.where(finite[:, None], q, np.nan)
        jac = jacobian(self.geometry, np.where(reach[:, None], q, 0.0), safe)
        cond = np.where(reach, condition_number(jac), np.inf)
        lim = self.limits
        with np.errstate(invalid="ignore"):
            outside = reach[:, None] & ((q < lim.q_min_rad) | (q > lim.q_max_rad))
        ill = reach & ~(cond <= lim.max_condition)
        ok = reach & ~outside.any(axis=1) & ~ill
        nearest, farthest = arm_reach(self.geometry, safe)
        refusals: list[tuple[Refusal, ...]] = [()] * len(pts)
        for n in np.flatnonzero(~ok):
            refusals[n] = self._refusals(
                finite[n], reach[n], q[n], outside[n], ill[n], cond[n], nearest[n], farthest[n]
            )
        return ReachReport(joints=q, ok=ok, refusals=tuple(refusals),
                           diagnostics={"condition": cond})  # fmt: skip

    def _refusals(self, finite, reach, q, outside, ill, cond, nearest, farthest):
        if not finite:
            return (Refusal(RefusalReason.NOT_FINITE, "coordinates"),)
        l2 = self.geometry.forearm_m
        out: list[Refusal] = []
        if not reach:
            for i in range(3):
                if nearest[i] > l2:
                    out.append(
                        Refusal(
                            RefusalReason.OUT_OF_WORKSPACE,
                            f"arm {i + 1}: distance from C{i + 1} to its elbow circle",
                            nearest[i] / M_PER_MM, None, l2 / M_PER_MM, "mm",
                            bound_names=("", "L2"), label=f"arm {i + 1}",
                        )
                    )  # fmt: skip
                elif farthest[i] < l2:
                    out.append(
                        Refusal(
                            RefusalReason.OUT_OF_WORKSPACE,
                            f"arm {i + 1}: farthest distance from C{i + 1} to its elbow circle",
                            farthest[i] / M_PER_MM, l2 / M_PER_MM, None, "mm",
                            bound_names=("L2", ""), label=f"arm {i + 1}",
                        )
                    )  # fmt: skip
            return tuple(out)
        lim = self.limits
        for i in range(3):
            if outside[i]:
                out.append(
                    Refusal(
                        RefusalReason.JOINT_LIMIT, f"arm {i + 1} angle q{i + 1}",
                        math.degrees(q[i]), math.degrees(lim.q_min_rad),
                        math.degrees(lim.q_max_rad), "deg", label=f"q{i + 1}",
                    )
                )  # fmt: skip
        if ill:
            out.append(
                Refusal(
                    RefusalReason.ILL_CONDITIONED, "Jacobian condition",
                    float(min(cond, _FINITE)), None, lim.max_condition,
                )
            )  # fmt: skip
        return tuple(out)

    def limit_target(self, xyz) -> Refusal | None:
        """Z of the platform centre outside [z_min_m, z_max_m] (the machine's Cartesian
        range), by more than half a pulse's worth of platform travel (1e-6 m)."""
        z = float(np.asarray(xyz, dtype=np.float64)[2])
        lim = self.limits
        if lim.z_min_m - 1e-6 <= z <= lim.z_max_m + 1e-6:
            return None
        return Refusal(
            RefusalReason.AXIS_RANGE, "Z", z / M_PER_MM, lim.z_min_m / M_PER_MM,
            lim.z_max_m / M_PER_MM, "mm",
        )  # fmt: skip

    def point_lines(self, report: ReachReport, i: int) -> list[str]:
        """The arm angles as the paper names them (below the base plane positive) and the
        Jacobian's condition number."""
        lines = [
            f"q{m} = {math.degrees(float(v)):.4f} deg" for m, v in enumerate(report.joints[i], 1)
        ]
        lines.append(f"Jacobian condition = {float(report.diagnostics['condition'][i]):.3f}")
        return lines

    def describe(self) -> dict[str, float | str]:
        g = self.geometry
        return {
            "kind": self.kind,
            "base_radius_m": g.base_radius_m,
            "platform_radius_m": g.platform_radius_m,
            "upper_arm_m": g.upper_arm_m,
            "forearm_m": g.forearm_m,
        }

    @classmethod
    def from_scenario(cls, scenario) -> DeltaKinematics:
        """The delta of a scenario's [delta] section (the only reader of that section)."""
        d = scenario.delta
        pulse_rate_hz = d.max_joint_speed_rad_s / (2.0 * math.pi) * d.gear_ratio * d.pulses_per_rev
        drives = tuple(
            StepperDrive(
                f"q{i}",
                steps_per_rev=d.pulses_per_rev,
                microsteps=1,
                ratio=d.gear_ratio,
                max_step_rate_hz=pulse_rate_hz,
                holding_torque_nm=d.joint_torque_limit_nm / d.gear_ratio,
            )
            for i in (1, 2, 3)
        )
        return cls(
            geometry=DeltaGeometry(
                base_radius_m=d.base_radius_m,
                platform_radius_m=d.platform_radius_m,
                upper_arm_m=d.upper_arm_m,
                forearm_m=d.forearm_m,
            ),
            limits=DeltaLimits(
                q_min_rad=d.q_min_rad,
                q_max_rad=d.q_max_rad,
                max_condition=d.max_condition,
                z_min_m=d.z_min_m,
                z_max_m=d.z_max_m,
            ),
            masses=DeltaMasses(
                upper_arm_kg=d.upper_arm_mass_kg,
                elbow_kg=d.elbow_mass_kg,
                forearm_kg=d.forearm_mass_kg,
                platform_kg=d.platform_mass_kg,
                rotor_inertia_kgm2=d.rotor_inertia_kgm2,
            ),
            drives=drives,
            home_q_rad=d.home_q_rad,
            max_joint_speed_rad_s=d.max_joint_speed_rad_s,
            max_joint_accel_rad_s2=d.max_joint_accel_rad_s2,
            joint_torque_limit_nm=d.joint_torque_limit_nm,
        )

    @classmethod
    def homing_from_scenario(cls, scenario) -> HomingConfig:
        """All three arms at once, raising towards their switches (decreasing q)."""
        d = scenario.delta
        rates = (d.homing_rate_hz,) * 3
        return HomingConfig(
            rate_hz=rates,
            locate_rate_hz=(d.homing_locate_rate_hz,) * 3,
            dirs=(-1, -1, -1),
            first_cycle=None,
        )
