"""`transplanter plan-move`: one pick-and-place move on the quintic B-spline of Zhao et al.
(2022), timed for the shortest total under the arm's limits, beside TOPP-RA's optimum along
the same path. Pure planning, no physics."""

from __future__ import annotations

import argparse
import math

import numpy as np

from transplanter.cli.common import (
    EXIT_OUTPUT_FAILED,
    EXIT_REFUSED,
    _clash,
    _err,
    _inputs,
    _machine,
    _show,
    add_options,
    ascii_finite_float,
)
from transplanter.cli.kinematics import check_point
from transplanter.units import M_PER_MM

EE_ACCEL_KEY = "motion.ee_accel_limit_mm_s2"  # the scenario key --ee-accel stands in for


def register(sub) -> None:
    p = sub.add_parser(
        "plan-move",
        help="time-optimal quintic B-spline pick-and-place move between two points (mm)",
    )
    add_options(p, "scenario")
    p.add_argument(
        "--from", dest="start", type=_point, required=True, metavar="X,Y,Z",
        help="pick point in mm in the base frame (--from=-100,0,-800 for a leading minus)",
    )  # fmt: skip
    p.add_argument(
        "--to", dest="end", type=_point, required=True, metavar="X,Y,Z",
        help="place point in mm in the base frame",
    )  # fmt: skip
    p.add_argument(
        "--ee-accel", type=ascii_finite_float, default=None, metavar="M_S2",
        help="end-effector acceleration limit in m/s^2, within the range of the scenario's "
        "motion.ee_accel_limit_mm_s2 (default: its value, 8830 mm/s^2 unless set: an "
        "estimate, see docs/planner.md)",
    )  # fmt: skip
    p.add_argument(
        "--exit-mm", type=ascii_finite_float, default=0.0, metavar="MM",
        help="a key point this high straight above each end, as delta_refill's transfers "
        "(delta_refill.exit_mm); default 0: the paper's seven key points",
    )  # fmt: skip
    p.add_argument(
        "--no-toppra", action="store_true", help="skip the TOPP-RA yardstick"
    )  # fmt: skip
    add_options(p, "--set", "--json")
    p.set_defaults(func=cmd_plan_move)


def _point(text: str) -> np.ndarray:
    parts = text.split(",")
    try:
        values = [ascii_finite_float(v) for v in parts]
    except argparse.ArgumentTypeError:
        values = []
    if len(values) != 3:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not X,Y,Z (three finite numbers in mm, ASCII digits 0-9)"
        )
    return np.array(values)


def _ee_accel_refusal(value: float) -> str | None:
    """Why --ee-accel (m/s^2) is refused: outside the range the schema gives its scenario key
    (in mm/s^2); None when it is within."""
    from transplanter.scenario.schema import key_spec

    spec = key_spec(EE_ACCEL_KEY)
    lo, hi = spec.lo * spec.scale, spec.hi * spec.scale
    if lo <= value <= hi:
        return None
    return (
        f"--ee-accel {value!r} m/s^2 is outside [{lo:g}, {hi:g}] m/s^2, the range of "
        f"{EE_ACCEL_KEY} ([{spec.lo:g}, {spec.hi:g}] mm/s^2): give a value within it"
    )


def cmd_plan_move(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.machine import planner_bspline as pb

    if args.ee_accel is not None:
        refusal = _ee_accel_refusal(args.ee_accel)
        if refusal is not None:
            _err(refusal)
            return EXIT_REFUSED
    json_target = None
    if args.json is not None:
        try:
            json_target = fileio.check_output(args.json, None)
        except fileio.FileRefused as exc:
            _err(f"--json: {exc}")
            return 1
        clash = _clash([("--json", args.json)], _inputs(args))
        if clash is not None:
            _err(clash)
            return 1
    machine = _machine(args)
    if machine is None:
        return 2
    kin = machine.kinematics
    if getattr(kin, "transfer_path", "pick") == "via":
        _err(
            f"plan-move plans the delta's pick path (lift, arc, top, arc, descent); robot kind "
            f"{kin.kind!r} moves through its taught points instead: run a trial with --set "
            "motion.planner='\"bspline5\"' (docs/planner.md, The five-bar), or try --set "
            "robot.kind=delta"
        )
        return 1
    if not hasattr(kin, "max_joint_speed_rad_s"):
        _err(
            f"plan-move needs an arm with joint speed and acceleration limits; robot kind "
            f"{kin.kind!r} has none (try --set robot.kind=delta)"
        )
        return 1
    ee = machine.sgf.motion.ee_accel_limit_m_s2 if args.ee_accel is None else args.ee_accel
    try:
        limits = pb.MoveLimits.of(kin, ee_accel_m_s2=ee)
    except ValueError as exc:
        _err(str(exc))
        return 1
    start, end = args.start * M_PER_MM, args.end * M_PER_MM
    for option, given, point in (("--from", args.start, start), ("--to", args.end, end)):
        reason = check_point(kin, point)[1]  # before the planner computes with it
        if reason is not None:
            print(f"move refused (reach): {option} {_mm(given)} mm: {reason}")
            return 1
    try:
        path = pb.PickPath(exit_m=args.exit_mm * M_PER_MM)
    except ValueError as exc:
        _err(f"--exit-mm: {exc}")
        return 1
    try:
        plan = pb.plan_move(kin, start, end, limits, path=path)
        topp = None
        if not args.no_toppra:
            topp = pb.toppra_total(kin, plan.nodes, plan.intervals_s, limits)
    except pb.MoveRefused as exc:
        print(f"move refused ({exc.limit}): {exc}")
        return 1
    _print_plan(kin, plan, limits, args, topp)
    if json_target is not None:
        try:
            fileio.write_json_atomic(json_target, _payload(kin, plan, limits, topp))
        except OSError as exc:
            _err(f"--json: the results could not be written to {_show(args.json)}: {exc}")
            return EXIT_OUTPUT_FAILED
        print(f"wrote {_show(json_target)}")
    return 0


def _mm(point) -> str:
    return f"({point[0]:g}, {point[1]:g}, {point[2]:g})"


def _limits_text(limits) -> str:
    parts = [
        f"{math.degrees(limits.joint_speed_rad_s):g} deg/s",
        f"{math.degrees(limits.joint_accel_rad_s2):g} deg/s^2",
    ]
    if limits.joint_torque_nm is not None:
        parts.append(f"{limits.joint_torque_nm:g} N m")
    if limits.ee_accel_m_s2 is not None:
        parts.append(f"end effector {limits.ee_accel_m_s2:g} m/s^2")
    return ", ".join(parts)


def _print_plan(kin, plan, limits, args, topp) -> None:
    print(
        f"move {_mm(args.start)} -> {_mm(args.end)} mm, {kin.kind}; limits {_limits_text(limits)}"
    )
    names = " ".join(f"{ax.name:>9}" for ax in kin.axes)
    print(f"key    {'x_mm':>8} {'y_mm':>8} {'z_mm':>8}  {names}  (deg)")
    for i, (p, q) in enumerate(zip(plan.points_m / M_PER_MM, np.degrees(plan.nodes), strict=True)):
        joints = " ".join(f"{v:9.3f}" for v in q)
        print(f"Q{i}     {p[0]:8.2f} {p[1]:8.2f} {p[2]:8.2f}  {joints}")
    print("intervals_s " + " ".join(f"{h:.4f}" for h in plan.intervals_s))
    print(f"total_s {plan.total_s:.4f}  binding limit: {plan.binding}")
    pk = plan.peaks
    line = (
        f"peaks: speed {math.degrees(pk['speed'].max()):.1f} deg/s, "
        f"accel {math.degrees(pk['accel'].max()):.1f} deg/s^2, "
        f"jerk {math.degrees(pk['jerk'].max()):.0f} deg/s^3"
    )
    if "torque" in pk:
        line += f", torque {pk['torque'].max():.3f} N m"
    line += f", end effector {pk['ee_accel'].max():.3f} m/s^2"
    print(line)
    if topp is not None:
        print(
            f"TOPP-RA along the same path: {topp:.4f} s; spline / TOPP-RA = "
            f"{plan.total_s / topp:.4f}"
        )
    print(f"planned in {plan.planning_s:.2f} s ({plan.evaluations} spline evaluations)")


def _payload(kin, plan, limits, topp) -> dict:
    pk = plan.peaks
    return {
        "kind": kin.kind,
        "points_mm": (plan.points_m / M_PER_MM).tolist(),
        "nodes_deg": np.degrees(plan.nodes).tolist(),
        "intervals_s": plan.intervals_s.tolist(),
        "total_s": plan.total_s,
        "binding": plan.binding,
        "toppra_total_s": topp,
        "ratio_to_toppra": None if topp is None else plan.total_s / topp,
        "limits": {
            "joint_speed_deg_s": math.degrees(limits.joint_speed_rad_s),
            "joint_accel_deg_s2": math.degrees(limits.joint_accel_rad_s2),
            "joint_torque_nm": limits.joint_torque_nm,
            "ee_accel_m_s2": limits.ee_accel_m_s2,
        },
        "peaks": {
            "speed_deg_s": float(np.degrees(pk["speed"].max())),
            "accel_deg_s2": float(np.degrees(pk["accel"].max())),
            "jerk_deg_s3": float(np.degrees(pk["jerk"].max())),
            "torque_nm": float(pk["torque"].max()) if "torque" in pk else None,
            "ee_accel_m_s2": float(pk["ee_accel"].max()),
        },
        "planning_s": plan.planning_s,
        "evaluations": plan.evaluations,
    }
