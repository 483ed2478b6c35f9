"""MuJoCo's inverse dynamics against the five-bar's lumped model along its bspline5 transfers.

The paper scenario with ``motion.planner = "bspline5"``: each pickup's transfer (lifted grip
point, retract point, drop point at Z_up) planned by machine.planner_via.plan_via_move under
the scenario's limits; along the planned spline, the two arm motors' torques by ``mj_inverse``
on the five-bar's own model carrying the heaviest pot (transplanter.scene.fivebar_inverse) and
by ``FiveBarKinematics.inverse_dynamics`` (the lumped model the planner holds to
``drives.arm_torque_limit_nm``). Also with the jaws' acceleration limit lifted
(``--set gripper.carry_accel_limit_mm_s2=...``), where the torque limit binds.

    python scripts/fivebar_mj_inverse.py [--samples 801] [--set KEY=VALUE ...]

Prints one row per transfer: N m at the motor shafts.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from transplanter.machine.planner_via import plan_via_move
from transplanter.machine.spline_motion import spline_limits
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.scene.fivebar_inverse import FiveBarInverse


def transfer_points(machine) -> list[np.ndarray]:
    """Each pickup's transfer as the PGF sends it: lifted grip point, retract (approach)
    point, drop point, all at Z_up (m)."""
    e = machine.eeprom
    return [
        np.array([[*p.grip_xy_m, e.z_up_m], [*p.approach_xy_m, e.z_up_m], [*e.drop_xy_m, e.z_up_m]])
        for p in e.pickups
    ]


def compare(kin, inv: FiveBarInverse, limits, points, samples: int) -> dict:
    """The plan through ``points``, and both models' motor torques along it."""
    plan = plan_via_move(kin, points, limits)
    spline = plan.spline()
    t = np.linspace(0.0, plan.total_s, samples)
    q, qd, qdd = (spline(t, nu=k)[:, :2] for k in range(3))
    lumped = kin.inverse_dynamics(q, qd, qdd)
    mj = inv.torques(q, qd, qdd)
    return {"plan": plan, "t": t, "lumped": lumped, "mj": mj, "diff": mj.torque - lumped}


def row(name: str, r: dict) -> dict:
    plan, mj, diff = r["plan"], r["mj"], r["diff"]
    return {
        "transfer": name,
        "total_s": round(plan.total_s, 4),
        "binding": plan.binding,
        "peak_lumped_nm": round(float(np.abs(r["lumped"]).max()), 5),
        "peak_mj_inverse_nm": round(float(np.abs(mj.torque).max()), 6),
        "max_diff_nm": round(float(np.abs(diff).max()), 5),
        "rms_diff_nm": round(float(np.sqrt(np.mean(diff**2))), 5),
        "damping_part_nm": round(float(np.abs(mj.damping).max()), 5),
        "rest_of_diff_nm": round(float(np.abs(diff - mj.damping).max()), 5),
        "gravity_nm": float(np.abs(mj.gravity).max()),
        "closure_m": mj.closure_m,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=801)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    overrides = {"motion.planner": "bspline5"}
    for item in args.set:
        key, _, value = item.partition("=")
        overrides[key] = json.loads(value)
    scenario = load_scenario("paper", overrides)
    config = assemble(scenario)
    kin = config.machine.sgf.kinematics
    limits = spline_limits(kin, config.machine.sgf.motion)
    carried = scenario.pots.mass_max_kg + scenario.pots.shoot_mass_kg
    inv = FiveBarInverse(config.scene, carried, z_m=config.machine.eeprom.z_up_m)
    print(f"paper, bspline5, {overrides}: limit {kin.arm_torque_limit_nm} N m at the motors")
    for i, points in enumerate(transfer_points(config.machine)):
        print(json.dumps(row(f"pickup {i + 1}", compare(kin, inv, limits, points, args.samples))))


if __name__ == "__main__":
    main()
