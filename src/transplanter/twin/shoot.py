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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ShootParams", "ShootSway", "shoot_params"]

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
