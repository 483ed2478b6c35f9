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

Not measured here yet (issue "Every machine at the five-bar's speed"): a bare `mj_step`
replay of the trial's recorded inputs checked to end in the trial's state; the split of the
time outside `mj_step` by stage (host, bus, firmware, drives, judge).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

T0 = time.perf_counter()


def one(name: str, units: int, seed: int) -> dict:
    """One scenario's trial in this process, `mj_step` timed."""
    import importlib

    import mujoco

    from transplanter import kinds
    from transplanter.scenario.schema import load_scenario, with_units

    calls = [0]
    inside = [0.0]
    step = mujoco.mj_step
    clock = time.perf_counter

    def timed(m, d, *args):
        t = clock()
        step(m, d, *args)
        inside[0] += clock() - t
        calls[0] += 1

    mujoco.mj_step = timed
    imported = time.perf_counter() - T0
    sc = load_scenario(name, with_units(name, {"scenario.seed": seed}, units))
    runner = kinds.job(sc.workcell.kind).runner(sc.robot.kind)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    if runner:
        module, _, function = runner.partition(":")
        result = getattr(importlib.import_module(module), function)(sc, seed)
    else:
        from transplanter.scenario.assemble import assemble
        from transplanter.twin.trial import run_trial

        result = run_trial(assemble(sc))
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    sim = float(getattr(result, "sim_time_s", 0.0) or 0.0)
    if not sim:  # the serial arm's trial: its jobs' physics, step by step
        sim = calls[0] * sc.physics.timestep_s
    done = getattr(result, "successes", None)
    if done is None and hasattr(result, "pick_totals"):
        done = result.pick_totals.get("successes")
    return {
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
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--units", type=int, default=3, help="the job's units per trial (3)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--scenarios", default="", help="comma-separated (default: every packaged)")
    p.add_argument("--json", default=None, help="write the rows here")
    p.add_argument("--one", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.one is not None:
        print(json.dumps(one(args.one, args.units, args.seed)))
        return 0
    from transplanter.scenario.schema import packaged_scenarios

    names = [s for s in args.scenarios.split(",") if s] or packaged_scenarios()
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "egl")
    rows = []
    head = (
        f"{'scenario':<24}{'robot':<9}{'job':<14}{'units':>5}{'sim s':>8}{'wall s':>8}"
        f"{'RTF':>7}{'RTF cpu':>8}{'steps/s':>9}{'us/step':>8}{'mj_step':>8}{'outside':>8}"
        f"{'overhead':>9}{'MB':>6}"
    )
    print(head)
    for name in names:
        cmd = [sys.executable, __file__, "--one", name, "--units", str(args.units),
               "--seed", str(args.seed)]  # fmt: skip
        run = subprocess.run(cmd, capture_output=True, text=True, env=env)
        if run.returncode != 0:
            print(f"{name:<24}failed: {run.stderr.strip().splitlines()[-1:]}")
            continue
        r = json.loads(run.stdout.strip().splitlines()[-1])
        rows.append(r)
        steps = max(r["steps"], 1)
        outside = r["wall_s"] - r["mj_step_s"]
        print(
            f"{name:<24}{r['robot']:<9}{r['job']:<14}{r['units']:>5}{r['sim_s']:>8.1f}"
            f"{r['wall_s']:>8.1f}{r['sim_s'] / r['wall_s']:>7.2f}{r['sim_s'] / r['cpu_s']:>8.2f}"
            f"{r['steps'] / r['wall_s']:>9.0f}{1e6 * r['wall_s'] / steps:>8.0f}"
            f"{1e6 * r['mj_step_s'] / steps:>8.0f}{1e6 * outside / steps:>8.0f}"
            f"{r['wall_s'] / max(r['mj_step_s'], 1e-9):>9.2f}{r['peak_mb']:>6.0f}"
        )
    print(
        "us/step: wall time per physics step; mj_step and outside: its time inside MuJoCo's "
        "mj_step and outside it (host, bus, firmware, drives, judge); overhead: wall / time "
        "in mj_step (1.0: nothing but physics)"
    )
    if args.json:
        from transplanter import fileio

        fileio.write_json_atomic(args.json, {"units": args.units, "seed": args.seed, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
