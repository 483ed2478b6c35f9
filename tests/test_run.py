"""transplanter.run_scenario (transplanter.studies.run): one trial of any scenario from Python,
every robot on every job, as the row the studies pool: what `trial --json` measures, the same
columns for every machine, refusals raised with their reason."""

import json

import pytest

import transplanter
from transplanter.cli import main
from transplanter.studies.backends import RESULT_FIELDS

WALL = ("wall_time_s",)


def _without_wall(row):
    return {k: v for k, v in row.items() if k not in WALL}


def test_the_row_is_what_the_trial_measures_and_repeats_bit_for_bit(tmp_path):
    out = tmp_path / "t.json"
    assert main(["trial", "paper", "--seedlings", "2", "--seed", "3", "--json", str(out),
                 "--quiet"]) == 0  # fmt: skip
    trial = json.loads(out.read_text())
    row = transplanter.run_scenario("paper", seed=3, units=2)
    assert (row["successes"], row["seedlings"], row["seed"]) == (trial["successes"], 2, 3)
    assert row["cycle_time_s"] == trial["cycle_time_s"]
    assert row["plants_per_hour"] == trial["plants_per_hour"]
    assert row["sim_time_s"] == trial["sim_time_s"]
    assert _without_wall(transplanter.run_scenario("paper", seed=3, units=2)) == _without_wall(row)


@pytest.mark.parametrize(
    ("scenario", "units", "overrides"),
    [
        ("delta_pots", 1, {}),
        ("serial_arm_pots", 1, {}),
        ("serial_arm", 1, {}),
        ("plug_bench", 2, {}),
        ("delta_refill", 1, {"delta_refill.vision": "truth"}),
    ],
)
def test_every_machine_on_its_job_gives_the_same_columns(scenario, units, overrides):
    row = transplanter.run_scenario(scenario, units=units, overrides=overrides)
    assert set(RESULT_FIELDS) <= set(row)
    assert row["seedlings"] == units and 0 <= row["successes"] <= units
    assert row["cycle_time_s"] > 0 and row["wall_time_s"] > 0 and row["error"] is None
    assert row["seed"] == transplanter.load_scenario(scenario).seed  # the scenario's own


def test_a_refused_scenario_or_key_raises_with_the_reason():
    with pytest.raises(transplanter.ScenarioError, match="did you mean taught.z_low_mm"):
        transplanter.run_scenario("paper", overrides={"taught.z_lo_mm": 30})
    with pytest.raises(transplanter.ScenarioError, match="did you mean paper"):
        transplanter.run_scenario("papr")
    with pytest.raises(transplanter.ScenarioError, match="taught"):
        transplanter.run_scenario("delta_refill", overrides={"taught.z_low_mm": 30})


def test_the_readmes_python_example_prints_what_the_readme_shows():
    """Run as a user runs it: a fresh interpreter, headless, MUJOCO_GL unset (the delta's
    trays are photographed with the backend the call chooses)."""
    import ctypes.util
    import os
    import re
    import subprocess
    import sys
    from pathlib import Path

    if not (ctypes.util.find_library("EGL") or ctypes.util.find_library("OSMesa")):
        pytest.skip("no offscreen GL library on this machine")
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = readme.split("<!-- python_example -->", 1)[1]
    code, shown = re.findall(r"```(?:python)?\n(.*?)```", block, re.S)[:2]
    drop = ("MUJOCO_GL", "DISPLAY", "WAYLAND_DISPLAY", "PYOPENGL_PLATFORM")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=600)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout == shown
