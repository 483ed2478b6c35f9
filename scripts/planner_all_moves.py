"""Every cell-to-cell move of the delta's two trays, planned by the quintic B-spline planner
(machine.planner_bspline.plan_move, after Zhao et al. 2022, "Research on the End Effector and
Optimal Motion Control Strategy for a Plug Seedling Transplanting Parallel Robot"): the 128
cell centres of the supply tray (Y0 = -160 mm) to the 128 of the planting tray (Y0 = +160 mm),
Z = -800 mm (docs/delta.md's layout, as benchmarks/bench_planner.py), 16 384 moves, on the
default delta under its limits (720 deg/s, 2500 deg/s^2, 12 N m, end effector 8.83 m/s^2).

Symmetry (exact in the model, so used): the delta is symmetric about its XZ plane (arm 1 at
0 deg, arms 2 and 3 at +-120 deg, all three alike) and the two trays are each other's mirror
images in it; a move's time law reversed is a move back along the same path (the key points
of B -> A are those of A -> B reversed, the spline through reversed nodes on reversed
intervals is the original run backwards, and speeds enter the dynamics squared). So the move
from supply cell i to planting cell j has the same plan, intervals reversed and joints 2 and
3 swapped, as the move from supply cell tau(j) to planting cell tau(i), tau the cell's row
mirrored: 8 256 moves are planned and the other 8 128 are their images (rows marked
"mirror"); ``--verify-mirror N`` plans N image moves directly for comparison, and
``--no-symmetry`` plans all 16 384.

Per move: the total, the six intervals, the binding limit, the plan's peaks (exact joint
speed, acceleration and jerk; refined torque and end-effector acceleration) and whether they
are within the limits, the search's evaluations and its CPU and wall time. The moves run in
a seeded order (the longest and the shortest first), so that a part of the run is a fair
sample. Resumable: the results file (a CSV, rewritten atomically every ``--flush`` moves) is
read back at start and its moves are skipped; the plan of a move depends on that move only,
so a resumed run gives the same rows, bit for bit, as one without a break.

    python scripts/planner_all_moves.py [--out results/planner_all_moves.csv] [--max-moves N]
    python scripts/planner_all_moves.py --report   # summary, docs/img/planner_all_moves.png

``--report`` (also run at the end of a complete run) writes the summary (count within the
limits, max, histogram, timing) to docs/data/planner_all_moves.json and the histogram to
docs/img/planner_all_moves.png, from whatever rows the file holds. Each planned move also
gets TOPP-RA's optimum along its path (Pham and Pham 2018; `planner_bspline.toppra_total`,
about 0.13 s a move) and the ratio of the plan's total to it (``--no-toppra``: plans only).
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from transplanter.machine import planner_bspline as pb
from transplanter.machine.kinematics.delta import DeltaKinematics

ROOT = Path(__file__).resolve().parents[1]
MM = 1e-3
PAPER_LINE_S = 1.36
FIELDS = (
    ["supply", "planting", "supply_x_mm", "supply_y_mm", "planting_x_mm", "planting_y_mm",
     "distance_mm", "total_s"]
    + [f"h{k}_s" for k in range(1, 7)]
    + ["binding", "speed_deg_s", "accel_deg_s2", "jerk_deg_s3", "torque_nm", "ee_accel_m_s2",
       "within_limits", "evaluations", "cpu_s", "wall_s", "planned", "toppra_total_s", "ratio",
       "toppra_cpu_s"]
)  # fmt: skip


def tray_cells(y0_mm: float, z_mm: float = -800.0) -> np.ndarray:
    """(128, 3) cell centres (m) of a 566 x 286 mm, 8 x 16 tray centred at (0, y0); cell
    index 8 ix + iy (as benchmarks/bench_planner.py)."""
    xs = (np.arange(16) - 7.5) * 566.0 / 16
    ys = (np.arange(8) - 3.5) * 286.0 / 8
    return np.array([(x, y0_mm + y, z_mm) for x in xs for y in ys]) * MM


SUPPLY, PLANTING = tray_cells(-160.0), tray_cells(160.0)


def mirror_cell(index: int) -> int:
    """tau: the cell of the other tray that is this cell's mirror image in the XZ plane."""
    ix, iy = divmod(index, 8)
    return 8 * ix + (7 - iy)


def image(move: tuple[int, int]) -> tuple[int, int]:
    """The move with the same plan reversed (and joints 2, 3 swapped)."""
    i, j = move
    return mirror_cell(j), mirror_cell(i)


def _check_layout() -> None:
    flip = np.array([1.0, -1.0, 1.0])
    for k in range(128):
        assert np.array_equal(SUPPLY[k] * flip, PLANTING[mirror_cell(k)]), k


def move_order(seed: int, symmetry: bool) -> list[tuple[int, int]]:
    """The moves to plan: the four longest and the shortest first, then the rest in a seeded
    random order; with ``symmetry`` one of each mirror pair (the smaller (i, j))."""
    moves = [(i, j) for i in range(128) for j in range(128)]
    if symmetry:
        moves = [m for m in moves if m <= image(m)]
    gaps = np.linalg.norm(SUPPLY[:, None, :2] - PLANTING[None, :, :2], axis=-1)
    order = np.argsort(gaps, axis=None, kind="stable")
    first = [
        tuple(int(a) for a in np.unravel_index(k, gaps.shape)) for k in (*order[-4:], order[0])
    ]
    if symmetry:
        first = [min(m, image(m)) for m in first]
    rng = np.random.default_rng(seed)
    rest = [moves[k] for k in rng.permutation(len(moves))]
    return list(dict.fromkeys(first + rest))


def plan_row(kin, limits, move: tuple[int, int], toppra: bool = True) -> dict:
    """The move's plan and, with ``toppra``, TOPP-RA's optimum along its path (its CPU time
    apart from the plan's)."""
    i, j = move
    wall, cpu = time.perf_counter(), time.process_time()
    plan = pb.plan_move(kin, SUPPLY[i], PLANTING[j], limits)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    topp, topp_cpu = "", ""
    if toppra:
        topp_cpu = time.process_time()
        topp = pb.toppra_total(kin, plan.nodes, plan.intervals_s, limits)
        topp_cpu = time.process_time() - topp_cpu
    peaks = plan.peaks
    row = {
        "supply": i,
        "planting": j,
        "total_s": plan.total_s,
        **{f"h{k + 1}_s": float(h) for k, h in enumerate(plan.intervals_s)},
        "binding": plan.binding,
        "speed_deg_s": math.degrees(float(peaks["speed"].max())),
        "accel_deg_s2": math.degrees(float(peaks["accel"].max())),
        "jerk_deg_s3": math.degrees(float(peaks["jerk"].max())),
        "torque_nm": float(peaks["torque"].max()),
        "ee_accel_m_s2": float(peaks["ee_accel"].max()),
        "evaluations": plan.evaluations,
        "cpu_s": cpu,
        "wall_s": wall,
        "planned": "direct",
        "toppra_total_s": topp,
        "ratio": plan.total_s / topp if toppra else "",
        "toppra_cpu_s": topp_cpu,
    }
    row["within_limits"] = within(row, limits)
    return _with_cells(row)


def within(row: dict, limits: pb.MoveLimits) -> bool:
    """The plan's peaks within the limits (1e-9 relative: the plan is scaled to 1 + 1e-9)."""
    tol = 1.0 + 1e-9
    return bool(
        math.radians(float(row["speed_deg_s"])) <= limits.joint_speed_rad_s * tol
        and math.radians(float(row["accel_deg_s2"])) <= limits.joint_accel_rad_s2 * tol
        and float(row["torque_nm"]) <= limits.joint_torque_nm * tol
        and float(row["ee_accel_m_s2"]) <= limits.ee_accel_m_s2 * tol
    )


def _with_cells(row: dict) -> dict:
    i, j = int(row["supply"]), int(row["planting"])
    a, b = SUPPLY[i] / MM, PLANTING[j] / MM
    row.update(
        supply_x_mm=float(a[0]), supply_y_mm=float(a[1]), planting_x_mm=float(b[0]),
        planting_y_mm=float(b[1]), distance_mm=float(np.hypot(*(b - a)[:2])),
    )  # fmt: skip
    return row


def mirrored_row(row: dict) -> dict:
    """The image move's row: the same peaks, the intervals reversed, TOPP-RA's optimum the
    same (its path is the image's run backwards: the same limits hold along it, so the same
    fastest traversal; on the reversed grid TOPP-RA's discretised answer differs from the
    original's by its gridding, measured by ``--verify-mirror``)."""
    i, j = image((int(row["supply"]), int(row["planting"])))
    h = np.array([float(row[f"h{k}_s"]) for k in range(6, 0, -1)])
    out = dict(row, supply=i, planting=j, planned="mirror", cpu_s=0.0, wall_s=0.0,
               toppra_cpu_s=0.0 if row.get("toppra_total_s") not in (None, "") else "")  # fmt: skip
    out.update({f"h{k + 1}_s": float(v) for k, v in enumerate(h)}, total_s=float(h.sum()))
    if out.get("toppra_total_s") not in (None, ""):
        out["ratio"] = out["total_s"] / float(out["toppra_total_s"])
    return _with_cells(out)


def read_rows(path: Path) -> dict[tuple[int, int], dict]:
    if not path.exists():
        return {}
    with path.open(newline="") as f:
        return {(int(r["supply"]), int(r["planting"])): r for r in csv.DictReader(f)}


def write_rows(path: Path, rows: dict[tuple[int, int], dict]) -> None:
    """The whole file, atomically (a temporary file beside it, then renamed over it)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        for key in sorted(rows):
            writer.writerow({k: _fmt(rows[key].get(k, "")) for k in FIELDS})
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _fmt(value):
    return repr(value) if isinstance(value, float) else value


def run(args) -> None:
    kin = DeltaKinematics()
    limits = pb.MoveLimits.of(kin)
    _check_layout()
    path = Path(args.out)
    rows = read_rows(path)
    todo = [m for m in move_order(args.seed, not args.no_symmetry) if m not in rows]
    if args.max_moves is not None:
        todo = todo[: args.max_moves]
    print(f"{len(rows)} rows in {path}; planning {len(todo)} moves", flush=True)
    started, since = time.perf_counter(), 0
    for n, move in enumerate(todo, start=1):
        row = plan_row(kin, limits, move, toppra=not args.no_toppra)
        rows[move] = row
        if not args.no_symmetry and image(move) != move:
            rows[image(move)] = mirrored_row(row)
        since += 1
        if since >= args.flush or n == len(todo):
            write_rows(path, rows)
            since = 0
            took = time.perf_counter() - started
            print(
                f"{n}/{len(todo)} planned, {len(rows)} rows, {took:.0f} s, "
                f"{took / n:.3f} s a move (wall)",
                flush=True,
            )
    if len(rows) == 128 * 128:
        report(args)


def verify_mirror(args) -> None:
    """Plan N image moves directly (seeded) and compare with their planned twins."""
    kin = DeltaKinematics()
    limits = pb.MoveLimits.of(kin)
    rows = read_rows(Path(args.out))
    planned = sorted(k for k, r in rows.items() if r["planned"] == "direct" and image(k) != k)
    rng = np.random.default_rng(args.seed + 1)
    pick = [planned[k] for k in rng.choice(len(planned), size=args.verify_mirror, replace=False)]
    diffs, topp = [], []
    for move in pick:
        twin = plan_row(kin, limits, image(move), toppra=not args.no_toppra)
        diffs.append(float(twin["total_s"]) - float(rows[move]["total_s"]))
        print(f"{move} -> {image(move)}: {rows[move]['total_s']} vs {twin['total_s']}")
        if twin["toppra_total_s"] != "" and rows[move].get("toppra_total_s", "") != "":
            topp.append(float(twin["toppra_total_s"]) - float(rows[move]["toppra_total_s"]))
    for name, d in (("plan", diffs), ("TOPP-RA", topp)):
        if d:
            d = np.asarray(d)
            print(
                f"{name}: image planned directly - its twin: max {d.max():+.3e} s, min "
                f"{d.min():+.3e} s, median |d| {np.median(np.abs(d)):.3e} s over {len(d)} moves"
            )


def report(args) -> None:
    rows = read_rows(Path(args.out))
    if not rows:
        sys.exit(f"no rows in {args.out}")
    keys = sorted(rows)
    total = np.array([float(rows[k]["total_s"]) for k in keys])
    ok = np.array([rows[k]["within_limits"] in (True, "True") for k in keys])
    direct = [k for k in keys if rows[k]["planned"] == "direct"]
    cpu = np.array([float(rows[k]["cpu_s"]) for k in direct])
    wall = np.array([float(rows[k]["wall_s"]) for k in direct])
    worst = keys[int(np.argmax(total))]
    best = keys[int(np.argmin(total))]
    bindings: dict[str, int] = {}
    for k in keys:
        bindings[rows[k]["binding"]] = bindings.get(rows[k]["binding"], 0) + 1
    edges = np.round(np.arange(0.60, 1.40001, 0.05), 2)
    counts, _ = np.histogram(total, bins=edges)
    peak = {name: float(max(float(rows[k][name]) for k in keys))
            for name in ("speed_deg_s", "accel_deg_s2", "torque_nm", "ee_accel_m_s2")}  # fmt: skip
    has_topp = [k for k in keys if rows[k].get("toppra_total_s", "") not in ("", None)]
    topp = np.array([float(rows[k]["toppra_total_s"]) for k in has_topp])
    ratio = np.array([float(rows[k]["ratio"]) for k in has_topp])
    topp_cpu = np.array(
        [float(rows[k]["toppra_cpu_s"]) for k in has_topp if rows[k]["planned"] == "direct"]
    )
    summary = {
        "moves": len(keys),
        "planned_directly": len(direct),
        "by_symmetry": len(keys) - len(direct),
        "within_limits": int(ok.sum()),
        "under_paper_1_36_s": int((total < PAPER_LINE_S).sum()),
        "max_total_s": float(total.max()),
        "max_move": {"supply": worst[0], "planting": worst[1],
                     "from_mm": [float(rows[worst][c]) for c in ("supply_x_mm", "supply_y_mm")],
                     "to_mm": [float(rows[worst][c]) for c in ("planting_x_mm", "planting_y_mm")]},
        "min_total_s": float(total.min()),
        "min_move": {"supply": best[0], "planting": best[1]},
        "median_total_s": float(np.median(total)),
        "mean_total_s": float(total.mean()),
        "binding": bindings,
        "largest_peaks": peak,
        "histogram_edges_s": edges.tolist(),
        "histogram_counts": counts.tolist(),
        "cpu_s_per_planned_move": {"median": float(np.median(cpu)), "mean": float(cpu.mean()),
                                   "max": float(cpu.max()), "sum": float(cpu.sum())},
        "wall_s_per_planned_move": {"median": float(np.median(wall)), "mean": float(wall.mean()),
                                    "max": float(wall.max()), "sum": float(wall.sum())},
    }  # fmt: skip
    if len(has_topp):
        low, high = has_topp[int(np.argmin(ratio))], has_topp[int(np.argmax(ratio))]
        redges = np.round(np.arange(1.10, 1.20001, 0.01), 2)
        rcounts, _ = np.histogram(ratio, bins=redges)
        summary["toppra"] = {
            "moves": len(has_topp),
            "max_toppra_total_s": float(topp.max()),
            "min_toppra_total_s": float(topp.min()),
            "median_toppra_total_s": float(np.median(topp)),
            "ratio_min": float(ratio.min()), "ratio_min_move": list(low),
            "ratio_median": float(np.median(ratio)), "ratio_mean": float(ratio.mean()),
            "ratio_max": float(ratio.max()), "ratio_max_move": list(high),
            "ratio_outside_histogram": int(((ratio < redges[0]) | (ratio >= redges[-1])).sum()),
            "ratio_histogram_edges": redges.tolist(),
            "ratio_histogram_counts": rcounts.tolist(),
            "cpu_s_per_planned_move": {"median": float(np.median(topp_cpu)),
                                       "sum": float(topp_cpu.sum())},
        }  # fmt: skip
    data = ROOT / "docs" / "data" / "planner_all_moves.json"
    data.parent.mkdir(parents=True, exist_ok=True)
    tmp = data.with_name(data.name + ".tmp")
    tmp.write_text(json.dumps(summary, indent=1) + "\n")
    os.replace(tmp, data)
    print(json.dumps(summary, indent=1))
    for lo, n in zip(edges[:-1], counts, strict=True):
        print(f"  [{lo:.2f}, {lo + 0.05:.2f}) s: {n}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2 if len(has_topp) else 1, figsize=(12 if len(has_topp) else 7, 4))
    ax = axes[0] if len(has_topp) else axes
    bins = np.arange(0.50, 1.40001, 0.01)
    ax.hist(total, bins=bins, color="C0", alpha=0.8,
            label=f"quintic B-spline, {len(keys)} moves")  # fmt: skip
    if len(has_topp):
        ax.hist(topp, bins=bins, color="C2", alpha=0.6,
                label=f"TOPP-RA on the same paths, {len(has_topp)} moves")  # fmt: skip
    ax.axvline(PAPER_LINE_S, color="r", ls="--", label=f"paper's bound {PAPER_LINE_S} s")
    ax.axvline(total.max(), color="k", ls=":", label=f"max {total.max():.4f} s")
    ax.set_xlabel("move time (s)")
    ax.set_ylabel("moves (0.01 s bins)")
    ax.set_title("Every supply -> planting cell move, default delta, a_ee 8.83 m/s^2")
    ax.legend(fontsize=8)
    if len(has_topp):
        axes[1].hist(ratio, bins=np.arange(1.10, 1.20001, 0.002), color="C1")
        axes[1].axvline(np.median(ratio), color="k", ls=":",
                        label=f"median {np.median(ratio):.4f}")  # fmt: skip
        axes[1].set_xlabel("spline total / TOPP-RA total")
        axes[1].set_ylabel("moves (0.002 bins)")
        axes[1].set_title("The spline's price over the time-optimal traversal")
        axes[1].legend(fontsize=8)
    fig.tight_layout()
    img = ROOT / "docs" / "img" / "planner_all_moves.png"
    fig.savefig(img, dpi=110)
    plt.close(fig)
    print(f"wrote {data.relative_to(ROOT)} and {img.relative_to(ROOT)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "results" / "planner_all_moves.csv"))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-moves", type=int, default=None, help="stop after N (resume later)")
    parser.add_argument("--flush", type=int, default=100, help="rewrite the file every N moves")
    parser.add_argument("--no-symmetry", action="store_true", help="plan all 16 384 directly")
    parser.add_argument("--report", action="store_true", help="only summarise the file")
    parser.add_argument("--verify-mirror", type=int, default=0, metavar="N")
    parser.add_argument(
        "--no-toppra", action="store_true", help="plans only (no TOPP-RA yardstick: faster)"
    )
    args = parser.parse_args()
    logging.disable(logging.WARNING)
    if args.report:
        report(args)
    elif args.verify_mirror:
        verify_mirror(args)
    else:
        run(args)


if __name__ == "__main__":
    main()
