"""Benchmark: the serial arm's jobs (seed 004): the tomatoes to the belt (`serial_arm`) and the
pot line (`serial_arm_pots`): wall time, simulated time, real-time factor and the cycle they
simulated.

Prints numbers; asserts nothing. Runs `twin.serial_arm.run_pick_place` and
`twin.serial_pots.run_serial_pots` on the packaged scenarios, one seed after another in this
process (one core), with any `--set KEY=VALUE` overrides (applied to both).

    python benchmarks/bench_serial_arm.py [--seeds 1] [--seedlings 10]
"""

from __future__ import annotations

import argparse
import time

from transplanter.cli.common import _overrides
from transplanter.scenario.schema import load_scenario
from transplanter.twin.serial_arm import run_pick_place
from transplanter.twin.serial_pots import run_serial_pots


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1", help="comma-separated seeds, e.g. 1,2")
    parser.add_argument("--seedlings", type=int, default=10, help="pots of the pot line")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    over = _overrides(args)
    tomatoes = load_scenario("serial_arm", over)
    pots = load_scenario("serial_arm_pots", {**over, "scenario.seedlings": args.seedlings})
    print("job            seed  picks  simulated s  wall s  real-time factor  cycle s")
    for seed in (int(s) for s in args.seeds.split(",")):
        t0 = time.perf_counter()
        records, totals, _, _ = run_pick_place(tomatoes, seed)
        wall = time.perf_counter() - t0
        sim = max((r.end_s or 0.0 for r in records), default=0.0)
        print(
            f"{'tomatoes':<13}  {seed:>4}  {totals['picked']:>5}  {sim:>11.1f}  {wall:>6.1f}  "
            f"{sim / wall:>15.2f}x  {totals['cycle_time_s']:>7.2f}"
        )
        r = run_serial_pots(pots, seed)
        print(
            f"{'pot line':<13}  {seed:>4}  {r.seedlings:>5}  {r.sim_time_s:>11.1f}  "
            f"{r.wall_s:>6.1f}  {r.sim_time_s / r.wall_s:>15.2f}x  {r.cycle_time_s:>7.2f}"
        )


if __name__ == "__main__":
    main()
