"""The planner's figures for docs/planner.md (after Figures 9-13 of Zhao et al. 2022).

- ``docs/img/planner_pick.png``: the paper's example move (200, 200, -800) -> (250, -175, -800) mm
  planned by `plan_move` under the paper's limits: the joints' position, speed, acceleration,
  jerk and torque (Eq. 9) against time, the limits dashed, the key points' times dotted.
- ``docs/img/planner_executed.png``: one cell of the delta's cull-and-refill job (seed 10,
  `max_cells = 1`) run in MuJoCo with each planner: the arms' measured speed and servo torque
  at the joint against the limits, from the end of homing.

    python scripts/planner_figures.py [--seed 10] [--out docs/img]

Prints the peaks it plots. About a minute (two one-cell trials and one plan).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from transplanter.machine.kinematics.delta import DeltaKinematics  # noqa: E402
from transplanter.machine.planner_bspline import MoveLimits, plan_move  # noqa: E402
from transplanter.scenario.schema import load_scenario  # noqa: E402
from transplanter.twin.delta_refill import run_delta_refill  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
A = np.array([0.200, 0.200, -0.800])
B = np.array([0.250, -0.175, -0.800])
ARMS = ("q1", "q2", "q3")


def plot_plan(out: Path) -> None:
    kin = DeltaKinematics()
    limits = MoveLimits.of(kin)
    plan = plan_move(kin, A, B, limits)
    spline = plan.spline()
    t = np.linspace(0.0, plan.total_s, 2001)
    q, qd, qdd, jerk = (spline(t, nu=k) for k in range(4))
    tau = kin.inverse_dynamics(q, qd, qdd)
    deg = math.degrees(1.0)
    rows = [
        ("position, deg", q * deg, None),
        ("speed, deg/s", qd * deg, limits.joint_speed_rad_s * deg),
        ("acceleration, deg/s^2", qdd * deg, limits.joint_accel_rad_s2 * deg),
        ("jerk, deg/s^3", jerk * deg, None),
        ("torque, N m", tau, limits.joint_torque_nm),
    ]
    nodes = np.concatenate([[0.0], np.cumsum(plan.intervals_s)])
    fig, axes = plt.subplots(len(rows), 1, figsize=(7, 10), sharex=True)
    for ax, (label, values, limit) in zip(axes, rows, strict=True):
        for j, name in enumerate(ARMS):
            ax.plot(t, values[:, j], label=name)
        if limit is not None:
            for sign in (1, -1):
                ax.axhline(sign * limit, color="k", ls="--", lw=0.8)
        for tn in nodes:
            ax.axvline(tn, color="0.7", ls=":", lw=0.8)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("time, s")
    fig.suptitle(
        f"The paper's example move: {plan.total_s:.4f} s, bound by {plan.binding} "
        f"(limits dashed, key points dotted)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(
        f"plan: {plan.total_s:.4f} s, intervals {np.round(plan.intervals_s, 4).tolist()}, "
        f"peaks speed {qd.__abs__().max() * deg:.1f} deg/s, accel {abs(qdd).max() * deg:.1f} "
        f"deg/s^2, jerk {abs(jerk).max() * deg:.0f} deg/s^3, torque {abs(tau).max():.2f} N m"
    )


class _Trace:
    """Every step's measured arm speed and torque at the joint (an observer)."""

    def __init__(self) -> None:
        self.next_t = 0.0
        self.rows: list[np.ndarray] = []

    def attach(self, view) -> None:
        m = view.model
        self.dofs = [m.jnt_dofadr[m.joint(n).id] for n in ARMS]

    def look(self, view) -> None:
        if "image" not in view.host.marks:  # homing (its instant starts saturate the servos)
            self.next_t = view.t + 1e-3
            return
        d = view.data
        self.rows.append(np.concatenate([[view.t], d.qvel[self.dofs], d.qfrc_actuator[self.dofs]]))
        self.next_t = view.t + 1e-3

    def finish(self, view, result) -> None:
        pass

    def abort(self) -> None:
        pass


def plot_executed(out: Path, seed: int) -> None:
    sc = load_scenario("delta_refill")
    fig, axes = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    deg = math.degrees(1.0)
    for planner, style in (("lines", ":"), ("bspline5", "-")):
        over = {"delta_refill.max_cells": 1, "delta_refill.image_delay_ms": 0.0,
                "motion.planner": planner, "delta_refill.vision": "truth"}  # fmt: skip
        trace = _Trace()
        result = run_delta_refill(load_scenario("delta_refill", over), seed, observers=(trace,))
        a = np.array(trace.rows)
        clamp = (np.abs(a[:, 4:7]) >= 0.999 * sc.delta.joint_torque_limit_nm).any(axis=1)
        for j in range(3):
            axes[0].plot(a[:, 0], np.abs(a[:, 1 + j]) * deg, style, lw=0.9,
                         label=f"{planner} arm {j + 1}")  # fmt: skip
            axes[1].plot(a[:, 0], np.abs(a[:, 4 + j]), style, lw=0.9)
        print(
            f"{planner}: tray time {result.tray_time_s:.3f} s, peak speed "
            f"{result.peak_joint_speed_deg_s} deg/s, peak torque {result.peak_joint_torque_nm} "
            f"N m ({clamp.sum()} of {len(a)} ms after homing with an arm at the servo's limit), "
            f"peak following error {result.peak_following_error_deg} deg, "
            f"cell {result.cells[0].culled}/{result.cells[0].refilled}"
        )
    axes[0].axhline(sc.delta.max_joint_speed_rad_s * deg, color="k", ls="--", lw=0.8)
    axes[1].axhline(sc.delta.joint_torque_limit_nm, color="k", ls="--", lw=0.8)
    axes[0].set_ylabel("|speed|, deg/s")
    axes[1].set_ylabel("|servo torque|, N m")
    axes[1].set_xlabel("time, s")
    axes[0].legend(fontsize=7, ncol=2)
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle(f"One cell of delta_refill (seed {seed}) in MuJoCo: lines (dotted) and "
                 "bspline5 (solid)", fontsize=10)  # fmt: skip
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=10)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "img")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    plot_plan(args.out / "planner_pick.png")
    plot_executed(args.out / "planner_executed.png", args.seed)


if __name__ == "__main__":
    main()
