"""The `transplanter` command: inverse kinematics, G-code planning, trials and replay."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

DEFAULT_SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "paper.toml"


def _scenario_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--scenario",
        type=Path,
        default=DEFAULT_SCENARIO,
        help="scenario file giving the machine (default: scenarios/paper.toml)",
    )


def _machine(path: Path):
    """The machine of a scenario file, or None after saying why it was refused."""
    from transplanter.machine import machine_from_scenario
    from transplanter.scenario import ScenarioError, load_scenario

    try:
        return machine_from_scenario(load_scenario(path))
    except ScenarioError as exc:
        print(f"scenario refused: {exc}", file=sys.stderr)
        return None


def cmd_ik(args: argparse.Namespace) -> int:
    from transplanter import kinematics

    machine = _machine(args.scenario)
    if machine is None:
        return 2
    x, y = args.x * 1e-3, args.y * 1e-3
    report = kinematics.check_points(
        machine.geometry, machine.limits, np.array([x]), np.array([y]), mode=machine.mode
    )
    if not report.ok[0]:
        print(f"({args.x:g}, {args.y:g}) mm cannot be reached: {report.reasons[0]}")
        return 1
    t1, t2 = float(report.theta1[0]), float(report.theta2[0])
    tr = float(kinematics.transmission_angle(machine.geometry, t1, t2, x, y))
    print(f"theta1 = {math.degrees(t1):.4f} deg")
    print(f"theta2 = {math.degrees(t2):.4f} deg")
    print(f"passive-link (transmission) angle = {math.degrees(tr):.4f} deg")
    return 0


def cmd_plan(args: argparse.Namespace) -> int:
    from transplanter.planner import PlanError, plan_program

    machine = _machine(args.scenario)
    if machine is None:
        return 2
    try:
        text = Path(args.file).read_text(encoding="utf-8")
    except OSError as exc:
        print(f"{args.file}: cannot read: {exc.strerror}", file=sys.stderr)
        return 1
    except UnicodeDecodeError:
        print(f"{args.file}: not a text file (G-code is ASCII text)", file=sys.stderr)
        return 1
    try:
        rows = plan_program(machine, text.splitlines())
    except PlanError as exc:
        print(f"{args.file}:{exc.line_no}: {exc}", file=sys.stderr)
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
        print(f"{row.line_no:>5}  {row.duration_s:>10.4f}  {a:>8d}  {b:>8d}  {z:>8d}  {row.text}")
    print(
        f"total  {total:>10.4f}  {totals[0]:>8d}  {totals[1]:>8d}  {totals[2]:>8d}  "
        f"({len(rows)} lines; step columns are net steps per line, total is |steps|)"
    )
    return 0


def cmd_trial(args: argparse.Namespace) -> int:
    from transplanter.scenario import ScenarioError
    from transplanter.trial import run_trial_cli

    try:
        return run_trial_cli(args)
    except ScenarioError as exc:
        print(f"scenario refused: {exc}", file=sys.stderr)
        return 2


def cmd_replay(args: argparse.Namespace) -> int:
    from transplanter.recording import replay

    return replay(args.file)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="transplanter",
        description="MuJoCo digital twin of a five-bar pot-seedling transplanter.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("ik", help="joint angles for a point of the plane (mm)")
    p.add_argument("x", type=float, help="x in mm")
    p.add_argument("y", type=float, help="y in mm")
    _scenario_arg(p)
    p.set_defaults(func=cmd_ik)

    p = sub.add_parser("plan", help="plan a G-code file: duration and steps of every line")
    p.add_argument("file", type=Path)
    _scenario_arg(p)
    p.set_defaults(func=cmd_plan)

    p = sub.add_parser(
        "trial",
        help="run a headless pick-and-drop trial",
        epilog="exit status: 0 done, 2 scenario refused, 3 invalid physics (a MuJoCo warning "
        "or divergence), 4 the firmware faulted (a line was refused)",
    )
    p.add_argument("scenario", type=Path)
    p.add_argument("--seedlings", type=int, default=None, help="override scenario.seedlings")
    p.add_argument("--seed", type=int, default=None, help="override scenario.seed")
    p.add_argument("--json", type=Path, default=None, help="write results to this JSON file")
    p.add_argument("--record", type=Path, default=None, help="write a rerun .rrd recording")
    p.add_argument("--record-rate", type=float, default=60.0, help="recording rate in Hz (> 0)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_trial)

    p = sub.add_parser("replay", help="open a recorded trial in the rerun viewer")
    p.add_argument("file", type=Path)
    p.set_defaults(func=cmd_replay)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
