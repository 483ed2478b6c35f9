"""Evidence for the window of live rows (conveyor.live_rows): the same trials with a body per
pot and with the window, compared.

For each seed the scenario runs twice on a belt of --rows rows: with live_rows = rows (a
body per pot) and with live_rows = --live. It prints the pooled success with its interval
and the failure kinds of each, and where every pot stands in its cell when the arm is sent
for it (the approach line): per row, the sd of its offset across the belt (x) and along it
(y) with and without the window, and the two-sample tests (scipy.stats.ks_2samp on the
offsets, levene on their spread) per row and over the rows that entered the window, of every
pot and of the pots met before their trial's first failure (a strike or a lost position moves
pots, differently on each side: chaos, not the belt). Asserts nothing; --json writes every
offset and outcome.

The defaults are the paper scenario's model (pots on 8 feet, the stepper index, a window of
12 on a 24-row belt). Three switches choose what the model does to a pot wherever it is
pushed, with or without the window (docs/performance.md, "Why the far rows drift";
benchmarks/push_drift.py measures them on the belt alone): `--drive pd|stepper`
(`conveyor.index_drive`: the index PD, whose lag grows with the pots it pushes, or the
conveyor stepper's own stiffness and damping), `--feet K` (`pots.feet`: each pot on K sphere
feet, 0 its cylinder on the table) and `--collider libccd` (the pots' cylinders collided with
the table's and ribs' boxes by MuJoCo's libccd instead of its native collider): feet and
libccd each take out the native cylinder-on-box contact that pushes a pot sideways by where it
stands on the table.

    python benchmarks/window_evidence.py paper --rows 24 --live 12 --seeds 1-6 --seedlings 120
    python benchmarks/window_evidence.py paper --set taught.z_low_mm=28 ...
    python benchmarks/window_evidence.py paper --feet 0 --drive pd --rows 16 --live 8 --seedlings 80
    python benchmarks/window_evidence.py paper --feet 0 --collider libccd ...
    python benchmarks/window_evidence.py paper --from-json runs.json   (the tables again)
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter

import mujoco
import numpy as np
from push_drift import STRUCK_M, add_model_args, model_keys  # benchmarks/, beside this
from scipy import stats

from transplanter.machine.pgf import LinePhase
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario, parse_value
from transplanter.studies.stats import parse_seeds, pooled_rate
from transplanter.twin.results import Outcome
from transplanter.twin.sim import LineEventKind, Twin
from transplanter.twin.trial import run_trial


def run(
    scenario: str, overrides: dict, seed: int, seedlings: int, collider: str = "native"
) -> dict:
    """One trial: its outcomes and, per seedling, its pot's offset in its cell (m) when the
    arm is sent for it."""
    config = assemble(
        load_scenario(
            scenario, {**overrides, "scenario.seed": seed, "scenario.seedlings": seedlings}
        )  # fmt: skip
    )
    offsets: dict[int, tuple[float, float]] = {}

    def factory(cfg):
        twin = Twin(cfg)
        if collider == "libccd":
            twin.scene.model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_NATIVECCD)

        def at_approach(event):
            line = event.line
            if event.kind != LineEventKind.SENT or line.phase != LinePhase.APPROACH:
                return
            pot = line.seedling  # seedling i is sent for the pot of cell i
            if pot is None or pot in offsets:
                return
            scene = twin.scene
            where = scene.pot_positions(twin.data)[pot]
            cell = scene.pots.cell_xy[pot] + [0.0, scene.conveyor_position(twin.data)]
            offsets[pot] = (float(where[0] - cell[0]), float(where[1] - cell[1]))

        twin.line_listeners.append(at_approach)
        return twin

    t0 = time.perf_counter()
    result = run_trial(config, twin_factory=factory)
    return {
        "seed": seed,
        "wall_s": time.perf_counter() - t0,
        "sim_s": result.sim_time_s,
        "outcomes": [str(r.outcome) for r in result.per_seedling],
        "offsets": {str(k): v for k, v in sorted(offsets.items())},
    }


def pooled_tests(full: dict, win: dict, live: int, indent: str) -> None:
    """KS and Levene tests of the offsets (mm, per row) pooled over the rows below `live`
    (bodies from the start on both sides) and over the rows that entered the window."""
    rows = sorted(set(full) & set(win))
    groups = {f"rows < {live}": [r for r in rows if r < live],
              f"rows >= {live}": [r for r in rows if r >= live]}  # fmt: skip
    for group, members in groups.items():
        a = np.concatenate([full[r] for r in members] or [np.zeros((0, 2))])
        b = np.concatenate([win[r] for r in members] or [np.zeros((0, 2))])
        if min(len(a), len(b)) < 3:
            print(f"{indent}{group} pooled: n {len(a)}/{len(b)}, too few to test")
            continue
        for axis, label in ((0, "across (x)"), (1, "along (y)")):
            ks = stats.ks_2samp(a[:, axis], b[:, axis]).pvalue
            lev = stats.levene(a[:, axis], b[:, axis]).pvalue
            print(f"{indent}{group} pooled, {label}: n {len(a)}/{len(b)}, mean "
                  f"{a[:, axis].mean():+.2f} / {b[:, axis].mean():+.2f} mm, sd "
                  f"{a[:, axis].std(ddof=1):.2f} / {b[:, axis].std(ddof=1):.2f} mm, "
                  f"KS p {ks:.3f}, Levene p {lev:.3f}")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE")
    parser.add_argument("--rows", type=int, default=24)
    parser.add_argument("--live", type=int, default=12)
    parser.add_argument("--seeds", default="1-6")
    parser.add_argument("--seedlings", type=int, default=120)
    add_model_args(parser)
    parser.add_argument("--collider", choices=("native", "libccd"), default="native")
    parser.add_argument("--json", default=None)
    parser.add_argument("--from-json", default=None, metavar="FILE",
                        help="print the tables of a saved --json, running nothing")  # fmt: skip
    args = parser.parse_args()
    saved = None
    if args.from_json:
        with open(args.from_json) as fh:
            saved = json.load(fh)
        args = argparse.Namespace(**{**saved["args"], "json": None})
    base = dict(kv.split("=", 1) for kv in args.set)
    base = {k: parse_value(v) for k, v in base.items()}
    base["conveyor.rows"] = args.rows
    base.update(model_keys(args))
    modes = {"body per pot": args.rows, f"window of {args.live}": args.live}
    runs: dict[str, list[dict]] = saved["runs"] if saved else {name: [] for name in modes}
    for seed in [] if saved else parse_seeds(args.seeds):
        for name, live in modes.items():
            runs[name].append(run(args.scenario, {**base, "conveyor.live_rows": live}, seed,
                                  args.seedlings, args.collider))  # fmt: skip
            r = runs[name][-1]
            print(f"  seed {seed} {name}: {r['wall_s']:.1f} s wall, "
                  f"{Counter(r['outcomes']).most_common()}", flush=True)  # fmt: skip
    print(f"{args.scenario} {' '.join(args.set)}, {args.rows} rows, seeds {args.seeds}, "
          f"{args.seedlings} seedlings each, {model_keys(args) or 'scenario drive and feet'}, "
          f"collider {args.collider}")  # fmt: skip
    for name, trials in runs.items():
        ok = [sum(o == Outcome.SUCCESS for o in t["outcomes"]) for t in trials]
        pooled = pooled_rate(ok, [len(t["outcomes"]) for t in trials])
        kinds = Counter(o for t in trials for o in t["outcomes"])
        lo, hi = pooled.ci95
        print(f"{name:>14}: {pooled.successes}/{pooled.seedlings} = "
              f"{100 * pooled.success_rate:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}]  "
              f"{dict(sorted(kinds.items()))}")  # fmt: skip
    cols = 5
    by_row: dict[str, dict[int, list]] = {name: {} for name in modes}
    # the same, of the pots the arm was sent for before its trial's first failure (a strike or
    # a lost position then moves pots on both sides, and differently: chaos, not the belt)
    clean: dict[str, dict[int, list]] = {name: {} for name in modes}
    struck = Counter()
    for name, trials in runs.items():
        for t in trials:
            first = next((i for i, o in enumerate(t["outcomes"]) if o != Outcome.SUCCESS),
                         len(t["outcomes"]))  # fmt: skip
            for pot, xy in t["offsets"].items():
                if max(abs(v) for v in xy) > STRUCK_M:  # struck out of its cell: not an offset
                    struck[name] += 1
                    continue
                by_row[name].setdefault(int(pot) // cols, []).append(xy)
                if int(pot) < first:
                    clean[name].setdefault(int(pot) // cols, []).append(xy)
    full, win = ({r: np.array(v) * 1e3 for r, v in by_row[n].items()} for n in modes)
    print(f"pots struck out of their cells, left out: {dict(struck) or 'none'}")
    print(
        "row  n  sd x (mm) full / window  sd y (mm) full / window  KS p (x)  Levene p (x)"
        "  mean x (mm) full / window"
    )
    rows = sorted(set(full) & set(win))
    for row in rows:
        a, b = full[row], win[row]
        ks = stats.ks_2samp(a[:, 0], b[:, 0]).pvalue
        lev = stats.levene(a[:, 0], b[:, 0]).pvalue
        print(f"{row:>3} {len(a):>3}  {a[:, 0].std(ddof=1):5.2f} / {b[:, 0].std(ddof=1):5.2f}"
              f"             {a[:, 1].std(ddof=1):5.2f} / {b[:, 1].std(ddof=1):5.2f}"
              f"             {ks:6.3f}    {lev:6.3f}"
              f"       {a[:, 0].mean():+5.2f} / {b[:, 0].mean():+5.2f}")  # fmt: skip
    pooled_tests(full, win, args.live, "")
    print("pots met before their trial's first failure:")
    pooled_tests(*({r: np.array(v) * 1e3 for r, v in clean[n].items()} for n in modes),
                 args.live, "  ")  # fmt: skip
    for name, trials in runs.items():
        wall = sum(t["wall_s"] for t in trials)
        sim = sum(t["sim_s"] for t in trials)
        print(f"{name:>14}: {wall:.0f} s wall for {sim:.0f} s simulated ({sim / wall:.1f}x)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"args": vars(args), "runs": runs}, fh)


if __name__ == "__main__":
    main()
