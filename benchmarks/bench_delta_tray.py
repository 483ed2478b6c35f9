"""Benchmark: one tray of the delta's cull-and-refill trial (`delta_refill`): wall time,
simulated time, real-time factor and the time per operation it simulated.

Prints numbers; asserts nothing. Runs `transplanter.twin.delta_refill.run_delta_refill` on the
packaged scenario, one seed after another in this process (one core), with the scenario's
own settings and any `--set KEY=VALUE` overrides.

    python benchmarks/bench_delta_tray.py [--seeds 1] [--set delta_refill.pose_judgement=false]

The scenario grades the trays from pictures (`delta_refill.vision = "pipeline"`): headless,
run it with MUJOCO_GL=egl (or osmesa), or add --set delta_refill.vision=truth.
"""

from __future__ import annotations

import argparse

from transplanter.cli.common import _overrides
from transplanter.scenario.schema import load_scenario
from transplanter.twin.delta_refill import run_delta_refill


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1", help="comma-separated seeds, e.g. 1,2")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    scenario = load_scenario("delta_refill", _overrides(args))  # --set as the CLI reads it
    print("seed  operations  simulated s  wall s  real-time factor  s per operation")
    for seed in (int(s) for s in args.seeds.split(",")):
        r = run_delta_refill(scenario, seed=seed)
        print(
            f"{seed:>4}  {r.operations:>10}  {r.sim_time_s:>11.1f}  {r.wall_time_s:>6.1f}  "
            f"{r.sim_time_s / r.wall_time_s:>15.2f}x  {r.time_per_operation_s:>15.2f}"
        )


if __name__ == "__main__":
    main()
