"""A seedling's shoot swaying on its stem while its pot is carried, dropped and lands.

The shoot (stem and leaves above the pot) is a rigid body on a two-axis hinge at the
centre of the pot's top, sprung and damped so that it sways at a given natural frequency
and damping ratio. It is driven by its pot's motion as the physics computes it: the
acceleration of the hinge point and the pot's angular acceleration, in the pot's frame,
with gravity. Its reaction on the pot is left out (a few grams on a 40-80 g pot), so the
shoot needs no bodies in the MuJoCo model and costs nothing while its pot rests: the judge
follows the shoots of the pots it watches (`ShootSway.update` with the pot's qpos and qvel).

The torques are those of two hinges in series (x, then y) on a shoot of constant inertia:
tests/test_shoot.py compares the bend with a MuJoCo body on two sprung hinges, within 10 %
from a few degrees to past the 45 degrees where damage starts. Pure Python and math, no
MuJoCo.

The gripper's bridge is an obstacle for the shoot (`ShootSway.press_out_of_box`): the stem,
a segment from the hinge along the shoot's axis, may not enter the bridge's box. A bridge
that meets it pushes the shoot over, the least bend that leaves the stem clear of the box,
and holds it there (the push is inelastic: the shoot's rates are cleared) until it moves
away and the spring stands the shoot back up. The bend it forces counts as any other bend.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ShootParams", "ShootSway", "segment_meets_box", "shoot_params"]

GRAVITY_M_S2 = 9.81


@dataclass(frozen=True)
class ShootParams:
    """A shoot on its hinge: mass (kg), centre of mass above the hinge (m), inertia about
    the hinge's axes (kg m^2), stiffness (N m/rad) and damping (N m s/rad), and where the
    hinge sits from the pot's centre (m, pot frame)."""

    mass: float
    com_height: float
    inertia: float
    stiffness: float
    damping: float
    hinge: tuple[float, float, float]
    sway_hz: float


def shoot_params(
    mass: float,
    com_height: float,
    spread: float,
    sway_hz: float,
    damping_ratio: float,
    hinge: tuple[float, float, float],
    gravity: float = GRAVITY_M_S2,
) -> ShootParams:
    """The hinge that makes a shoot of `mass` (leaves as a disc of diameter `spread` at
    `com_height` above the hinge) sway upright at `sway_hz` with `damping_ratio`. Gravity
    tips an upright shoot over, so the stiffness carries m*g*h on top of the sway's I*w^2."""
    inertia = mass * (spread / 2) ** 2 / 4 + mass * com_height**2
    omega = 2 * math.pi * sway_hz
    return ShootParams(
        mass=mass,
        com_height=com_height,
        inertia=inertia,
        stiffness=inertia * omega**2 + mass * gravity * com_height,
        damping=2 * damping_ratio * omega * inertia,
        hinge=(float(hinge[0]), float(hinge[1]), float(hinge[2])),
        sway_hz=sway_hz,
    )


def segment_meets_box(p, d, half) -> bool:
    """Whether the segment p + s d (s from 0 to 1) meets the box |x_k| <= half_k, all in the
    box's frame (slab clipping)."""
    lo, hi = 0.0, 1.0
    for k in range(3):
        if abs(d[k]) < 1e-15:
            if abs(p[k]) > half[k]:
                return False
            continue
        t1, t2 = (-half[k] - p[k]) / d[k], (half[k] - p[k]) / d[k]
        if t1 > t2:
            t1, t2 = t2, t1
        lo, hi = max(lo, t1), min(hi, t2)
        if lo > hi:
            return False
    return True


def _mat_vec(m, v):
    """A 3x3 matrix (9 floats, row-major) times a vector."""
    return (
        m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
        m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
        m[6] * v[0] + m[7] * v[1] + m[8] * v[2],
    )


def _mat_t_vec(m, v):
    """The transpose of a 3x3 matrix (9 floats, row-major) times a vector."""
    return (
        m[0] * v[0] + m[3] * v[1] + m[6] * v[2],
        m[1] * v[0] + m[4] * v[1] + m[7] * v[2],
        m[2] * v[0] + m[5] * v[1] + m[8] * v[2],
    )


# bisection steps for the least bend that frees a stem from a box: 2^-24 of the range
_PRESS_ITERATIONS = 24
# below this horizontal share the shoot's own lean gives no side to push it to
_LEAN_MIN = math.sin(math.radians(1.0))


class ShootSway:
    """The bend of one shoot, advanced from its pot's state (semi-implicit Euler over the
    interval since the last update; the pot's velocity change over it acts as an impulse,
    so a landing shorter than the interval still delivers its whole kick).

    The shoot stands along the pot's axis, or, given `mount` (a rotation matrix, 3x3, from
    the shoot's base frame to the pot's: a crooked pot's wall), along the mount's z axis;
    its angles and bend are taken in that frame."""

    def __init__(self, params: ShootParams, gravity: float = GRAVITY_M_S2, mount=None) -> None:
        self.p = params
        self.g = gravity
        self.mount = None if mount is None else [[float(v) for v in row] for row in mount]
        self.max_substep = 1.0 / (20.0 * params.sway_hz)
        self.theta_x = self.theta_y = 0.0  # about the pot's x and y axes (rad)
        self.rate_x = self.rate_y = 0.0
        self._peak_cos = 1.0  # cosine of the largest bend from the pot's axis so far
        self._last: tuple[float, tuple[float, float, float], tuple[float, float, float]] | None
        self._last = None  # time, hinge velocity (world), pot angular velocity (pot frame)

    @property
    def peak_rad(self) -> float:
        """The largest bend from the pot's axis so far."""
        return math.acos(self._peak_cos)

    @property
    def bend_rad(self) -> float:
        """Angle between the shoot and its pot's axis."""
        return math.acos(math.cos(self.theta_x) * math.cos(self.theta_y))

    def _torques(self, tx_, ty_, gx, gy, gz) -> tuple[float, float]:
        """Spring and felt-gravity torque about the two hinges at angles (tx_, ty_): the felt
        gravity F at the centre of mass, r = h_c Rx(tx_) Ry(ty_) z, about the first hinge (x)
        and the second (y, turned by the first)."""
        ml, k = self.p.mass * self.p.com_height, self.p.stiffness
        sx, cx, sy, cy = math.sin(tx_), math.cos(tx_), math.sin(ty_), math.cos(ty_)
        return (
            -ml * cy * (sx * gz + cx * gy) - k * tx_,
            ml * (cy * gx - sy * (cx * gz - sx * gy)) - k * ty_,
        )

    def _rest(self, gx, gy, gz) -> tuple[float, float]:
        """The angles where the spring holds the shoot against this felt gravity (Newton)."""
        tx_, ty_, h = 0.0, 0.0, 1e-7
        for _ in range(30):
            fx, fy = self._torques(tx_, ty_, gx, gy, gz)
            dx = (self._torques(tx_ + h, ty_, gx, gy, gz)[0] - fx) / h
            dy = (self._torques(tx_, ty_ + h, gx, gy, gz)[1] - fy) / h
            tx_, ty_ = tx_ - fx / dx, ty_ - fy / dy
            if abs(fx) + abs(fy) < 1e-15:
                break
        return tx_, ty_

    def update(self, t: float, quat, vel, omega_local) -> None:
        """Advance to time `t` given the pot's orientation (w, x, y, z), the velocity of its
        centre (world, m/s) and its angular velocity (pot frame, rad/s): a free joint's
        qpos[3:7], qvel[0:3] and qvel[3:6]."""
        w, x, y, z = quat
        # the pot's frame: columns of its rotation matrix
        r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
        r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        ox, oy, oz = omega_local
        hx, hy, hz = self.p.hinge
        # hinge point velocity: the centre's plus omega x hinge, in the pot frame
        lx, ly, lz = oy * hz - oz * hy, oz * hx - ox * hz, ox * hy - oy * hx
        vx = vel[0] + r00 * lx + r01 * ly + r02 * lz
        vy = vel[1] + r10 * lx + r11 * ly + r12 * lz
        vz = vel[2] + r20 * lx + r21 * ly + r22 * lz
        if self.mount is not None:  # the shoot's base frame: R_pot M, omega in it M^T omega
            (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = self.mount
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = (
                r00 * m00 + r01 * m10 + r02 * m20, r00 * m01 + r01 * m11 + r02 * m21,
                r00 * m02 + r01 * m12 + r02 * m22, r10 * m00 + r11 * m10 + r12 * m20,
                r10 * m01 + r11 * m11 + r12 * m21, r10 * m02 + r11 * m12 + r12 * m22,
                r20 * m00 + r21 * m10 + r22 * m20, r20 * m01 + r21 * m11 + r22 * m21,
                r20 * m02 + r21 * m12 + r22 * m22,
            )  # fmt: skip
            ox, oy, oz = (
                m00 * ox + m10 * oy + m20 * oz,
                m01 * ox + m11 * oy + m21 * oz,
                m02 * ox + m12 * oy + m22 * oz,
            )
        last = self._last
        self._last = (t, (vx, vy, vz), (ox, oy, oz))
        c, inertia = self.p.damping, self.p.inertia
        if last is None:  # start at rest where gravity holds the shoot on a tilted pot
            self.theta_x, self.theta_y = self._rest(-self.g * r20, -self.g * r21, -self.g * r22)
            self._peak_cos = math.cos(self.theta_x) * math.cos(self.theta_y)
            return
        dt = t - last[0]
        if dt <= 0.0:
            return
        (pvx, pvy, pvz), (pox, poy, _) = last[1], last[2]
        # velocity change of the hinge (world -> pot frame) and of the pot's rotation
        dvx, dvy, dvz = vx - pvx, vy - pvy, vz - pvz
        ax = (r00 * dvx + r10 * dvy + r20 * dvz) / dt
        ay = (r01 * dvx + r11 * dvy + r21 * dvz) / dt
        az = (r02 * dvx + r12 * dvy + r22 * dvz) / dt
        alpha_x, alpha_y = (ox - pox) / dt, (oy - poy) / dt
        # gravity less the hinge's acceleration, in the pot frame: what the shoot feels
        gx = -self.g * r20 - ax
        gy = -self.g * r21 - ay
        gz = -self.g * r22 - az
        # the felt acceleration is taken as constant over the interval, cut into substeps
        # of at most a twentieth of a sway
        n = max(1, math.ceil(dt / self.max_substep))
        step = dt / n
        for _ in range(n):
            tx, ty = self._torques(self.theta_x, self.theta_y, gx, gy, gz)
            acc_x = (tx - c * self.rate_x) / inertia - alpha_x
            acc_y = (ty - c * self.rate_y) / inertia - alpha_y
            self.rate_x += step * acc_x
            self.rate_y += step * acc_y
            self.theta_x += step * self.rate_x
            self.theta_y += step * self.rate_y
            cos_bend = math.cos(self.theta_x) * math.cos(self.theta_y)  # after the step
            if cos_bend < self._peak_cos:
                self._peak_cos = cos_bend

    def _axis_in_base(self) -> tuple[float, float, float]:
        """The shoot's axis in its base frame: Rx(theta_x) Ry(theta_y) z."""
        sx, cx = math.sin(self.theta_x), math.cos(self.theta_x)
        sy, cy = math.sin(self.theta_y), math.cos(self.theta_y)
        return (sy, -sx * cy, cx * cy)

    def press_out_of_box(
        self, pot_pos, pot_mat, length: float, radius: float, box_pos, box_mat, box_half
    ) -> float:
        """Keep the stem (`length` from the hinge along the shoot's axis, `radius` thick) out
        of a box (centre, rotation matrix as 9 floats row-major, half sizes; world) given
        its pot's pose (centre, rotation as 9 floats): a stem that meets the box is bent
        over, away from it, to the least bend from the box's z axis that frees it (bisection),
        or with its tip under the box's underside. Returns that bend (rad; 0 when the stem was
        clear), the new bend counting towards `peak_rad`."""
        hx, hy, hz = self.p.hinge
        hinge_w = _mat_vec(pot_mat, (hx, hy, hz))
        rel = (
            pot_pos[0] + hinge_w[0] - box_pos[0],
            pot_pos[1] + hinge_w[1] - box_pos[1],
            pot_pos[2] + hinge_w[2] - box_pos[2],
        )
        h = _mat_t_vec(box_mat, rel)  # the hinge in the box's frame
        half = (box_half[0] + radius, box_half[1] + radius, box_half[2] + radius)
        base_axis = self._axis_in_base()
        if self.mount is not None:
            m = self.mount
            base_axis = tuple(
                m[i][0] * base_axis[0] + m[i][1] * base_axis[1] + m[i][2] * base_axis[2]
                for i in range(3)
            )
        axis = _mat_t_vec(box_mat, _mat_vec(pot_mat, base_axis))
        if not segment_meets_box(h, tuple(length * a for a in axis), half):
            return 0.0
        # the side to push it to: its own lean, else away from the box's centre
        ux, uy = axis[0], axis[1]
        if math.hypot(ux, uy) < _LEAN_MIN:
            ux, uy = h[0], h[1]
            if math.hypot(ux, uy) < 1e-9:
                ux, uy = 0.0, 1.0
        norm = math.hypot(ux, uy)
        ux, uy = ux / norm, uy / norm
        # bent so far its tip lies under the box, the stem is clear (flat at the most)
        hi = math.acos(min(1.0, max(0.0, (-half[2] - h[2]) / length)))
        lo = 0.0
        for _ in range(_PRESS_ITERATIONS):
            mid = 0.5 * (lo + hi)
            sb = length * math.sin(mid)
            if segment_meets_box(h, (sb * ux, sb * uy, length * math.cos(mid)), half):
                lo = mid
            else:
                hi = mid
        bend = hi
        new_axis = _mat_t_vec(  # box frame -> world -> pot frame
            pot_mat,
            _mat_vec(box_mat, (math.sin(bend) * ux, math.sin(bend) * uy, math.cos(bend))),
        )
        if self.mount is not None:
            m = self.mount
            new_axis = tuple(
                m[0][i] * new_axis[0] + m[1][i] * new_axis[1] + m[2][i] * new_axis[2]
                for i in range(3)
            )
        lx, ly, lz = new_axis
        self.theta_y = math.asin(min(1.0, max(-1.0, lx)))
        self.theta_x = math.atan2(-ly, lz)
        self.rate_x = self.rate_y = 0.0
        cos_bend = math.cos(self.theta_x) * math.cos(self.theta_y)
        if cos_bend < self._peak_cos:
            self._peak_cos = cos_bend
        return bend
