"""Overhead of TrialRecorder on a 40-pot scene, and the .rrd size per simulated minute.

Run: /tmp/venv/bin/python benchmarks/bench_recording.py [--sim-s 10] [--sleep] [--repeats 3]

Steps the same model with and without the recorder (frame() at every physics step, 60 Hz
frames, a few scalar channels) and prints the wall-time overhead in percent (best of the
repeats, recorder set-up and close() included) and the file size.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

from transplanter.viewing.recording import TrialRecorder

SCALARS = ("motors/theta1", "motors/theta2", "gripper/angle", "conveyor/position")


def pots_mjcf(rows: int = 8, columns: int = 5, pitch_m: float = 0.045, sleep: bool = False) -> str:
    """A plane with rows x columns free cylinders ("pots") dropped in a grid of cells."""
    sleep_option = '<option sleep_tolerance="1e-3"><flag sleep="enable"/></option>' if sleep else ""
    pots = []
    for row in range(rows):
        for column in range(columns):
            x = (column - (columns - 1) / 2) * pitch_m
            y = 0.2 + row * pitch_m
            pots.append(
                f'<body name="pot_{row}_{column}" pos="{x:.4f} {y:.4f} 0.03">'
                '<freejoint/><geom type="cylinder" size="0.018 0.025" mass="0.05" '
                'rgba="0.55 0.35 0.2 1"/></body>'
            )
    return f"""
<mujoco>
  <option timestep="0.001"/>
  {sleep_option}
  <worldbody>
    <geom name="belt" type="plane" size="0.5 0.5 0.01" rgba="0.2 0.2 0.2 1"/>
    {"".join(pots)}
  </worldbody>
</mujoco>"""


def run(model: mujoco.MjModel, sim_s: float, path: Path | None) -> tuple[float, float]:
    """Wall time of one run and the part spent in the recorder's set-up and close().

    With a recorder, frame() is called at every physics step, as a trial runner would.
    """
    data = mujoco.MjData(model)
    n_steps = round(sim_s / model.opt.timestep)
    scalars = np.zeros(len(SCALARS))
    start = time.perf_counter()
    recorder = TrialRecorder(model, path, scalar_names=SCALARS) if path is not None else None
    setup_s = time.perf_counter() - start
    for step in range(n_steps):
        mujoco.mj_step(model, data)
        if recorder is not None:
            scalars[0] = data.time
            recorder.frame(data.time, data, scalars)
            if step % 2500 == 0:
                recorder.event(data.time, "grasp", "benchmark event", seedling=step)
    close_start = time.perf_counter()
    if recorder is not None:
        recorder.close()
    end = time.perf_counter()
    return end - start, setup_s + (end - close_start)


def frame_cost_us(model: mujoco.MjModel, path: Path, calls: int = 100_000) -> tuple[float, float]:
    """Microseconds per frame() call that records nothing, and per call that records."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    scalars = np.zeros(len(SCALARS))
    with TrialRecorder(model, path, scalar_names=SCALARS) as recorder:
        recorder.frame(0.0, data, scalars)
        start = time.perf_counter()
        for _ in range(calls):
            recorder.frame(1e-3, data, scalars)
        idle_us = (time.perf_counter() - start) / calls * 1e6
        frames = 3000
        start = time.perf_counter()
        for k in range(1, frames + 1):
            recorder.frame(k / recorder.config.rate_hz, data, scalars)
        record_us = (time.perf_counter() - start) / frames * 1e6
    return idle_us, record_us


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim-s", type=float, default=10.0, help="simulated seconds per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each kind (best kept)")
    parser.add_argument("--sleep", action="store_true", help="enable MuJoCo sleeping")
    args = parser.parse_args()

    model = mujoco.MjModel.from_xml_string(pots_mjcf(sleep=args.sleep))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.rrd"
        static_path = Path(tmp) / "static.rrd"
        TrialRecorder(model, static_path, scalar_names=SCALARS).close()
        bare, recorded, fixed = [], [], []
        for _ in range(args.repeats):  # interleaved so drifts hit both kinds alike
            bare.append(run(model, args.sim_s, None)[0])
            wall_s, fixed_s = run(model, args.sim_s, path)
            recorded.append(wall_s)
            fixed.append(fixed_s)
        size = path.stat().st_size
        static_size = static_path.stat().st_size

        idle_us, record_us = frame_cost_us(model, Path(tmp) / "micro.rrd")

    moving = int(np.count_nonzero(model.body_weldid != 0))
    best_bare, best_recorded = min(bare), min(recorded)
    overhead = 100.0 * (best_recorded - best_bare) / best_bare
    per_minute = (size - static_size) * 60.0 / args.sim_s
    print(
        f"model: {moving} free bodies, {model.ngeom} geoms, sleep={'on' if args.sleep else 'off'}"
    )
    print(f"simulated {args.sim_s:g} s at 1 ms, frames at 60 Hz, {len(SCALARS)} scalar channels")
    print(f"wall time without recorder: {best_bare:.3f} s (runs: {np.round(bare, 3).tolist()})")
    runs = np.round(recorded, 3).tolist()
    print(f"wall time with recorder:    {best_recorded:.3f} s (runs: {runs})")
    print(f"overhead: {overhead:+.1f} %  ({(best_recorded - best_bare) * 1e3:.0f} ms per run)")
    print(f"  of which recorder set-up + close(): {min(fixed) * 1e3:.0f} ms (independent of sim_s)")
    print(f"frame() cost: {idle_us:.2f} us per call between frames, {record_us:.1f} us per frame")
    print(f"file: {size / 1e6:.3f} MB for {args.sim_s:g} s, static part {static_size / 1e3:.1f} kB")
    print(f"size per simulated minute (static part excluded): {per_minute / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
