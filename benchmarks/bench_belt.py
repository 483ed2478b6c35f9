"""Benchmark: a trial's cost against the belt's length, a long soak, and its start-up.

Each measurement runs in a fresh Python process (`--one`), as a user's `transplanter trial`
does, so its peak memory and its start-up (imports, the scene's compile, the first physics
step) are its own. Prints numbers; asserts nothing.

- cost against the belt: the paper scenario with `conveyor.rows` = 8, 24, 100 and 400 and the
  same seedlings (--seedlings, default 40), with the scenario's window of live rows
  (`conveyor.live_rows`, 12 in `paper.toml`; --live 12,16 for others) and, for the belts up to
  --full-up-to rows, with a body per pot (live_rows = rows): wall time per seedling,
  real-time factor, peak memory, and the share of the wall time spent starting (imports,
  compile, first step);
- with --soak N: N seedlings on a 100-row belt (live_rows: the first of --live) beside the
  40-seedling paper trial of the same run: real-time factor (and its ratio to the paper
  trial's), peak memory, and the first and last 100 seedlings' success, failure kinds and
  cycle time (`--set recovery.stall_detection=true`: the machine re-homes after a stall, as a
  production machine would over 500 seedlings; the paper's open-loop arm fails every pick
  after its first lost position, docs/performance.md "The soak on the default").

Real-time factors are given on wall time and on the process's CPU time (on a machine shared
with other work the wall time measures the neighbours too).

    python benchmarks/bench_belt.py [--rows 8,24,100,400] [--seedlings 40] [--soak 500]
    python benchmarks/bench_belt.py --rows 100 --live 6,8 --set pots.feet=0 \
        --set conveyor.index_drive=pd          (the pots on cylinders, the PD index)
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from collections import Counter

T0 = time.perf_counter()


def one(rows: int, live_rows: int, seedlings: int, seed: int, sets: dict | None = None) -> dict:
    """One trial in this process: its timings, memory and per-seedling outcomes."""
    import resource

    import mujoco

    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import load_scenario
    from transplanter.twin.results import Outcome
    from transplanter.twin.sim import Twin
    from transplanter.twin.trial import run_trial

    t_import = time.perf_counter()
    config = assemble(
        load_scenario(
            "paper",
            {
                **(sets or {}),
                "conveyor.rows": rows,
                "conveyor.live_rows": live_rows,
                "scenario.seedlings": seedlings,
                "scenario.seed": seed,
            },
        )  # fmt: skip
    )
    first_step: list[float] = []

    def factory(cfg):
        twin = Twin(cfg)
        t = time.perf_counter()
        first_step.append(t)  # compiled; the first step is timed on a copy of its data
        scratch = mujoco.MjData(twin.model)
        mujoco.mj_copyData(scratch, twin.model, twin.data)
        mujoco.mj_step(twin.model, scratch)
        first_step.append(time.perf_counter())
        return twin

    t_run, cpu_run = time.perf_counter(), time.process_time()
    result = run_trial(config, twin_factory=factory)
    t_end, cpu_end = time.perf_counter(), time.process_time()
    return {
        "rows": rows,
        "live_rows": live_rows,
        "seedlings": seedlings,
        "import_s": t_import - T0,
        "build_s": first_step[0] - t_run,
        "first_step_s": first_step[1] - first_step[0],
        "wall_s": t_end - T0,
        "trial_wall_s": result.wall_time_s,
        "trial_cpu_s": cpu_end - cpu_run,
        "sim_s": result.sim_time_s,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "success": [r.outcome == Outcome.SUCCESS for r in result.per_seedling],
        "outcome": [r.outcome.value for r in result.per_seedling],
        "cycle_s": [r.cycle_time_s for r in result.per_seedling],
    }


def measure(rows: int, live_rows: int, seedlings: int, seed: int, sets: list[str]) -> dict:
    """One trial in a fresh process; `sets`: its --set SECTION.KEY=VALUE."""
    flags = [arg for kv in sets for arg in ("--set", kv)]
    out = subprocess.run(
        [sys.executable, __file__, "--one", f"{rows},{live_rows},{seedlings},{seed}", *flags],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


def parse_sets(sets: list[str]) -> dict:
    """--set SECTION.KEY=VALUE arguments as scenario overrides."""
    from transplanter.scenario.schema import parse_value

    return {k: parse_value(v) for k, v in (kv.split("=", 1) for kv in sets)}


def scenario_live_rows(sets: list[str]) -> int:
    """The paper scenario's conveyor.live_rows with these --set keys."""
    from transplanter.scenario.schema import load_scenario

    return load_scenario("paper", parse_sets(sets)).conveyor.live_rows


def line(r: dict) -> str:
    start = r["import_s"] + r["build_s"] + r["first_step_s"]
    return (
        f"{r['rows']:>4} rows, live_rows {r['live_rows']:>3}: {r['wall_s']:7.1f} s for "
        f"{r['seedlings']} seedlings = {r['wall_s'] / r['seedlings']:6.3f} s/seedling, "
        f"{r['sim_s'] / r['trial_wall_s']:5.1f}x real time ({r['sim_s'] / r['trial_cpu_s']:5.1f}x "
        f"on CPU time), peak {r['peak_mb']:5.0f} MB, "
        f"start-up {start:4.2f} s ({100 * start / r['wall_s']:4.1f} %: imports "
        f"{r['import_s']:.2f}, compile {r['build_s']:.2f}, first step {r['first_step_s']:.4f})"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", help=argparse.SUPPRESS)
    parser.add_argument("--rows", default="8,24,100,400", help="belts to run ('' for none)")
    parser.add_argument(
        "--live", default="", help="live_rows for each belt, e.g. 12,16 (default: the scenario's)"
    )
    parser.add_argument("--seedlings", type=int, default=40)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--full-up-to", type=int, default=24,
                        help="also run belts up to this many rows with a body per pot")  # fmt: skip
    parser.add_argument("--soak", type=int, default=0, help="seedlings of the 100-row soak")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="a scenario key for every trial (e.g. pots.feet=8)")  # fmt: skip
    args = parser.parse_args()
    if args.one:
        rows, live, seedlings, seed = (int(x) for x in args.one.split(","))
        print(json.dumps(one(rows, live, seedlings, seed, parse_sets(args.set))))
        return
    print(f"paper scenario {' '.join(args.set)}, seed {args.seed}, one process per trial")
    lives = [int(x) for x in args.live.split(",") if x] or [scenario_live_rows(args.set)]
    for rows in (int(x) for x in args.rows.split(",") if x):
        # live_rows >= rows is the belt without a window: run it once, as live_rows = rows
        for live in sorted({min(live, rows) for live in lives}):
            print(line(measure(rows, live, args.seedlings, args.seed, args.set)), flush=True)
        if max(lives) < rows <= args.full_up_to:
            print(line(measure(rows, rows, args.seedlings, args.seed, args.set)), flush=True)
    if args.soak:
        paper = measure(8, 8, 40, args.seed, args.set)
        soak = measure(100, lives[0], args.soak, args.seed, args.set)  # the first --live
        print(line(paper))
        print(line(soak))
        for clock in ("wall", "cpu"):
            rtf_paper = paper["sim_s"] / paper[f"trial_{clock}_s"]
            rtf_soak = soak["sim_s"] / soak[f"trial_{clock}_s"]
            print(f"soak real-time factor ({clock} time) {rtf_soak:.1f}x against the paper "
                  f"trial's {rtf_paper:.1f}x: ratio {rtf_paper / rtf_soak:.2f}")  # fmt: skip
        counts = []
        for label, part in (("first 100", slice(0, 100)), ("last 100", slice(-100, None))):
            ok = soak["success"][part]
            counts.append((sum(ok), len(ok) - sum(ok)))
            cycles = [c for c in soak["cycle_s"][part] if c is not None]
            clean = sorted(c for c, s in zip(soak["cycle_s"][part], ok, strict=True) if s)
            kinds = Counter(o for o in soak["outcome"][part] if o != "success")
            print(f"{label}: {sum(ok)}/{len(ok)} success, mean cycle "
                  f"{sum(cycles) / len(cycles):.4f} s (min {min(cycles):.4f}, max "
                  f"{max(cycles):.4f}; the successes' median {clean[len(clean) // 2]:.4f}), "
                  f"failures {dict(kinds) or 'none'}")  # fmt: skip
        from scipy.stats import fisher_exact

        print(
            f"first against last 100: Fisher's exact p {fisher_exact(counts).pvalue:.3f} "
            "(failures cluster after a strike: read it with the kinds)"
        )


if __name__ == "__main__":
    main()
