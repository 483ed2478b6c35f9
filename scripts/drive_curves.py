"""The stepper drives' lag and slip threshold against speed and load, per axis and timestep.

Each axis's field runs a trapezoid (the firmware's 1500 mm/s^2 at the grip for Z; 50 ms to
speed for an arm) from rest to a speed and on, the other motors holding, in the robot with one
conveyor cell (no pots in the way): Z lifts from 20 mm with an extra load on the slide (N, down:
a payload's weight and the screw friction it adds), arm 1 turns from its home angle with an
extra torque against it (N m at the arm). It prints the steady lag (full steps, mean over the
last 50 ms), the peak lag and whether the motor slipped, and the slip threshold (the lowest
speed at which it slips, by bisection) for each load, at 1 and 0.25 ms; docs/drives.md quotes
the tables.

Run: .venv/bin/python scripts/drive_curves.py [--quick]
"""

from __future__ import annotations

import argparse
import math

import mujoco
import numpy as np

from transplanter.scene import SceneConfig, build_scene

Z_LOADS_N = (0.0, 20.0, 40.0, 80.0)
ARM_LOADS_NM = (0.0, 0.3, 0.6, 1.0)
Z_ACCEL_M_S2 = 1.5


def run(axis: int, speed: float, load: float, dt: float) -> tuple[float, float, bool]:
    """(steady lag, peak lag in full steps, slipped) of one axis at speed (m/s or rad/s at the
    joint) against load (N or N m at the joint)."""
    cfg = SceneConfig(rows=1, cols=1, timestep_s=dt)
    scene = build_scene(cfg, seed=0)
    m, d = scene.model, scene.make_data()
    home = scene.joint_positions(d)
    field = home.copy()
    full = cfg.full_step_rad / scene.motor_gears[axis]
    dof = m.jnt_dofadr[m.actuator_trnid[scene.motor_actuators[axis], 0]]
    if axis == 2:  # lower Z to 20 mm first, slowly (peak 0.1 m/s), then rest
        for k in range(int(2.2 / dt)):
            u = min(k * dt / 2.0, 1.0)
            field[2] = home[2] + (0.02 - home[2]) * u**3 * (10 - 15 * u + 6 * u * u)
            speed_now = (0.02 - home[2]) * 30 * u * u * (1 - u) ** 2 / 2.0
            scene.hold_motors(d, field, [0.0, 0.0, speed_now])
            mujoco.mj_step(m, d)
        accel, travel, sign = Z_ACCEL_M_S2, 0.13, 1.0
    else:
        accel, travel, sign = speed / 0.05, math.radians(90.0), -1.0
    start = field[axis]
    t_speed = speed / accel
    t_end = t_speed + (travel - 0.5 * accel * t_speed**2) / speed
    lags, slipped, k = [], False, 0
    while k * dt < t_end:
        t = k * dt
        pos = (
            0.5 * accel * t * t if t < t_speed else 0.5 * accel * t_speed**2 + speed * (t - t_speed)
        )
        field[axis] = start + sign * pos
        v = np.zeros(3)
        v[axis] = sign * min(accel * t, speed)
        d.qfrc_applied[dof] = -sign * load
        scene.hold_motors(d, field, v)
        mujoco.mj_step(m, d)
        k += 1
        t1 = k * dt
        pos1 = (
            0.5 * accel * t1 * t1
            if t1 < t_speed
            else 0.5 * accel * t_speed**2 + speed * (t1 - t_speed)
        )
        lag = (start + sign * pos1 - d.qpos[scene.motor_qpos_adr[axis]]) * sign / full
        lags.append(lag)
        if abs(lag) > 2.0:
            slipped = True
            break
    lags = np.array(lags)
    steady = float(lags[-max(1, int(0.05 / dt)) :].mean())
    return steady, float(np.abs(lags).max()), slipped


def threshold(axis: int, load: float, dt: float, hi: float) -> float:
    """The lowest speed at which the axis slips against load (bisection to 2 %)."""
    lo = 0.0
    if not run(axis, hi, load, dt)[2]:
        return math.inf
    if run(axis, 0.01 * hi, load, dt)[2]:
        return 0.0  # it cannot hold the load at all
    while hi - lo > 0.02 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if run(axis, mid, load, dt)[2] else (mid, hi)
    return hi


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 ms only, fewer speeds")
    args = parser.parse_args()
    steps = (1e-3,) if args.quick else (1e-3, 0.5e-3, 0.25e-3)
    print("Z lift (lag in full steps behind the field; slip past 2):")
    print(f"{'dt ms':>6} {'load N':>7} " + " ".join(f"{v:>12g}" for v in (25, 50, 100, 150)))
    for dt in steps:
        for load in Z_LOADS_N:
            cells = []
            for v in (0.025, 0.05, 0.1, 0.15):
                steady, peak, slip = run(2, v, load, dt)
                cells.append("slips" if slip else f"{steady:.2f}/{peak:.2f}")
            print(f"{dt * 1e3:>6g} {load:>7g} " + " ".join(f"{c:>12}" for c in cells))
    print("  (columns: mm/s; cells: steady/peak lag)")
    print("arm 1 turn (lag in full steps; columns: deg/s at the arm):")
    speeds = (60, 180, 360, 720)
    print(f"{'dt ms':>6} {'load Nm':>7} " + " ".join(f"{v:>12g}" for v in speeds))
    for dt in steps:
        for load in ARM_LOADS_NM:
            cells = []
            for v in speeds:
                steady, peak, slip = run(0, math.radians(v), load, dt)
                cells.append("slips" if slip else f"{steady:.2f}/{peak:.2f}")
            print(f"{dt * 1e3:>6g} {load:>7g} " + " ".join(f"{c:>12}" for c in cells))
    print("slip thresholds (lowest speed that slips):")
    for dt in steps:
        z = [threshold(2, load, dt, 0.6) for load in Z_LOADS_N]
        arm = [threshold(0, load, dt, math.radians(3000)) for load in ARM_LOADS_NM]
        print(
            f"  dt {dt * 1e3:g} ms: Z "
            + ", ".join(f"{ld:g} N: {v * 1e3:.0f} mm/s" for ld, v in zip(Z_LOADS_N, z, strict=True))
            + "; arm 1 "
            + ", ".join(
                f"{ld:g} N m: {math.degrees(v):.0f} deg/s"
                for ld, v in zip(ARM_LOADS_NM, arm, strict=True)
            )
        )


if __name__ == "__main__":
    main()
