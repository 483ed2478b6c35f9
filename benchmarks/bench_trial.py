"""Benchmark: the paper trial's wall time, real-time factor, pipeline overhead and where a
physics step goes.

Prints numbers; asserts nothing. In one run, on one core:

- the trial (median wall time of `--repeats` runs): wall time, real-time factor, physics
  steps/s, against the target of 60x real time;
- one more run of the same trial that records what the physics was given at every step
  (ctrl, the conveyor's applied force, the model fields the twin edits: the conveyor's
  hold, rows past the edge, a jam's friction; and the judge's parking of finished pots)
  and times our own stages (firmware exchange, command blocks, judge monitor, slip checks)
  and MuJoCo's (`mjcb_time`, `data.timer`): microseconds per step and share of the wall
  time, mean awake kinematic trees and contacts;
- the replay: the same model and seed stepped by a bare `mj_step` loop on that recorded
  input, checked to end in the trial's exact state, run in turns with the trial
  (`--repeats` pairs); the median of the pairs' trial/replay wall-time ratios is the
  pipeline overhead; the replay's steps/s while the conveyor
  indexes and while the scene rests (nothing but the arm moving) are printed too.

    python benchmarks/bench_trial.py [--seedlings N] [--repeats 3] [--record]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.twin import judge as judge_module
from transplanter.twin.sim import Twin
from transplanter.twin.trial import run_trial

TARGET_RTF = 60.0  # issue 11: the 40-seedling paper trial at 60x real time on one core
# MuJoCo's stages, outermost first (mjtTimer), as printed.
STAGES = (
    "STEP", "FORWARD", "POSITION", "POS_KINEMATICS", "POS_INERTIA", "POS_COLLISION",
    "COL_BROAD", "COL_NARROW", "POS_MAKE", "POS_PROJECT", "VELOCITY", "ACTUATION",
    "CONSTRAINT", "ADVANCE",
)  # fmt: skip
# Our stages: Twin methods and the judge's monitor, timed by wrapping them in the timed run.
OWN_STAGES = (
    (Twin, "_exchange", "firmware exchange"),
    (Twin, "_block", "command blocks"),
    (Twin, "_slip", "slip checks"),
    (judge_module.Judge, "monitor", "judge monitor"),
)
# Model fields the twin edits while it runs (conveyor hold and rows, a jam's brake).
EDITED_FIELDS = (
    "jnt_stiffness", "dof_damping", "qpos_spring", "geom_conaffinity", "dof_frictionloss",
    "dof_solimp",
)  # fmt: skip


class InputRecorder:
    """A trial observer: what the physics was given at every step, and MuJoCo's counters."""

    def attach(self, twin: Twin, records) -> None:
        self.twin = twin
        self.ctrl: list[np.ndarray] = []
        self.force: list[float] = []  # the conveyor's applied force (its only user)
        self.indexing: list[bool] = []
        self.edits: dict[int, dict[str, np.ndarray]] = {0: self._fields()}
        self.parks: dict[int, list[tuple[slice, np.ndarray, slice, np.ndarray]]] = {}
        self.awake, self.contacts = 0, 0
        self.q0 = twin.data.qpos.copy()

    def _fields(self) -> dict[str, np.ndarray]:
        m = self.twin.model
        return {name: getattr(m, name).copy() for name in EDITED_FIELDS}

    def step(self, twin: Twin) -> None:
        d, k = twin.data, len(self.ctrl)
        self.ctrl.append(d.ctrl.copy())
        dof = twin.conveyor.dof_adr
        self.force.append(float(d.qfrc_applied[dof]))
        self.indexing.append(bool(d.qfrc_applied[dof] != 0.0))
        if np.count_nonzero(d.qfrc_applied) > 1:
            raise RuntimeError("forces other than the conveyor's: the replay cannot repeat them")
        fields = self._fields()
        last = self.edits[max(self.edits)]
        if any(not np.array_equal(fields[n], last[n]) for n in EDITED_FIELDS):
            self.edits[k] = fields
        self.awake += d.ntree_awake
        self.contacts += d.ncon

    def park(self, judge, pot: int) -> None:
        """The judge moved a finished pot away (Judge._park): before physics step twin.k."""
        d = judge.twin.data
        a, v = judge.pot_qadr[pot], judge.pot_dadr[pot]
        qs, vs = slice(a, a + 7), slice(v, v + 6)
        self.parks.setdefault(judge.twin.k, []).append(
            (qs, d.qpos[qs].copy(), vs, d.qvel[vs].copy())
        )

    def finish(self, twin: Twin, interrupted: bool) -> None:
        self.q_end = twin.data.qpos.copy()

    def abort(self) -> None:
        pass


def timed_trial(config) -> tuple[InputRecorder, dict[str, float], float]:
    """The trial once more, recording its input, with MuJoCo's and our stage timers on."""
    recorder = InputRecorder()
    spent = {label: 0.0 for _, _, label in OWN_STAGES}
    originals = []
    for owner, name, label in OWN_STAGES:
        original = getattr(owner, name)
        originals.append((owner, name, original))

        def timed(*args, _f=original, _label=label, **kwargs):
            t0 = time.perf_counter()
            try:
                return _f(*args, **kwargs)
            finally:
                spent[_label] += time.perf_counter() - t0

        setattr(owner, name, timed)
    park = judge_module.Judge._park

    def parked(judge, pot: int) -> None:
        park(judge, pot)
        recorder.park(judge, pot)

    judge_module.Judge._park = parked
    mujoco.set_mjcb_time(time.perf_counter)
    try:
        result = run_trial(config, observers=[recorder])
    finally:
        mujoco.set_mjcb_time(None)
        judge_module.Judge._park = park
        for owner, name, original in originals:
            setattr(owner, name, original)
    return recorder, spent, result.wall_time_s


def replay(config, rec: InputRecorder) -> tuple[float, float, float, float]:
    """A bare mj_step loop on the recorded input: wall time, steps/s while indexing and
    while not, and the largest difference from the trial's final qpos."""
    twin = Twin(config)  # the same model and seed, before any step
    m, d = twin.model, twin.data
    ctrl, force = np.array(rec.ctrl), np.array(rec.force)
    indexing = np.array(rec.indexing)
    dof, edits, parks = twin.conveyor.dof_adr, rec.edits, rec.parks
    spent = np.zeros(2)
    t_all = time.perf_counter()
    for k in range(len(ctrl)):
        if k in edits:
            for name, value in edits[k].items():
                getattr(m, name)[:] = value
        for qs, q, vs, v in parks.get(k, ()):
            d.qpos[qs], d.qvel[vs] = q, v
        d.ctrl[:] = ctrl[k]
        d.qfrc_applied[dof] = force[k]
        t0 = time.perf_counter()
        mujoco.mj_step(m, d)
        spent[int(indexing[k])] += time.perf_counter() - t0
    wall = time.perf_counter() - t_all
    for qs, q, vs, v in parks.get(len(ctrl), ()):  # parked after the last step
        d.qpos[qs], d.qvel[vs] = q, v
    n_index = int(indexing.sum())
    rest_rate = (len(ctrl) - n_index) / spent[0]
    index_rate = n_index / spent[1] if n_index else float("nan")
    return wall, rest_rate, index_rate, float(np.abs(d.qpos - rec.q_end).max())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seedlings", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--record", action="store_true", help="also time a 60 Hz recording")
    args = parser.parse_args()
    config = assemble(load_scenario("paper", {"scenario.seedlings": args.seedlings}))

    # The input to replay first; then trial and replay in turns, so that the machine's drift
    # (clock, other load) falls on both sides of each ratio.
    rec, own, timed_wall = timed_trial(config)
    results, replays = [], []
    for _ in range(args.repeats):
        results.append(run_trial(config))
        replays.append(replay(config, rec))
    result = results[0]
    wall = statistics.median(r.wall_time_s for r in results)
    d = result.to_dict()
    steps = round(result.sim_time_s / config.scene.timestep_s)
    print(f"paper trial, {d['seedlings']} seedlings, seed {d['seed']}, median of {args.repeats}")
    print(f"  success rate         {100 * d['success_rate']:.1f} %  failures {d['failures']}")
    print(f"  cycle time           {d['cycle_time_s']:.3f} s (sd {d['cycle_time_sd_s']:.3f})")
    print(f"  simulated time       {result.sim_time_s:.1f} s ({steps} physics steps)")
    print(f"  wall time            {wall:.2f} s")
    print(f"  real-time factor     {result.sim_time_s / wall:.1f}x (target {TARGET_RTF:.0f}x)")
    print(f"  pipeline steps/s     {steps / wall:,.0f}")

    data, model = rec.twin.data, rec.twin.model
    step_timer = data.timer[int(mujoco.mjtTimer.mjTIMER_STEP)]
    inside, n = step_timer.duration, step_timer.number
    print(
        f"  awake trees          {rec.awake / n:.2f} of {model.ntree} on average; "
        f"contacts {rec.contacts / n:.2f} per step"
    )
    print(f"  stages of the timed run ({timed_wall:.2f} s wall; us per step, share of wall):")
    for label, seconds in own.items():
        print(f"    {label:18s} {1e6 * seconds / n:7.2f} us  {100 * seconds / timed_wall:5.1f} %")
    for name in STAGES:
        timer = data.timer[int(getattr(mujoco.mjtTimer, f"mjTIMER_{name}"))]
        print(
            f"    mj {name:15s} {1e6 * timer.duration / n:7.2f} us  "
            f"{100 * timer.duration / timed_wall:5.1f} %"
        )
    print(f"    (mj_step alone: {n / inside:,.0f} steps/s with the timers on)")

    bare = statistics.median(r[0] for r in replays)
    ratio = statistics.median(r.wall_time_s / b[0] for r, b in zip(results, replays, strict=True))
    _, rest_rate, index_rate, dq = replays[0]
    same = "yes, bit for bit" if dq == 0.0 else f"no, max |dq| {dq:.3g}"
    print(f"  bare mj_step replay  {bare:.2f} s ({steps / bare:,.0f} steps/s); ends in the "
          f"trial's state: {same}")  # fmt: skip
    print(f"    while indexing     {index_rate:,.0f} steps/s (target 20,000)")
    print(f"    otherwise          {rest_rate:,.0f} steps/s")
    print(f"  pipeline / bare      {ratio:.2f}x (median of the trial/replay pairs; target 1.2x)")

    if args.record:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "paper.rrd"
            recorded = run_trial(config, record_path=path)
            size = path.stat().st_size
        overhead = recorded.wall_time_s / wall - 1.0
        per_min = size / (recorded.sim_time_s / 60.0)
        print(
            f"  recording at 60 Hz   +{100 * overhead:.0f} % wall time, "
            f"{per_min / 1e6:.2f} MB per simulated minute"
        )


if __name__ == "__main__":
    main()
