"""MuJoCo's inverse dynamics against the lumped model of Eq. 9 along the planner's example move.

The paper's example, (200, 200, -800) -> (250, -175, -800) mm (Zhao et al. 2022, "Research on
the End Effector and Optimal Motion Control Strategy for a Plug Seedling Transplanting
Parallel Robot"), planned by machine.planner_bspline.plan_move on the default delta under its
limits; along the planned spline, the three actuated joints' torques by ``mj_inverse`` on the
delta model (transplanter.scene.delta_inverse: the closed chain's state from the arms' motion,
the torques by virtual work) and by ``DeltaKinematics.inverse_dynamics`` (Eq. 9). The same for
the move planned with the end effector left free (the torque limit binds), to see whether the
planner's 12 N m on Eq. 9 keeps MuJoCo's torques under 12 N m, and for the longest tray move
(corner to far corner), whose Eq. 9 torque comes nearest the limit of the tray moves.

    python scripts/planner_mj_inverse.py [--samples 801] [--no-plot]

Prints the largest differences and writes docs/img/planner_mj_inverse.png.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from transplanter.machine import planner_bspline as pb
from transplanter.machine.kinematics.delta import DeltaKinematics
from transplanter.scene.delta_inverse import DeltaInverse

ROOT = Path(__file__).resolve().parents[1]
MM = 1e-3
START = np.array([200.0, 200.0, -800.0]) * MM
END = np.array([250.0, -175.0, -800.0]) * MM
LONGEST_FROM = np.array([-265.3125, -285.125, -800.0]) * MM
LONGEST_TO = np.array([265.3125, 285.125, -800.0]) * MM


def compare(kin, inv, limits, samples: int, start=START, end=END) -> dict:
    plan = pb.plan_move(kin, start, end, limits)
    spline = plan.spline()
    t = np.linspace(0.0, plan.total_s, samples)
    q, qd, qdd = spline(t), spline(t, nu=1), spline(t, nu=2)
    eq9 = kin.inverse_dynamics(q, qd, qdd)
    mj = inv.torques(q, qd, qdd)
    diff = mj.torque - eq9
    return {
        "plan": plan,
        "t": t,
        "eq9": eq9,
        "mj": mj,
        "diff": diff,
        "gravity_diff": float(np.abs(mj.gravity - kin.gravity_torques(q)).max()),
        "inertial_diff": diff - mj.damping,
    }


def report(name: str, r: dict) -> None:
    plan, mj, diff = r["plan"], r["mj"], r["diff"]
    peak_eq9, peak_mj = np.abs(r["eq9"]).max(), np.abs(mj.torque).max()
    worst = np.unravel_index(np.argmax(np.abs(diff)), diff.shape)
    print(f"== {name}: total {plan.total_s:.4f} s, binding {plan.binding}")
    print(
        f"  peak |tau|: Eq. 9 {peak_eq9:.4f} N m, mj_inverse {peak_mj:.4f} N m "
        f"(per joint: Eq. 9 {np.round(np.abs(r['eq9']).max(axis=0), 4).tolist()}, "
        f"MuJoCo {np.round(np.abs(mj.torque).max(axis=0), 4).tolist()})"
    )
    print(
        f"  mj - Eq. 9: max |d| {np.abs(diff).max():.4f} N m (joint {worst[1] + 1}, "
        f"t = {r['t'][worst[0]]:.4f} s), rms {np.sqrt(np.mean(diff**2)):.4f} N m; "
        f"of which the joints' damping up to {np.abs(mj.damping).max():.4f} N m, the rest "
        f"(inertia) up to {np.abs(r['inertial_diff']).max():.4f} N m; at rest (gravity) "
        f"{r['gravity_diff']:.2e} N m"
    )
    print(
        f"  closure: equalities {mj.closure_m:.1e} m, {mj.closure_speed_m_s:.1e} m/s; "
        f"equations of motion residual {mj.residual:.1e}"
    )


def plot(example: dict, free: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(10, 6.5), sharex="col")
    for col, (r, title) in enumerate(
        (
            (example, "example, a_ee 8.83 m/s^2 (binding)"),
            (free, "end effector free (torque binds)"),
        )
    ):
        ax = axes[0, col]
        for j in range(3):
            ax.plot(r["t"], r["mj"].torque[:, j], color=f"C{j}", label=f"q{j + 1} mj_inverse")
            ax.plot(r["t"], r["eq9"][:, j], color=f"C{j}", ls="--", label=f"q{j + 1} Eq. 9")
        ax.axhline(12.0, color="r", lw=0.8, ls=":")
        ax.axhline(-12.0, color="r", lw=0.8, ls=":", label="limit 12 N m")
        ax.set_ylabel("joint torque (N m)")
        ax.set_title(f"{title}: {r['plan'].total_s:.4f} s", fontsize=9)
        ax = axes[1, col]
        for j in range(3):
            ax.plot(r["t"], r["diff"][:, j], color=f"C{j}", label=f"q{j + 1}")
            ax.plot(r["t"], r["mj"].damping[:, j], color=f"C{j}", lw=0.8, ls=":")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("mj_inverse - Eq. 9 (N m)")
        ax.set_title("difference (dotted: the joints' damping in it)", fontsize=9)
    axes[0, 0].legend(fontsize=7, ncol=3)
    axes[1, 0].legend(fontsize=7)
    fig.suptitle("Delta, paper's example move: MuJoCo inverse dynamics vs the lumped Eq. 9")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path.relative_to(ROOT)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=801)
    parser.add_argument("--no-plot", action="store_true")
    args = parser.parse_args()
    kin = DeltaKinematics()
    inv = DeltaInverse()
    limits = pb.MoveLimits.of(kin)
    example = compare(kin, inv, limits, args.samples)
    report("the paper's example", example)
    free = compare(kin, inv, pb.MoveLimits.of(kin, ee_accel_m_s2=1000.0), args.samples)
    report("the same move, end effector free", free)
    # the longest tray move (corner to far corner, docs/planner.md), the largest Eq. 9 peak
    longest = compare(kin, inv, limits, args.samples, LONGEST_FROM, LONGEST_TO)
    report("the longest tray move", longest)
    if not args.no_plot:
        plot(example, free, ROOT / "docs" / "img" / "planner_mj_inverse.png")


if __name__ == "__main__":
    main()
