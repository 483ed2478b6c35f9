"""benchmarks/bench_matrix.py's bare replay: what the pipeline gave the physics before every
step, replayed by a bare `mj_step` loop, ends in the trial's own state bit for bit (the claim
its `pipeline` column rests on), and a replay on input it did not record does not."""

from __future__ import annotations

import importlib.util
import sys

import mujoco
import numpy as np

from conftest import ROOT

SCRIPT = ROOT / "benchmarks" / "bench_matrix.py"


def _bench():
    spec = importlib.util.spec_from_file_location("bench_matrix", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_a_trials_replay_ends_in_its_state_and_the_step_is_split():
    bench = _bench()
    step = mujoco.mj_step
    row = bench.one("plug_bench", 1, 3)
    assert mujoco.mj_step is step  # put back
    assert row["steps"] > 1000 and row["replay_same"] and row["recorded_same_trial"]
    assert 0.0 < row["replay_s"] and 0.0 < row["loop_s"] <= row["wall_s"]
    split = row["split_us"]
    assert split["all of mj_step"] > split["collision"] > 0.0
    assert any(k.startswith("before: ") for k in split) and any(
        k.startswith("after: ") for k in split
    )


def test_a_replay_that_misses_an_input_does_not_end_in_the_trials_state():
    """A pipeline that pushes the body (ctrl) and moves it (qpos) between steps: the
    recording holds both; drop the pose write and the replay ends elsewhere, and says so."""
    bench = _bench()
    xml = """<mujoco><option timestep="0.002"/><worldbody><body><joint name="x" type="slide"
    axis="1 0 0"/><geom size="0.01" mass="1"/></body></worldbody><actuator><motor joint="x"/>
    </actuator></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    recorder = bench._Recorder(mujoco.mj_step)
    for k in range(200):
        d.ctrl[0] = np.sin(0.1 * k)
        if k == 120:
            d.qpos[0] += 0.01  # the judge parks a pot, say
        if k == 150:
            m.dof_damping[0] = 3.0  # a drive's hold
        recorder(m, d)
    _, same, worst = bench.replay(recorder.segments, mujoco.mj_step)
    assert same and worst == 0.0
    seg = recorder.segments[0]
    assert 150 in seg.edits and 120 in seg.diffs
    idx, val = seg.diffs[120]
    keep = idx < seg.ctrl.start  # the qpos entry of the change
    seg.diffs[120] = (idx[~keep], val[~keep])
    _, same, worst = bench.replay(recorder.segments, mujoco.mj_step)
    assert not same and worst > 1e-3
