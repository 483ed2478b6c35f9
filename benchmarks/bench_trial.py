"""Benchmark: the paper trial's wall time, real-time factor and pipeline overhead.

Prints numbers; asserts nothing. The overhead ratio compares the whole twin (firmware, bus,
per-move command generation, trial monitoring) with bare `mj_step` on the same scene fed the
same recorded actuator commands, i.e. the cost of our own code per physics step.

    python benchmarks/bench_trial.py [--seedlings N] [--record]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

from transplanter.config import assemble
from transplanter.scenario import load_scenario
from transplanter.sim import Twin
from transplanter.trial import run_trial

TARGET_WALL_S = 10.0  # issue 4: the 40-seedling paper trial in under 10 s wall on one core


def bare_replay(config, seconds: float) -> tuple[float, int]:
    """Run the twin once to log its commands, then time bare mj_step on the same commands."""
    twin = Twin(config)
    rows: list[np.ndarray] = []
    twin.step_until(
        seconds, monitor=lambda tw, i: rows.append(tw.data.ctrl.copy()), monitor_every=1
    )
    ctrl = np.array(rows)
    fresh = Twin(config)
    m, d = fresh.model, fresh.data
    t0 = time.perf_counter()
    for row in ctrl:
        d.ctrl[:] = row
        mujoco.mj_step(m, d)
    return time.perf_counter() - t0, ctrl.shape[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seedlings", type=int, default=40)
    parser.add_argument("--record", action="store_true", help="also time a 60 Hz recording")
    args = parser.parse_args()
    config = assemble(load_scenario("paper", {"scenario.seedlings": args.seedlings}))

    result = run_trial(config)
    d = result.to_dict()
    steps = round(result.sim_time_s / config.scene.timestep)
    print(f"paper trial, {d['seedlings']} seedlings, seed {d['seed']}")
    print(f"  success rate         {100 * d['success_rate']:.1f} %  failures {d['failures']}")
    print(f"  cycle time           {d['cycle_time_s']:.3f} s (sd {d['cycle_time_sd_s']:.3f})")
    print(f"  simulated time       {result.sim_time_s:.1f} s ({steps} physics steps)")
    print(f"  wall time            {result.wall_time_s:.2f} s (target < {TARGET_WALL_S:.0f} s)")
    print(f"  real-time factor     {d['real_time_factor']:.1f}x")
    print(f"  pipeline steps/s     {steps / result.wall_time_s:,.0f}")

    bare_s, bare_steps = bare_replay(config, result.sim_time_s)
    pipeline_per_step = result.wall_time_s / steps
    bare_per_step = bare_s / bare_steps
    print(f"  bare mj_step         {bare_steps / bare_s:,.0f} steps/s on the same commands")
    print(f"  pipeline / bare      {pipeline_per_step / bare_per_step:.2f}x per physics step")

    if args.record:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "paper.rrd"
            rec = run_trial(config, record_path=path)
            size = path.stat().st_size
        overhead = rec.wall_time_s / result.wall_time_s - 1.0
        per_min = size / (rec.sim_time_s / 60.0)
        print(
            f"  recording at 60 Hz   +{100 * overhead:.0f} % wall time, "
            f"{per_min / 1e6:.2f} MB per simulated minute"
        )


if __name__ == "__main__":
    main()
