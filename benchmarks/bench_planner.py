"""Benchmark: the quintic B-spline move planner (machine.planner_bspline) of Zhao et al. 2022
on the default delta, against a particle swarm and against TOPP-RA.

1. The paper's example move (200, 200, -800) -> (250, -175, -800) mm under its limits (720
   deg/s, 2500 deg/s^2, 12 N m, end effector 8.83 m/s^2): the scale-then-SLSQP search, the
   scale-then-Nelder-Mead variant and a plain PSO on the six intervals as the paper runs it
   (20 particles, 120 iterations, w = 0.6; c1 = c2 = 2 and the paper's c1 = c2 = 5), each
   as best total vs spline evaluations (printed, and docs/img/planner_convergence.png).
2. Moves from cell centres of the supply tray (Y0 = -160 mm) to cell centres of the planting
   tray (Y0 = +160 mm), Z = -800 mm (docs/delta.md): all 128 x 128 with --all, else a seeded
   sample of --moves plus the four longest (corner to far corner) and the shortest; per move
   the planned total, the planning time and TOPP-RA's optimum along the same path; max, the
   counts against the paper's 1.36 s line, and docs/img/planner_tray_moves.png. The planning
   time per move is printed as CPU time (the machine may be shared) and wall time;
   ``--no-toppra`` times the planner alone. Every move of both trays, resumably:
   scripts/planner_all_moves.py.

    python benchmarks/bench_planner.py [--moves N] [--all] [--seed S] [--no-plots] [--no-toppra]

Asserts nothing.
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import numpy as np

from transplanter.machine import planner_bspline as pb
from transplanter.machine.kinematics.delta import DeltaKinematics

IMG = Path(__file__).resolve().parents[1] / "docs" / "img"
MM = 1e-3
START = np.array([200.0, 200.0, -800.0]) * MM
END = np.array([250.0, -175.0, -800.0]) * MM
PAPER_LINE_S = 1.36


def tray_cells(y0_mm: float, z_mm: float = -800.0) -> np.ndarray:
    """(128, 3) cell centres (m) of a 566 x 286 mm, 8 x 16 tray centred at (0, y0)."""
    xs = (np.arange(16) - 7.5) * 566.0 / 16
    ys = (np.arange(8) - 3.5) * 286.0 / 8
    return np.array([(x, y0_mm + y, z_mm) for x in xs for y in ys]) * MM


def example(kin, limits, plots: bool) -> None:
    print("== the paper's example move (paper: PSO-AFSA 1.05 s, AFSA 1.18 s, PSO 1.37 s)")
    runs = {}
    for method in ("slsqp", "nelder-mead"):
        plan = pb.plan_move(kin, START, END, limits, method=method)
        runs[f"scale + {method}"] = plan.history
        print(
            f"{method:>12}: total {plan.total_s:.4f} s in {plan.evaluations} evaluations, "
            f"{plan.planning_s:.2f} s; intervals {np.round(plan.intervals_s, 4).tolist()}; "
            f"binding {plan.binding}"
        )
    nodes = plan.nodes
    for c in (2.0, 5.0):
        started = time.perf_counter()
        h, best, hist = pb.pso_search(kin, nodes, limits, c1=c, c2=c, seed=0)
        took = time.perf_counter() - started
        runs[f"PSO c1=c2={c:g}"] = np.column_stack([np.arange(1, len(hist) + 1), hist])
        print(
            f"PSO c1=c2={c:g}: total {best:.4f} s after {len(hist)} evaluations, {took:.1f} s; "
            f"intervals {np.round(h, 4).tolist()}"
        )
        for n in (100, 500, 1000, 2400):
            print(f"    best after {n:>4} evaluations: {hist[min(n, len(hist)) - 1]:.4f} s")
    plan = pb.plan_move(kin, START, END, limits)
    started = time.perf_counter()
    topp = pb.toppra_total(kin, plan.nodes, plan.intervals_s, limits)
    took = time.perf_counter() - started
    va = pb.MoveLimits(limits.joint_speed_rad_s, limits.joint_accel_rad_s2, None, None)
    topp_va = pb.toppra_total(kin, plan.nodes, plan.intervals_s, va)
    print(
        f"TOPP-RA along the spline's path: {topp:.4f} s ({took:.2f} s); spline / TOPP-RA = "
        f"{plan.total_s / topp:.4f}; with speed and acceleration limits only {topp_va:.4f} s"
    )
    if plots:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        for name, hist in runs.items():
            hist = np.asarray(hist)
            finite = np.isfinite(hist[:, 1])
            ax.step(hist[finite, 0], hist[finite, 1], where="post", label=name)
        ax.axhline(1.05, color="k", ls="--", lw=0.8, label="paper PSO-AFSA 1.05 s")
        ax.axhline(1.37, color="grey", ls=":", lw=0.8, label="paper PSO 1.37 s")
        ax.set_xscale("log")
        ax.set_ylim(0.7, 2.0)
        ax.set_xlabel("spline evaluations")
        ax.set_ylabel("best total time (s)")
        ax.set_title("Example move: search convergence (default delta, a_ee 8.83 m/s^2)")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(IMG / "planner_convergence.png", dpi=110)
        plt.close(fig)
        print(f"wrote {IMG / 'planner_convergence.png'}")


def sweep(
    kin, limits, moves: int, all_moves: bool, seed: int, plots: bool, toppra: bool = True
) -> None:
    supply, planting = tray_cells(-160.0), tray_cells(160.0)
    pairs = [(i, j) for i in range(128) for j in range(128)]
    if not all_moves:
        rng = np.random.default_rng(seed)
        picked = [pairs[k] for k in rng.choice(len(pairs), size=moves, replace=False)]
        gaps = np.linalg.norm(supply[:, None, :2] - planting[None, :, :2], axis=-1)
        order = np.argsort(gaps, axis=None)
        extremes = [np.unravel_index(k, gaps.shape) for k in (*order[-4:], order[0])]
        pairs = list(dict.fromkeys([(int(i), int(j)) for i, j in extremes] + picked))
    print(f"== {len(pairs)} supply -> planting cell moves (of 16384)")
    totals, topps, times, cpus = [], [], [], []
    logging.disable(logging.WARNING)
    started = time.perf_counter()
    for i, j in pairs:
        cpu = time.process_time()
        plan = pb.plan_move(kin, supply[i], planting[j], limits)
        cpus.append(time.process_time() - cpu)
        totals.append(plan.total_s)
        times.append(plan.planning_s)
        if toppra:
            topps.append(pb.toppra_total(kin, plan.nodes, plan.intervals_s, limits))
        else:
            topps.append(np.nan)
    wall = time.perf_counter() - started
    totals, topps, times, cpus = map(np.asarray, (totals, topps, times, cpus))
    ratio = totals / topps
    worst = int(np.argmax(totals))
    print(
        f"total: min {totals.min():.4f}, median {np.median(totals):.4f}, max {totals.max():.4f} s "
        f"(move {pairs[worst]}: {np.round(supply[pairs[worst][0]] / MM, 1).tolist()} -> "
        f"{np.round(planting[pairs[worst][1]] / MM, 1).tolist()} mm)"
    )
    print(f"under the paper's {PAPER_LINE_S} s: {int((totals < PAPER_LINE_S).sum())}/{len(totals)}")
    if toppra:
        print(
            f"spline / TOPP-RA: min {ratio.min():.4f}, median {np.median(ratio):.4f}, "
            f"max {ratio.max():.4f}; TOPP-RA total max {topps.max():.4f} s"
        )
    print(
        f"planning time per move (plan_move): CPU median {np.median(cpus):.3f} s, mean "
        f"{cpus.mean():.3f} s, max {cpus.max():.3f} s; wall median {np.median(times):.3f} s, "
        f"max {times.max():.3f} s; {'with TOPP-RA ' if toppra else ''}"
        f"{wall / len(pairs):.3f} s of wall per move, {wall:.0f} s in all"
    )
    edges = np.arange(0.5, 1.45, 0.05)
    counts, _ = np.histogram(totals, bins=edges)
    for lo, n in zip(edges[:-1], counts, strict=True):
        print(f"  [{lo:.2f}, {lo + 0.05:.2f}) s: {n}")
    if plots:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        ax.hist(totals, bins=edges, label="quintic B-spline, scale + SLSQP")
        if toppra:
            ax.hist(topps, bins=edges, histtype="step", color="k", label="TOPP-RA on the same path")
        ax.axvline(PAPER_LINE_S, color="r", ls="--", label=f"paper's bound {PAPER_LINE_S} s")
        ax.set_xlabel("move time (s)")
        ax.set_ylabel("moves")
        ax.set_title(f"Supply -> planting cell moves ({len(pairs)} of 16384), default delta")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(IMG / "planner_tray_moves.png", dpi=110)
        plt.close(fig)
        print(f"wrote {IMG / 'planner_tray_moves.png'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--moves", type=int, default=64, help="sampled moves (default 64)")
    parser.add_argument("--all", action="store_true", help="all 16384 moves (hours)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-plots", action="store_true")
    parser.add_argument("--skip-example", action="store_true")
    parser.add_argument(
        "--no-toppra", action="store_true", help="time the planner alone (no TOPP-RA ratios)"
    )
    args = parser.parse_args()
    kin = DeltaKinematics()
    limits = pb.MoveLimits.of(kin)
    logging.disable(logging.WARNING)
    if not args.skip_example:
        example(kin, limits, not args.no_plots)
    sweep(kin, limits, args.moves, args.all, args.seed, not args.no_plots, not args.no_toppra)


if __name__ == "__main__":
    main()
