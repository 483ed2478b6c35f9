"""How many index pushes it takes for a pot's offset in its cell to stop changing: the cap
of the pushes a windowed scene runs for an entering row (scene.row_pushes.PUSH_CAP).

Runs the side model of scene.row_pushes (one row of the belt: its pots, ribs, table and the
index motion, the ballast of the rest of the belt) on the rows --first.. of a belt of --rows
rows, each row pushed by the belt's first --pushes indexes,
for each seed, and prints, after each push n, the mean and sd of the offsets across (x) and
along (y) the belt, and the two-sample KS p of the x offsets after n pushes against after the
last push and against after n + 4 (scipy.stats.ks_2samp; the same pots, so the p values are
a guide, not a test). Asserts nothing; --json writes every offset.

    python benchmarks/push_cap.py paper --rows 40 --first 24 --pushes 24 --seeds 1-3
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from scipy import stats

from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario, parse_value
from transplanter.scene import build_scene
from transplanter.scene.row_pushes import RowPushes
from transplanter.studies.stats import parse_seeds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE")
    parser.add_argument("--rows", type=int, default=40)
    parser.add_argument("--first", type=int, default=24)
    parser.add_argument("--pushes", type=int, default=24)
    parser.add_argument("--seeds", default="1-3")
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    overrides = {k: parse_value(v) for k, v in (kv.split("=", 1) for kv in args.set)}
    overrides |= {"conveyor.rows": args.rows, "conveyor.live_rows": args.rows}
    t0 = time.perf_counter()
    poses = []  # (pushes + 1, cols, 7) per row
    for seed in parse_seeds(args.seeds):
        config = assemble(load_scenario(args.scenario, {**overrides, "scenario.seed": seed}))
        side = RowPushes(build_scene(config.scene, seed))
        index_s = config.machine.sgf.conveyor_index_s
        for row in range(args.first, args.rows):
            poses.append(side.push(row, range(1, args.pushes + 1), index_s))
    wall = time.perf_counter() - t0
    xy = np.concatenate(poses, axis=1)[:, :, :2] * 1e3  # (pushes + 1, pots, 2) mm
    n_push = len(poses) * args.pushes
    print(f"{args.scenario} {' '.join(args.set)}: {xy.shape[1]} pots, {args.pushes} pushes "
          f"each, {wall:.0f} s ({1e3 * wall / n_push:.0f} ms a push)")  # fmt: skip
    print("push  x mean   x sd  y mean   y sd  KS p vs last  KS p vs n+4")
    last = xy[-1, :, 0]
    for n in range(args.pushes + 1):
        x, y = xy[n, :, 0], xy[n, :, 1]
        p_last = stats.ks_2samp(x, last).pvalue
        p_next = stats.ks_2samp(x, xy[n + 4, :, 0]).pvalue if n + 4 <= args.pushes else np.nan
        print(f"{n:>4} {x.mean():7.2f} {x.std(ddof=1):6.2f} {y.mean():7.2f} "
              f"{y.std(ddof=1):6.2f}  {p_last:12.3f}  {p_next:11.3f}")  # fmt: skip
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"args": vars(args), "xy_mm": xy.tolist()}, fh)


if __name__ == "__main__":
    main()
