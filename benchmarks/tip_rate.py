"""How often an index push tips a pot over, on the full belt and in the window's side model
(docs/performance.md, "Evidence"): pots whose axis leans more than 8 deg after a push.

``full``: a belt of --rows rows with a body per pot, indexed --pushes times by its drive
alone (no arm), every pot still on the belt's top run counted after each push.
``side``: the side model (scene.row_pushes.RowPushes) running, for every row from 8 on, the
pushes a window of 8 live rows skips on that belt (row_pushes.modelled_indexes).
Prints the pot-pushes counted and the (row, column[, push]) of each pot that tipped.

    python benchmarks/tip_rate.py full --seed 1 --pushes 30
    python benchmarks/tip_rate.py side --seed 1
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.scene import build_scene
from transplanter.scene.conveyor import ConveyorDrive
from transplanter.scene.row_pushes import RowPushes, modelled_indexes

TIPPED_DEG = 8.0


def tilt_deg(quat_xy: np.ndarray) -> np.ndarray:
    """The angle (deg) between a pot's axis and the vertical, from its quaternion's x, y."""
    return np.degrees(np.arccos(np.clip(1 - 2 * (quat_xy**2).sum(axis=-1), -1, 1)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("full", "side"))
    parser.add_argument("--scenario", default="paper")
    parser.add_argument("--rows", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--pushes", type=int, default=30, help="full: indexes to run")
    args = parser.parse_args()
    over = {"conveyor.rows": args.rows, "conveyor.live_rows": args.rows, "scenario.seed": args.seed}
    config = assemble(load_scenario(args.scenario, over))
    scene = build_scene(config.scene, args.seed)
    index_s = config.machine.sgf.conveyor_index_s
    cols = config.scene.cols
    t0, tips, n = time.perf_counter(), [], 0
    if args.mode == "side":
        side = RowPushes(scene)
        for row in range(8, args.rows - 1):
            indexes = list(modelled_indexes(row, row - 7))
            if not indexes:
                continue
            poses = side.push(row, indexes, index_s)
            tilt = tilt_deg(poses[1:, :, 4:6])
            n += tilt.size
            tips += [(row, c) for c in range(cols) if (tilt[:, c] > TIPPED_DEG).any()]
    else:
        m = scene.model
        d = mujoco.MjData(m)
        if m.nkey:
            mujoco.mj_resetDataKeyframe(m, d, 0)
        mujoco.mj_forward(m, d)
        drive = ConveyorDrive(scene)
        adr = {(r, c): m.jnt_qposadr[m.body_jntadr[m.body(f"pot_{r}_{c}").id]]
               for r in range(args.rows) for c in range(cols)}  # fmt: skip
        seen = set()
        for i in range(1, args.pushes + 1):
            drive.start(d, d.time, index_s)
            while drive.armed(d):
                drive.apply(d, d.time)
                mujoco.mj_step(m, d)
            end = d.time + 1.0  # rest until the belt lies still
            while d.time < end:
                for _ in range(10):
                    mujoco.mj_step(m, d)
                if np.abs(d.qvel).max() < 1e-3:
                    break
            for (r, c), a in adr.items():
                if r <= i:  # past the belt's top run by now
                    continue
                n += 1
                if (r, c) not in seen and tilt_deg(d.qpos[a + 4 : a + 6]) > TIPPED_DEG:
                    seen.add((r, c))
                    tips.append((r, c, i))
    print(f"{args.mode}, seed {args.seed}, {args.rows} rows: {n} pot-pushes, "
          f"{len(tips)} tipped {tips} ({time.perf_counter() - t0:.0f} s)")  # fmt: skip


if __name__ == "__main__":
    main()
