"""`transplanter ik` and `transplanter plan`: the machine's kinematics and G-code planning,
without physics."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from transplanter.cli.common import _err, _machine, _show, add_options, ascii_finite_float
from transplanter.units import M_PER_MM

# A G-code program for `plan`: a 100k-move file is about 3 MB; anything far bigger is not one.
MAX_GCODE_FILE_BYTES = 64 << 20


def register(sub) -> None:
    _ik_parser(sub)
    _plan_parser(sub)


def _ik_parser(sub) -> None:
    p = sub.add_parser("ik", help="joint angles for a point (mm), or why it cannot be reached")
    p.add_argument("x", type=ascii_finite_float, help="x in mm")
    p.add_argument("y", type=ascii_finite_float, help="y in mm")
    p.add_argument(
        "z",
        type=ascii_finite_float,
        nargs="?",
        help="z in mm (default: the taught Z_up; the five-bar's plane does not depend on it)",
    )
    add_options(p, "--scenario", "--set")
    p.set_defaults(func=cmd_ik)


def cmd_ik(args: argparse.Namespace) -> int:
    machine = _machine(args)
    if machine is None:
        return 2
    kinematics = machine.kinematics
    if args.z is None and kinematics.kind != "fivebar":
        _err(
            f"ik: give x, y and z in mm for the {kinematics.kind} arm (only the five-bar's z "
            "defaults to the taught Z_up)"
        )
        return 2
    z_mm = args.z if args.z is not None else machine.eeprom.z_up_m / M_PER_MM
    point = np.array([[args.x, args.y, z_mm]]) * M_PER_MM
    report, reason = check_point(kinematics, point[0])
    shown = f"({args.x:g}, {args.y:g})" if args.z is None else f"({args.x:g}, {args.y:g}, {z_mm:g})"
    if reason is not None:
        print(f"{shown} mm cannot be reached: {reason}")
        return 1
    for line in kinematics.point_lines(report, 0):
        print(line)
    return 0


def check_point(kinematics, point_m: np.ndarray):
    """(the arm's ReachReport of one point (m), why it cannot be reached or None): its reach,
    then its limits (ik, and plan-move's two ends before planning). A point far outside
    every arm (1e308 mm) squares past the largest float on the way to its refusal: the
    arms read that as a chain that cannot close and refuse it with its distance, so the
    overflow is no news and is not warned about."""
    with np.errstate(over="ignore"):
        report = kinematics.check(point_m[None])
        refusal = kinematics.limit_target(point_m)
    if report.ok[0] and refusal is None:
        return report, None
    return report, report.reasons[0] or refusal.text()


def _plan_parser(sub) -> None:
    p = sub.add_parser("plan", help="plan a G-code file: duration and steps of every line")
    p.add_argument("file", type=Path)
    add_options(p, "--scenario", "--set")
    p.set_defaults(func=cmd_plan)


def cmd_plan(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.machine.planner import PlanError, plan_program

    machine = _machine(args)
    if machine is None:
        return 2
    try:
        text = fileio.read_text_input(args.file, MAX_GCODE_FILE_BYTES, "G-code")
    except fileio.FileRefused as exc:
        _err(str(exc))
        return 1
    try:
        rows = plan_program(machine, text)  # split at newlines only
    except PlanError as exc:
        _err(f"{args.file}:{exc.line_no}: {exc}")
        return 1
    print(
        f"{'line':>5}  {'duration_s':>10}  {'steps_a':>8}  {'steps_b':>8}  {'steps_z':>8}  g-code"
    )
    total = 0.0
    totals = np.zeros(3, dtype=np.int64)
    for row in rows:
        total += row.duration_s
        totals += np.abs(row.steps)
        a, b, z = row.steps
        print(
            f"{row.line_no:>5}  {row.duration_s:>10.4f}  {a:>8d}  {b:>8d}  {z:>8d}  "
            f"{_show(row.text)}"
        )
    print(
        f"total  {total:>10.4f}  {totals[0]:>8d}  {totals[1]:>8d}  {totals[2]:>8d}  "
        f"({len(rows)} lines; step columns are net steps per line, total is |steps|)"
    )
    return 0
