"""Where the conveyor's index pushes leave the pots: the belt alone, pushed N times.

No arm, no firmware: the paper scenario's scene on a belt of --rows rows, each seed's pots at
rest in their cells, then --indexes indexes of the conveyor (`scene.ConveyorDrive`, the
scenario's index time), each followed by 1.5 s at rest. After every index it records each pot's
offset in its cell (across the belt, x, and along it, y; mm), how far the carriage lagged its
index profile, and how many index pushes the pot has had in the physics. Pots of the two rows
nearest the pickup and pots struck out of their cells are left out. Prints, per push count,
the mean and sd of the offsets (and the mean across the belt of the pots of the near and of
the far half of the belt, by their rows as built); per column, the mean across the belt after
a pot's first push; per row, after the last index; and the lag. Asserts nothing.

It separates what the window of live rows (`conveyor.live_rows`) changes from what the model
does wherever a pot is pushed (docs/performance.md, "Why the far rows drift"):

- `--live L` (< rows): the window, as a trial has it (rows enter as slots free up);
- `--drive pd|stepper`: `SceneConfig.conveyor_index_drive`, the index PD (`conveyor_kp_n_m`,
  `conveyor_kd_n_s_m`) or the conveyor stepper's own stiffness and damping about a set point
  that follows the profile;
- `--collider libccd`: MuJoCo's convex collider for the pots' cylinders against the boxes of
  the table and ribs is libccd (`mjDSBL_NATIVECCD`) instead of its native one;
- `--table-shift M`: the belt table's box is M metres longer beyond the far end of the belt
  (its top and front edge where they were; only its centre moves);
- `--feet K`: `SceneConfig.pot_feet`, each pot on a ring of K sphere feet inside its base
  that alone touch the table (0: its cylinder stands on the table's box).

    python benchmarks/push_drift.py --rows 24 --seeds 1-6 --indexes 8
    python benchmarks/push_drift.py --rows 24 --live 8 --seeds 1-6 --indexes 8
    python benchmarks/push_drift.py --rows 24 --seeds 1-6 --collider libccd
    python benchmarks/push_drift.py --rows 32 --live 12 --drive stepper --feet 8 --indexes 16
"""

from __future__ import annotations

import argparse
import json
import time

import mujoco
import numpy as np

from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.scene import ConveyorDrive, build_scene
from transplanter.scene.config import INDEX_DRIVES
from transplanter.studies.stats import parse_seeds

REST_S = 1.5  # at rest after each index, before the pots' offsets are read
STRUCK_M = 0.006  # a pot this far across the belt from its cell centre was struck out of it


def add_model_args(parser: argparse.ArgumentParser) -> None:
    """--drive and --feet: the scenario keys conveyor.index_drive and pots.feet."""
    parser.add_argument("--drive", choices=INDEX_DRIVES, default=None,
                        help="conveyor.index_drive (default: the scenario's)")  # fmt: skip
    parser.add_argument("--feet", type=int, default=None, metavar="K",
                        help="pots.feet (0: cylinders; default: the scenario's)")  # fmt: skip


def model_keys(args: argparse.Namespace) -> dict:
    """The scenario keys --drive and --feet stand for (none when left out)."""
    keys = {} if args.drive is None else {"conveyor.index_drive": args.drive}
    return keys if args.feet is None else {**keys, "pots.feet": args.feet}


def run(args: argparse.Namespace, seed: int) -> dict:
    """One seed's belt pushed args.indexes times: per index, every pot's offset (m), whether
    it was a body and the pushes it has had as one; the carriage's largest lag (m)."""
    overrides = {"scenario.seed": seed, "conveyor.rows": args.rows,
                 "conveyor.live_rows": args.live or args.rows, **model_keys(args)}  # fmt: skip
    config = assemble(load_scenario(args.scenario, overrides))
    cfg = config.scene
    scene = build_scene(cfg, seed=seed)
    m = scene.model
    if args.collider == "libccd":
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_NATIVECCD)
    if args.table_shift:
        g = m.geom("belt_table").id
        m.geom_size[g, 1] += args.table_shift / 2
        m.geom_pos[g, 1] += args.table_shift / 2
        m.geom_aabb[g, 4] += args.table_shift / 2
        m.geom_rbound[g] = float(np.linalg.norm(m.geom_size[g]))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    drive = ConveyorDrive(scene)
    rest_steps = round(REST_S / m.opt.timestep)
    for _ in range(rest_steps // 3):
        mujoco.mj_step(m, d)
    n = cfg.rows * cfg.cols
    pushes = np.zeros(n, dtype=int)
    out = []
    for _ in range(args.indexes):
        if scene.window is not None:
            scene.window.on_index(d)
        live = np.zeros(n, bool)
        live[scene.window.live() if scene.window is not None else slice(None)] = True
        pushes[~live] = 0
        drive.start(d, d.time, config.machine.sgf.conveyor_index_s)
        lag = 0.0
        while drive.armed(d):
            drive.apply(d, d.time)
            q_ref, _ = drive.reference(d, d.time)
            lag = max(lag, abs(q_ref - d.qpos[scene.conveyor_qpos_adr]))
            mujoco.mj_step(m, d)
        pushes[live] += 1
        for _ in range(rest_steps):
            mujoco.mj_step(m, d)
        where = scene.pot_positions(d)
        cell = scene.pots.cell_xy + [0.0, scene.conveyor_position(d)]
        out.append({"offset": (where[:, :2] - cell).tolist(), "live": live.tolist(),
                    "pushes": pushes.tolist(), "lag": lag})  # fmt: skip
    return {"seed": seed, "cols": cfg.cols, "indexes": out}


def tally(seeds: list[dict], rows: int) -> tuple[dict, dict, dict, list]:
    """The offsets (mm) of run()'s seeds: by the pushes a pot has had, (x, y, on the far half
    of the belt as built); after the last index, x by row; after a pot's first push, x by
    column; and every index's lag (m). The two rows at the pickup, waiting pots and pots
    struck out of their cells (STRUCK_M across) are left out."""
    by_push: dict[int, list] = {}
    last: dict[int, list] = {}
    first_by_col: dict[int, list] = {}
    lags = []
    for s in seeds:
        cols = s["cols"]
        for i, rec in enumerate(s["indexes"]):
            lags.append(rec["lag"])
            off = np.array(rec["offset"]) * 1e3
            for pot, (x, y) in enumerate(off):
                row = pot // cols
                if row < i + 3 or not rec["live"][pot] or abs(x) > STRUCK_M * 1e3:
                    continue  # the two rows at the pickup, a waiting pot, a struck pot
                far = row >= rows // 2  # on the far half of the belt as built
                by_push.setdefault(rec["pushes"][pot], []).append((x, y, far))
                if i == len(s["indexes"]) - 1:
                    last.setdefault(row, []).append(x)
                if rec["pushes"][pot] == 1:
                    first_by_col.setdefault(pot % cols, []).append(x)
    return by_push, last, first_by_col, lags


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="paper")
    parser.add_argument("--rows", type=int, default=24)
    parser.add_argument("--live", type=int, default=0, help="live rows (0: a body per pot)")
    parser.add_argument("--seeds", default="1-6")
    parser.add_argument("--indexes", type=int, default=8)
    add_model_args(parser)
    parser.add_argument("--collider", choices=("native", "libccd"), default="native")
    parser.add_argument("--table-shift", type=float, default=0.0, metavar="M")
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    t0 = time.perf_counter()
    seeds = [run(args, seed) for seed in parse_seeds(args.seeds)]
    by_push, last, first_by_col, lags = tally(seeds, args.rows)
    print(f"{args.scenario}, {args.rows} rows, "
          f"{'window of ' + str(args.live) if args.live else 'a body per pot'}, "
          f"{model_keys(args) or 'the scenario drive and feet'}, collider {args.collider}, "
          f"table shift {args.table_shift} m, "
          f"seeds {args.seeds}, {args.indexes} indexes")  # fmt: skip
    print(
        "pushes    n   across: mean   sd (mm)   along: mean   sd (mm)"
        "   across, mean: near half / far half of the belt (mm)"
    )
    for k in sorted(by_push):
        v = np.array(by_push[k])
        far = v[:, 2] > 0
        halves = " / ".join(f"{v[h, 0].mean():+.2f}" if h.any() else "-" for h in (~far, far))
        print(f"{k:>6} {len(v):>4}   {v[:, 0].mean():+12.2f} {v[:, 0].std():5.2f}"
              f"   {v[:, 1].mean():+11.2f} {v[:, 1].std():5.2f}   {halves:>18}")  # fmt: skip
    print("after a pot's first push, mean across the belt per column, -x to +x (mm):")
    print("  " + "  ".join(f"{np.mean(v):+.2f}" for _, v in sorted(first_by_col.items())))
    print("after the last index, mean across the belt per row (mm):")
    print("  " + "  ".join(f"{r}: {np.mean(v):+.2f}" for r, v in sorted(last.items())))
    print(
        f"carriage lag behind its profile: median {1e3 * np.median(lags):.2f} mm, "
        f"largest {1e3 * max(lags):.2f} mm; {time.perf_counter() - t0:.0f} s wall"
    )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"args": vars(args), "seeds": seeds}, fh)


if __name__ == "__main__":
    main()
