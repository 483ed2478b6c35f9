"""Benchmark: the paper trial's wall time, real-time factor, pipeline overhead and where a
physics step goes.

Prints numbers; asserts nothing. In one run, on one core:

- the trial (median wall time of `--repeats` runs), real-time factor and physics steps/s;
- one more run of the same trial with MuJoCo's stage timers on (`mjcb_time`; `data.timer`):
  the time inside `mj_step` and its stages (microseconds per step, share of `mj_step`), the
  mean awake kinematic trees and contacts per step. Our own code's cost is the ratio of the
  trial's wall time to the time inside `mj_step`; the timers add a little to `mj_step`, so
  that ratio is a slight underestimate. (Replaying only the recorded `ctrl` on a bare model
  would not be the same physics: the conveyor is driven through `qfrc_applied` and its hold
  is edited in the model at each index.)

    python benchmarks/bench_trial.py [--seedlings N] [--repeats 3] [--record]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import mujoco

from transplanter.config import assemble
from transplanter.scenario import load_scenario
from transplanter.sim import Twin
from transplanter.trial import run_trial

TARGET_WALL_S = 10.0  # issue 4: the 40-seedling paper trial in under 10 s wall on one core
# MuJoCo's stages, outermost first (mjtTimer), as printed.
STAGES = (
    "STEP", "FORWARD", "POSITION", "POS_KINEMATICS", "POS_INERTIA", "POS_COLLISION",
    "COL_BROAD", "COL_NARROW", "POS_MAKE", "POS_PROJECT", "VELOCITY", "ACTUATION",
    "CONSTRAINT", "ADVANCE",
)  # fmt: skip


class StageTimers:
    """A trial observer: keeps the twin (for its data.timer) and counts, per physics step,
    the awake trees and contacts."""

    def attach(self, twin: Twin, records) -> None:
        self.twin = twin
        self.steps, self.awake, self.contacts = 0, 0, 0
        self.max_awake, self.max_contacts = 0, 0

    def step(self, twin: Twin) -> None:
        d = twin.data
        self.steps += 1
        self.awake += d.ntree_awake
        self.contacts += d.ncon
        self.max_awake = max(self.max_awake, d.ntree_awake)
        self.max_contacts = max(self.max_contacts, d.ncon)

    def finish(self, twin: Twin, interrupted: bool) -> None:
        pass

    def abort(self) -> None:
        pass


def timed_trial(config) -> StageTimers:
    """The trial once more with MuJoCo's stage timers on."""
    timers = StageTimers()
    mujoco.set_mjcb_time(time.perf_counter)
    try:
        run_trial(config, observers=[timers])
    finally:
        mujoco.set_mjcb_time(None)
    return timers


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seedlings", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--record", action="store_true", help="also time a 60 Hz recording")
    args = parser.parse_args()
    config = assemble(load_scenario("paper", {"scenario.seedlings": args.seedlings}))

    results = [run_trial(config) for _ in range(args.repeats)]
    result = results[0]
    wall = statistics.median(r.wall_time_s for r in results)
    d = result.to_dict()
    steps = round(result.sim_time_s / config.scene.timestep)
    print(f"paper trial, {d['seedlings']} seedlings, seed {d['seed']}, median of {args.repeats}")
    print(f"  success rate         {100 * d['success_rate']:.1f} %  failures {d['failures']}")
    print(f"  cycle time           {d['cycle_time_s']:.3f} s (sd {d['cycle_time_sd_s']:.3f})")
    print(f"  simulated time       {result.sim_time_s:.1f} s ({steps} physics steps)")
    print(f"  wall time            {wall:.2f} s (target < {TARGET_WALL_S:.0f} s)")
    print(f"  real-time factor     {result.sim_time_s / wall:.1f}x")
    print(f"  pipeline steps/s     {steps / wall:,.0f}")

    timers = timed_trial(config)
    data, model = timers.twin.data, timers.twin.model
    inside = data.timer[int(mujoco.mjtTimer.mjTIMER_STEP)].duration
    n = data.timer[int(mujoco.mjtTimer.mjTIMER_STEP)].number
    print(f"  mj_step alone        {n / inside:,.0f} steps/s inside the trial (timers on)")
    print(f"  pipeline / mj_step   {wall / inside:.2f}x wall time over the time inside mj_step")
    print(
        f"  awake trees          {timers.awake / timers.steps:.2f} of {model.ntree} on average "
        f"(max {timers.max_awake}); contacts {timers.contacts / timers.steps:.2f} per step "
        f"(max {timers.max_contacts})"
    )
    print("  mj_step stages (us per step, share of mj_step):")
    for name in STAGES:
        timer = data.timer[int(getattr(mujoco.mjtTimer, f"mjTIMER_{name}"))]
        print(
            f"    {name:16s} {1e6 * timer.duration / n:7.2f} us  "
            f"{100 * timer.duration / inside:5.1f} %"
        )

    if args.record:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "paper.rrd"
            rec = run_trial(config, record_path=path)
            size = path.stat().st_size
        overhead = rec.wall_time_s / wall - 1.0
        per_min = size / (rec.sim_time_s / 60.0)
        print(
            f"  recording at 60 Hz   +{100 * overhead:.0f} % wall time, "
            f"{per_min / 1e6:.2f} MB per simulated minute"
        )


if __name__ == "__main__":
    main()
