"""Benchmark: every packaged scenario (every robot x effector x job cell that runs) on one
core: what a trial costs, and how much of it is MuJoCo's `mj_step`.

Each scenario runs in a fresh Python process (`--one`), as a user's `transplanter trial` does,
its job picked through the registry (`transplanter.kinds`: the job's `runner` with the
scenario's robot, or the twin's own `run_trial`), for `--units` of the job's units (pots,
tray cells, tomatoes, bench picks: `--seedlings`' meaning), with `mujoco.mj_step` wrapped by
a counter and a clock. Per scenario it prints: simulated and wall time, the real-time factor
(wall and CPU; the wall time is the trial's, its scene's build and compile included: short
trials pay it more), physics steps and steps per second, the time inside `mj_step` and outside it
(per step and as a share), the pipeline's overhead over the bare physics (wall / time in
`mj_step`: 1.0 is nothing but physics) and the peak memory. Prints numbers; asserts nothing.

Run it on one core of an otherwise idle machine (`taskset -c 0`), the delta's vision with an
offscreen GL context (`MUJOCO_GL=egl`, set here when unset):

    taskset -c 0 python benchmarks/bench_matrix.py [--units 3] [--scenarios paper,delta_pots]
        [--json out.json]

Then, in the same process, the trial runs once more, recorded: before every `mj_step` what the
pipeline changed since the step before (any entry of MuJoCo's integration state: ctrl, applied
forces, a pose the judge or the live rows set; and the model fields a job edits), each hook of
the loop timed by its name, and MuJoCo's stages (`mjcb_time`). The recorded input is replayed by
a bare `mj_step` loop on a copy of the model as it was before the first step, and the replay is
checked to end in the trial's state, bit for bit (`same`). `pipeline` is the timed trial's
time in its loop against the replay's (1.0: nothing but physics; the trial's wall time less its
build), and a second table splits a step: MuJoCo's collision, its constraint solver, the rest
of `mj_step`, then our stages (the firmware exchange, each hook of the loop by name), in
microseconds a step.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import resource
import subprocess
import sys
import time

T0 = time.perf_counter()

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

SIG = int(mujoco.mjtState.mjSTATE_INTEGRATION)
# Model fields a job edits while it runs (the conveyor's hold and rows, a jam's brake, the live
# rows' pots, the plugs' shear and mass, torn leaves): recorded at every step they change.
EDITED_FIELDS = (
    "jnt_stiffness", "dof_damping", "qpos_spring", "dof_frictionloss", "dof_solimp",
    "body_pos", "body_mass", "body_subtreemass", "body_inertia", "body_ipos", "body_iquat",
    "body_invweight0", "body_contype", "body_conaffinity", "body_margin", "dof_invweight0",
    "dof_M0", "geom_pos", "geom_size", "geom_rbound", "geom_aabb", "geom_friction",
    "geom_solimp", "geom_solref", "geom_contype", "geom_conaffinity", "bvh_aabb",
    "actuator_gear",
)  # fmt: skip


class _Segment:
    """One model's and data's physics as the trial stepped it: the model and the state
    before its first step, and what the pipeline changed before each step (state entries,
    model fields); the state after its last step."""

    def __init__(self, m, d) -> None:
        self.m, self.d = m, d
        self.model = copy.deepcopy(m)
        self.init = np.empty(mujoco.mj_stateSize(m, SIG))
        mujoco.mj_getState(m, d, self.init, SIG)
        self.after = self.init.copy()
        self.now = self.init.copy()
        self.fields = {f: getattr(m, f).copy() for f in EDITED_FIELDS}
        self.diffs: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.edits: dict[int, dict[str, np.ndarray]] = {}
        self.n = 0
        self.ctrl = slice(*_component(m, int(mujoco.mjtState.mjSTATE_CTRL)))

    def before(self) -> None:
        m, d, k = self.m, self.d, self.n
        mujoco.mj_getState(m, d, self.now, SIG)
        if k:
            changed = np.flatnonzero(self.now != self.after)
            if changed.size:
                self.diffs[k] = (changed, self.now[changed].copy())
        edited = {}
        for f in EDITED_FIELDS:
            value = getattr(m, f)
            if not np.array_equal(value, self.fields[f]):
                edited[f] = self.fields[f] = value.copy()
        if edited:
            self.edits[k] = edited

    def stepped(self) -> None:
        mujoco.mj_getState(self.m, self.d, self.after, SIG)
        self.n += 1


def _component(m, bit) -> tuple[int, int]:
    """Where the state component `bit` lies in a state vector of signature SIG."""
    start = sum(mujoco.mj_stateSize(m, 1 << b) for b in range(16) if (1 << b) < bit and
                (1 << b) & SIG)  # fmt: skip
    return start, start + mujoco.mj_stateSize(m, bit)


class _Recorder:
    """Stands in for `mujoco.mj_step` in the recorded run: each (model, data) pair it is
    called with is a segment (the plug bench builds one scene a pick)."""

    def __init__(self, step) -> None:
        self.step, self.segments = step, []

    def __call__(self, m, d, *args) -> None:
        seg = self.segments[-1] if self.segments else None
        if seg is None or seg.m is not m or seg.d is not d:
            seg = _Segment(m, d)
            self.segments.append(seg)
        else:
            seg.before()
        self.step(m, d, *args)
        seg.stepped()


def replay(segments, step) -> tuple[float, bool, float]:
    """Each segment stepped by a bare `mj_step` loop on its recorded input: the wall time
    of the loops, whether every one ended in the trial's state bit for bit, and the largest
    difference of any state entry from it."""
    wall, same, worst = 0.0, True, 0.0
    for seg in segments:
        m = seg.model
        d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, seg.init, SIG)
        state = np.empty_like(seg.init)
        lo, hi = seg.ctrl.start, seg.ctrl.stop
        plan = []
        for k in range(seg.n):
            idx, val = seg.diffs.get(k, (None, None))
            ctrl_only = idx is not None and idx.size and idx[0] >= lo and idx[-1] < hi
            plan.append((seg.edits.get(k), idx, val, ctrl_only))
        ctrl = d.ctrl
        t0 = time.perf_counter()
        for edits, idx, val, ctrl_only in plan:
            if edits:
                for f, value in edits.items():
                    getattr(m, f)[...] = value
            if idx is not None:
                if ctrl_only:
                    ctrl[idx - lo] = val
                else:
                    mujoco.mj_getState(m, d, state, SIG)
                    state[idx] = val
                    mujoco.mj_setState(m, d, state, SIG)
            step(m, d)
        wall += time.perf_counter() - t0
        mujoco.mj_getState(m, d, state, SIG)
        equal = np.array_equal(state, seg.after, equal_nan=True)
        same = same and equal
        if not equal:
            worst = max(worst, float(np.nanmax(np.abs(state - seg.after))))
    return wall, same, worst


def _run(sc, seed: int, runner: str):
    """The scenario's trial through its job's runner (or the twin's run_trial)."""
    import importlib

    if runner:
        module, _, function = runner.partition(":")
        return getattr(importlib.import_module(module), function)(sc, seed)
    from transplanter.scenario.assemble import assemble
    from transplanter.twin.trial import run_trial

    return run_trial(assemble(sc))


def _hook_name(fn) -> str:
    name = getattr(fn, "__qualname__", type(fn).__name__).replace(".<locals>", "")
    return name.rsplit(".", 2)[-2] + "." + name.rsplit(".", 1)[-1] if "." in name else name


class _Split:
    """Times the loop's exchange and each of its hooks (by name) while installed."""

    def __init__(self) -> None:
        from transplanter.twin.loop import StepLoop

        self.spent: dict[str, float] = {}
        self.loop_class = StepLoop
        self.originals = (StepLoop.advance, StepLoop._run_block)
        split = self

        def advance(loop, t_limit=math.inf):
            if not getattr(loop.exchange, "_timed", False):
                loop.exchange = split.timed(loop.exchange, "exchange with the firmware")
            return split.originals[0](loop, t_limit)

        def run_block(loop, n):
            for hooks, kind in ((loop.before_step, "before"), (loop.after_step, "after"),
                                (loop.after_block, "after block")):  # fmt: skip
                for i, fn in enumerate(hooks):
                    if not getattr(fn, "_timed", False):
                        hooks[i] = split.timed(fn, f"{kind}: {_hook_name(fn)}")
            return split.originals[1](loop, n)

        StepLoop.advance, StepLoop._run_block = advance, run_block

    def timed(self, fn, label: str):
        spent, clock = self.spent, time.perf_counter
        spent.setdefault(label, 0.0)

        def wrapper(*args):
            t0 = clock()
            try:
                return fn(*args)
            finally:
                spent[label] += clock() - t0

        wrapper._timed = True
        return wrapper

    def remove(self) -> None:
        self.loop_class.advance, self.loop_class._run_block = self.originals


STAGES = {
    "collision": ("mjTIMER_POS_COLLISION",),
    "constraint": ("mjTIMER_POS_MAKE", "mjTIMER_POS_PROJECT", "mjTIMER_CONSTRAINT"),
}
"""MuJoCo's stages as the split shows them (`data.timer`); the rest of `mj_step` beside."""


def one(name: str, units: int, seed: int, replayed: bool = True) -> dict:
    """One scenario's trial in this process, `mj_step` timed; then (`replayed`) the trial
    again, recorded and split, and its bare replay."""
    from transplanter import kinds
    from transplanter.scenario.schema import load_scenario, with_units

    calls = [0]
    inside = [0.0]
    span = [math.nan, math.nan]  # the first mj_step's start, the last one's end
    step = mujoco.mj_step
    clock = time.perf_counter

    def timed(m, d, *args):
        t = clock()
        step(m, d, *args)
        end = clock()
        inside[0] += end - t
        calls[0] += 1
        if calls[0] == 1:
            span[0] = t
        span[1] = end

    imported = time.perf_counter() - T0
    sc = load_scenario(name, with_units(name, {"scenario.seed": seed}, units))
    runner = kinds.job(sc.workcell.kind).runner(sc.robot.kind)
    mujoco.mj_step = timed
    try:
        cpu0, wall0 = time.process_time(), time.perf_counter()
        result = _run(sc, seed, runner)
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    finally:
        mujoco.mj_step = step
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    sim = float(getattr(result, "sim_time_s", 0.0) or 0.0)
    if not sim:  # the serial arm's trial: its jobs' physics, step by step
        sim = calls[0] * sc.physics.timestep_s
    done = getattr(result, "successes", None)
    if done is None and hasattr(result, "pick_totals"):
        done = result.pick_totals.get("successes")
    row = {
        "scenario": name,
        "robot": sc.robot.kind,
        "effector": sc.effector.kind,
        "job": sc.workcell.kind,
        "units": units,
        "successes": done,
        "sim_s": sim,
        "wall_s": wall,
        "cpu_s": cpu,
        "start_s": imported,
        "steps": calls[0],
        "mj_step_s": inside[0],
        "loop_s": span[1] - span[0],
        "peak_mb": peak_mb,
    }
    if not replayed:
        return row
    recorder = _Recorder(step)
    mujoco.mj_step = recorder
    split = _Split()
    mujoco.set_mjcb_time(time.perf_counter)
    try:
        again = _run(sc, seed, runner)
    finally:
        mujoco.set_mjcb_time(None)
        split.remove()
        mujoco.mj_step = step
    steps = sum(seg.n for seg in recorder.segments)
    stages = {}
    for label, timers in STAGES.items():
        stages[label] = sum(
            seg.d.timer[getattr(mujoco.mjtTimer, t)].duration
            for seg in recorder.segments
            for t in timers
        )
    stages["all of mj_step"] = sum(
        seg.d.timer[mujoco.mjtTimer.mjTIMER_STEP].duration for seg in recorder.segments
    )
    bare, same, worst = replay(recorder.segments, step)
    row |= {
        "replay_s": bare,
        "replay_same": same,
        "replay_worst": worst,
        "recorded_same_trial": _same_result(result, again) and steps == calls[0],
        "split_us": {k: 1e6 * v / max(steps, 1) for k, v in (stages | split.spent).items()},
        "split_wall_s": again.wall_time_s if hasattr(again, "wall_time_s") else math.nan,
    }
    return row


def _same_result(a, b) -> bool:
    """Whether two runs of a trial gave the same result, wall times aside."""

    def plain(r):
        d = r.to_dict() if hasattr(r, "to_dict") else dict(vars(r))
        text = json.dumps(d, sort_keys=True, default=str)
        out = json.loads(text)
        for key in ("wall_time_s", "wall_s", "real_time_factor", "grading"):
            out.pop(key, None)
        return out

    try:
        return plain(a) == plain(b)
    except (TypeError, ValueError):
        return False


def _split_table(rows: list[dict]) -> None:
    """The split of a step, us: MuJoCo's stages, then ours (each hook by name), the top
    ones of each scenario."""
    print()
    print("where a step goes (us a step, from the recorded run: its timers cost a little "
          "each; hooks below 1 us left out)")  # fmt: skip
    for r in rows:
        split = r.get("split_us")
        if not split:
            continue
        mj = split.pop("all of mj_step")
        mujoco_part = [
            ("collision", split.pop("collision")),
            ("constraint", split.pop("constraint")),
        ]
        mujoco_part.append(("rest of mj_step", mj - sum(v for _, v in mujoco_part)))
        ours = sorted(((k, v) for k, v in split.items() if v >= 1.0), key=lambda kv: -kv[1])
        shown = ", ".join(f"{k} {v:.1f}" for k, v in mujoco_part)
        print(f"  {r['scenario']}: mj_step {mj:.1f} ({shown})")
        print("    " + "; ".join(f"{k} {v:.1f}" for k, v in ours))


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--units", type=int, default=3, help="the job's units per trial (3)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--scenarios", default="", help="comma-separated (default: every packaged)")
    p.add_argument("--json", default=None, help="write the rows here")
    p.add_argument("--no-replay", action="store_true",
                   help="the timed trial only: no recorded run, replay or split")  # fmt: skip
    p.add_argument("--one", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.one is not None:
        print(json.dumps(one(args.one, args.units, args.seed, not args.no_replay)))
        return 0
    from transplanter.scenario.schema import packaged_scenarios

    names = [s for s in args.scenarios.split(",") if s] or packaged_scenarios()
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "egl")
    rows = []
    head = (
        f"{'scenario':<24}{'robot':<9}{'job':<14}{'units':>5}{'sim s':>8}{'wall s':>8}"
        f"{'RTF':>7}{'RTF cpu':>8}{'steps/s':>9}{'us/step':>8}{'mj_step':>8}{'outside':>8}"
        f"{'loop s':>8}{'bare s':>8}{'pipeline':>9}{'same':>6}{'MB':>6}"
    )
    print(head)
    for name in names:
        cmd = [sys.executable, __file__, "--one", name, "--units", str(args.units),
               "--seed", str(args.seed)] + (["--no-replay"] if args.no_replay else [])  # fmt: skip
        run = subprocess.run(cmd, capture_output=True, text=True, env=env)
        if run.returncode != 0:
            print(f"{name:<24}failed: {run.stderr.strip().splitlines()[-1:]}")
            continue
        r = json.loads(run.stdout.strip().splitlines()[-1])
        rows.append(r)
        steps = max(r["steps"], 1)
        outside = r["wall_s"] - r["mj_step_s"]
        bare = r.get("replay_s", math.nan)
        same = "-" if "replay_same" not in r else (
            "yes" if r["replay_same"] and r["recorded_same_trial"] else "NO")  # fmt: skip
        print(
            f"{name:<24}{r['robot']:<9}{r['job']:<14}{r['units']:>5}{r['sim_s']:>8.1f}"
            f"{r['wall_s']:>8.1f}{r['sim_s'] / r['wall_s']:>7.2f}{r['sim_s'] / r['cpu_s']:>8.2f}"
            f"{r['steps'] / r['wall_s']:>9.0f}{1e6 * r['wall_s'] / steps:>8.0f}"
            f"{1e6 * r['mj_step_s'] / steps:>8.0f}{1e6 * outside / steps:>8.0f}"
            f"{r['loop_s']:>8.1f}{bare:>8.1f}{r['loop_s'] / bare:>9.2f}{same:>6}"
            f"{r['peak_mb']:>6.0f}"
        )
    print(
        "us/step: wall time per physics step; mj_step and outside: its time inside MuJoCo's "
        "mj_step and outside it (host, bus, firmware, drives, judge, the scene's build); "
        "loop s: from the first mj_step to the last; bare s: the bare mj_step replay of the "
        "trial's recorded input; pipeline: loop / bare (1.0: nothing but physics); same: the "
        "replay ended in the trial's state bit for bit and the recorded run was the timed one"
    )
    if not args.no_replay:
        _split_table(rows)
    if args.json:
        from transplanter import fileio

        fileio.write_json_atomic(args.json, {"units": args.units, "seed": args.seed, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
