"""Do the solver's knobs move the pooled success rate? (sleep, timestep; issue: trust at the edge)

Runs the paper scenario at the paper's approach height and at two edge heights, over several
seeds, with sleeping on and off and three timesteps, and prints for each setting the pooled
success with its interval from the spread between trials (transplanter.stats). A single
trial may change with a knob (a different contact order, a strike one step earlier); the
pooled rates must agree within their intervals.

    python benchmarks/study_solver_knobs.py [--seeds 1-5] [--seedlings 20] [--workers 2]
"""

from __future__ import annotations

import argparse
import itertools
import time
from concurrent.futures import ProcessPoolExecutor

from transplanter.config import assemble
from transplanter.scenario import load_scenario
from transplanter.stats import parse_seeds, pooled_rate
from transplanter.trial import run_trial

HEIGHTS_MM = (34.0, 30.0, 28.0)  # the paper's Z_low, and two edge settings
KNOBS = (
    ("sleep on, 1 ms", {"physics.sleep": True, "physics.timestep_ms": 1.0}),
    ("sleep off, 1 ms", {"physics.sleep": False, "physics.timestep_ms": 1.0}),
    ("sleep on, 0.5 ms", {"physics.sleep": True, "physics.timestep_ms": 0.5}),
    ("sleep on, 2 ms", {"physics.sleep": True, "physics.timestep_ms": 2.0}),
)


def one(job):
    z_low, knob, seed, seedlings = job
    over = {"taught.z_low_mm": z_low, "scenario.seed": seed, "scenario.seedlings": seedlings}
    over.update(dict(KNOBS)[knob])
    t0 = time.perf_counter()
    r = run_trial(assemble(load_scenario("paper", over)))
    return z_low, knob, seed, r.successes, r.seedlings, r.valid, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1-5")
    parser.add_argument("--seedlings", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    jobs = [
        (z, k, s, args.seedlings) for z, (k, _), s in itertools.product(HEIGHTS_MM, KNOBS, seeds)
    ]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(one, jobs))
    print("| Z_low | knob | per seed | pooled | 95 % CI | wall s |")
    print("| --- | --- | --- | --- | --- | --- |")
    for z, (knob, _) in itertools.product(HEIGHTS_MM, KNOBS):
        sel = [r for r in rows if r[0] == z and r[1] == knob]
        p = pooled_rate([r[3] for r in sel], [r[4] for r in sel])
        per_seed = " ".join(f"{r[3]}" + ("" if r[5] else "!") for r in sel)
        wall = sum(r[6] for r in sel)
        print(
            f"| {z:g} mm | {knob} | {per_seed} | {100 * p.success_rate:.1f} % "
            f"| {100 * p.ci95[0]:.1f}-{100 * p.ci95[1]:.1f} % | {wall:.0f} |"
        )


if __name__ == "__main__":
    main()
