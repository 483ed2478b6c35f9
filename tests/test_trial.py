"""Trials end to end: the paper regression, determinism, and the physics answering changes.

The 40-seedling paper trial is run once per session (about 10 s) and shared by the tests.
"""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from transplanter.cli import main
from transplanter.scenario import ScenarioError, load_scenario
from transplanter.trial import FAILURE_KINDS, run_trial, wilson_interval

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "scenarios" / "paper.toml"

# Baseline recorded from the 40-seedling paper trial, seed 1 (2026-11-21): 40/40 successes
# (100 %, 95 % Wilson interval 91.2-100 %), mean cycle 3.503 s; seeds 2-6 also gave 40/40.
# The paper reports 93.3 %: the twin has fewer failure modes than the field (see README).
BASELINE_SEED = 1
BASELINE_SUCCESSES = 40


@pytest.fixture(scope="module")
def paper_result():
    scenario = load_scenario(PAPER, {"scenario.seed": BASELINE_SEED})
    assert scenario["scenario"]["seedlings"] == 40
    return run_trial(scenario)


@pytest.mark.slow
def test_paper_cycle_time_is_3_5_s(paper_result):
    d = paper_result.to_dict()
    assert d["valid"], d["invalid_reason"]
    assert d["seedlings"] == 40
    assert d["cycle_time_s"] == pytest.approx(3.5, abs=0.1)
    assert 15.0 < d["seedlings_per_min"] < 18.0  # paper: about 17 per minute


@pytest.mark.slow
def test_paper_success_rate_at_least_baseline(paper_result):
    assert paper_result.successes >= BASELINE_SUCCESSES
    failures = paper_result.failures()
    assert set(failures) == set(FAILURE_KINDS)
    assert sum(failures.values()) == 40 - paper_result.successes
    for rec in paper_result.per_seedling:
        assert rec.cycle_time_s is not None and rec.t_start_s < rec.t_release_s
        if rec.outcome == "success":
            # the servo squeezes at its force limit (6 N per jaw) while the pot is held
            assert rec.peak_grip_force_n == pytest.approx(6.0, rel=0.05)
            assert rec.lifted and rec.in_gripper_at_drop and not rec.lost_steps


def _small(n, **over):
    return load_scenario(PAPER, {"scenario.seedlings": n, **over})


@pytest.mark.slow
def test_same_seed_gives_identical_json(tmp_path):
    """Same scenario and seed: the same JSON apart from wall time, in this process and in a
    fresh interpreter (no dependence on hash seeds, import order or leftover state)."""
    args = ["trial", str(PAPER), "--seedlings", "6", "--seed", "3", "--quiet", "--json"]
    paths = [tmp_path / f"run{i}.json" for i in range(3)]
    assert main([*args, str(paths[0])]) == 0
    assert main([*args, str(paths[1])]) == 0
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), PYTHONHASHSEED="12345")
    subprocess.run(
        [sys.executable, "-m", "transplanter.cli", *args, str(paths[2])],
        check=True,
        env=env,
        capture_output=True,
    )
    runs = [json.loads(p.read_text()) for p in paths]
    for d in runs:
        d.pop("wall_time_s")
        d.pop("real_time_factor")
    assert runs[0] == runs[1] == runs[2]
    a = runs[0]
    for key in (
        "cycle_time_s",
        "success_rate",
        "successes",
        "seedlings",
        "failures",
        "per_seedling",
        "sim_time_s",
    ):
        assert key in a
    assert a["seedlings"] == 6 and len(a["per_seedling"]) == 6


@pytest.mark.slow
def test_raising_s_high_shortens_the_cycle():
    slow = run_trial(_small(5))
    fast = run_trial(_small(5, **{"taught.s_high_mm_s": 250.0}))
    # approach, retract and drop moves get faster; the Z lift and the dwells do not
    assert fast.to_dict()["cycle_time_s"] < slow.to_dict()["cycle_time_s"] - 0.1


@pytest.mark.slow
def test_approach_too_low_knocks_the_neighbours():
    """The paper approaches at Z_low. At Z_low = 26 mm the jaws still clear the belt (3.5 mm),
    but the palm above them (from 22.5 mm over the grip centre) sweeps at 48.5 mm, below the
    52 mm rims of the pot and its neighbours: it pushes them, and the success rate drops."""
    good = run_trial(_small(10))
    low = run_trial(_small(10, **{"taught.z_low_mm": 26.0}))
    assert good.success_rate == 1.0
    assert low.success_rate <= 0.5
    failures = low.failures()
    assert failures["not_gripped"] + failures["knocked_over"] + failures["slipped"] >= 4


def test_wilson_interval_known_values():
    lo, hi = wilson_interval(39, 40)
    assert lo == pytest.approx(0.8712, abs=1e-4) and hi == pytest.approx(0.9956, abs=1e-4)
    assert wilson_interval(0, 0) == (0.0, 1.0)
    lo, hi = wilson_interval(28, 30)  # the paper's 93.3 %
    assert lo < 28 / 30 < hi and math.isclose(lo, 0.7868, abs_tol=1e-3)


def test_unknown_key_refused_before_simulation(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(f'[scenario]\nbase = "{PAPER.as_posix()}"\n[taught]\nspeed_high = 3\n')
    assert main(["trial", str(bad), "--quiet"]) == 2
    assert "taught.speed_high: unknown key" in capsys.readouterr().err


def test_unreachable_taught_point_refused_naming_the_key(tmp_path, capsys):
    bad = tmp_path / "far.toml"
    text = PAPER.read_text().replace("grip_mm = [90.0, 215.0]", "grip_mm = [90.0, 340.0]")
    bad.write_text(text)
    assert main(["trial", str(bad), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "taught.pickup[4].grip_mm = [90, 340] mm cannot be reached" in err
    from transplanter.preflight import check_scenario

    with pytest.raises(ScenarioError, match="taught.pickup"):
        check_scenario(load_scenario(bad))


def test_path_through_singular_region_refused(tmp_path):
    """Both ends reachable, the straight line between them not: refused before simulating."""
    from transplanter import kinematics
    from transplanter.machine import machine_from_scenario
    from transplanter.preflight import check_scenario

    text = (
        PAPER.read_text()
        .replace("drop_mm = [0.0, 140.0]", "drop_mm = [-16.0, 84.0]")
        .replace("approach_mm = [-90.0, 180.0]", "approach_mm = [-131.0, 107.0]")
        .replace("grip_mm = [-90.0, 215.0]", "grip_mm = [-125.0, 110.0]")
    )
    path = tmp_path / "singular.toml"
    path.write_text(text)
    scenario = load_scenario(path)
    machine = machine_from_scenario(scenario)
    ends = kinematics.check_points(
        machine.geometry, machine.limits, [-0.016, -0.131, -0.125], [0.084, 0.107, 0.110]
    )
    assert ends.ok.all()  # every taught point on its own is fine
    with pytest.raises(
        ScenarioError,
        match=r"taught.pickup\[0\]: the move from .* leaves the "
        r"workspace: elbow angle at B",
    ):
        check_scenario(scenario)


def test_first_move_from_home_is_checked():
    """The drop point is reachable, but not on a straight line from the homed position."""
    from transplanter.preflight import check_scenario

    scenario = load_scenario(PAPER, {"taught.drop_mm": [80.0, 100.0]})
    with pytest.raises(ScenarioError, match="the first move, from the homed position .* to "):
        check_scenario(scenario)


@pytest.mark.slow
def test_recorded_trial_reads_back(tmp_path, capsys):
    """A 2-seedling trial recorded to .rrd, read back with rerun's own API."""
    from transplanter.recording import read_summary

    rrd = tmp_path / "two.rrd"
    out = tmp_path / "two.json"
    assert (
        main(
            [
                "trial",
                str(PAPER),
                "--seedlings",
                "2",
                "--record",
                str(rrd),
                "--json",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    result = json.loads(out.read_text())
    summary = read_summary(rrd)
    entities = set(summary["entity_paths"])
    for body in (
        "link1",
        "link2",
        "passive1",
        "passive2",
        "gripper",
        "jaw_left",
        "platform",
        "conveyor",
        "pot_0_0",
        "pot_7_4",
    ):
        assert f"world/bodies/{body}" in entities, body
    t0, t1 = summary["sim_time_range"]
    assert t0 == 0.0
    assert t1 == pytest.approx(result["sim_time_s"], abs=1e-9)
    events = summary["events"]
    assert events["grasp"] == events["release"] == 2
    assert events["success"] + events.get("failure", 0) == 2
    assert events["sent"] == events["ack"] > 20
    channels = set(summary["scalar_channels"])
    assert {
        "motors/theta1_cmd_deg",
        "motors/theta1_deg",
        "gripper/force_n",
        "conveyor/position_mm",
        "step_rate/z_hz",
    } <= channels
    assert "recording written to" in capsys.readouterr().out


def test_rejected_move_is_recorded_and_nothing_after_it_runs(tmp_path):
    """Without the preflight, the SGF itself refuses an unreachable grip point (error:33):
    that seedling is 'move_rejected', the rest 'not_run', and the firmware fault is reported."""
    text = PAPER.read_text().replace("grip_mm = [-45.0, 215.0]", "grip_mm = [-45.0, 330.0]")
    path = tmp_path / "reject.toml"
    path.write_text(text)
    result = run_trial(load_scenario(path, {"scenario.seedlings": 3}))
    outcomes = [r.outcome for r in result.per_seedling]
    assert outcomes == ["success", "move_rejected", "not_run"]
    assert "error:33 target position not reachable" in result.per_seedling[1].rejected_line
    assert result.fault is not None and result.valid


def test_cli_exit_status_for_a_firmware_fault(tmp_path, monkeypatch, capsys):
    text = PAPER.read_text().replace("grip_mm = [-45.0, 215.0]", "grip_mm = [-45.0, 330.0]")
    path = tmp_path / "reject.toml"
    path.write_text(text)
    assert main(["trial", str(path), "--seedlings", "3", "--quiet"]) == 2  # preflight refuses
    import transplanter.preflight

    monkeypatch.setattr(transplanter.preflight, "check_scenario", lambda scenario: None)
    assert main(["trial", str(path), "--seedlings", "3", "--quiet"]) == 4  # the SGF refuses
    assert "firmware fault" in capsys.readouterr().out


def test_a_missing_pot_is_a_failure_not_a_crash(tmp_path):
    """Pickup 1 taught 40 mm beside its cell: no pot stands there, the gripper closes on
    nothing, and the seedling counts as knocked over or out of its cell."""
    text = (
        PAPER.read_text()
        .replace("approach_mm = [-90.0, 180.0]", "approach_mm = [-130.0, 180.0]")
        .replace("grip_mm = [-90.0, 215.0]", "grip_mm = [-130.0, 215.0]")
    )
    path = tmp_path / "beside.toml"
    path.write_text(text)
    result = run_trial(load_scenario(path, {"scenario.seedlings": 2}))
    first, second = result.per_seedling
    assert first.pot is None and first.outcome == "knocked_over"
    assert first.peak_grip_force_n == 0.0  # the jaws closed on air
    assert second.outcome == "success"
    assert result.to_dict()["seedlings_per_min"] > 0


def test_seedlings_per_minute_counts_only_attempted(tmp_path, monkeypatch):
    text = PAPER.read_text().replace("grip_mm = [-45.0, 215.0]", "grip_mm = [-45.0, 330.0]")
    path = tmp_path / "reject.toml"
    path.write_text(text)
    result = run_trial(load_scenario(path, {"scenario.seedlings": 5}))
    assert result.attempted == 2  # one success, one rejected; three never ran
    d = result.to_dict()
    assert d["seedlings_per_min"] == pytest.approx(60 * 2 / d["sim_time_s"])


def test_cli_refuses_bad_output_paths_before_simulating(tmp_path, capsys):
    base = ["trial", str(PAPER), "--seedlings", "1", "--quiet"]
    assert main([*base, "--json", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err
    assert main([*base, "--record", str(tmp_path / "x.txt")]) == 2
    assert "must end in .rrd" in capsys.readouterr().err
    assert main([*base, "--json", str(tmp_path / "missing" / "r.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main([*base, "--record", str(tmp_path / "r.rrd"), "--record-rate", "0"]) == 2
    assert main(["trial", str(ROOT / "scenarios"), "--quiet"]) == 2
    assert "is a directory" in capsys.readouterr().err
    assert main(["trial", str(PAPER), "--seedlings", "41", "--quiet"]) == 2
    assert "more than the conveyor holds" in capsys.readouterr().err


def test_json_is_readable_by_others(tmp_path):
    from transplanter.trial import write_json_atomic

    umask = os.umask(0o022)
    try:
        write_json_atomic(tmp_path / "r.json", {"a": 1})
    finally:
        os.umask(umask)
    assert (tmp_path / "r.json").stat().st_mode & 0o777 == 0o644
    assert json.loads((tmp_path / "r.json").read_text()) == {"a": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]  # no temporary left behind
