"""Trials end to end: the paper regression, determinism, and the physics answering changes.

The 40-seedling paper trial is run once per session (about 10 s) and shared by the tests.
"""

import dataclasses
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import PAPER_PATH, ROOT, paper_config, variant
from transplanter.cli import main
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.scene import PotBatch
from transplanter.twin.results import FAILURE_KINDS, Outcome
from transplanter.twin.trial import run_trial

# Baseline recorded from the 40-seedling paper trial, seed 1 (2026-11-21): 40/40 successes
# (100 %, 95 % Wilson interval 91.2-100 %), mean cycle 3.496 s; seeds 2-6 also gave 40/40.
# The paper reports 93.3 %: the twin has fewer failure modes than the field (see README).
BASELINE_SEED = 1
BASELINE_SUCCESSES = 40


@pytest.fixture(scope="module")
def paper_result():
    config = paper_config(**{"scenario.seed": BASELINE_SEED})
    assert config.seedlings == 40
    return run_trial(config)


@pytest.mark.slow
def test_paper_cycle_time_is_3_5_s(paper_result):
    d = paper_result.to_dict()
    assert d["valid"], d["invalid_reason"]
    assert d["seedlings"] == 40
    assert d["cycle_time_s"] == pytest.approx(3.496, abs=0.005)  # paper: 3.5 s
    # a pick every 3.617 s over 7 whole rows (the index between rows included): 995 an hour
    assert d["pick_pitch_s"] == pytest.approx(3.617, abs=0.005) and d["pick_pitch_picks"] == 35
    assert d["plants_per_hour"] == pytest.approx(995.0, abs=2.0)
    # the conveyor's drive holds the belt while the arm picks: it moves under 1 mm
    assert 0.0 < d["max_belt_displacement_mm"] < 1.0
    assert len(d["belt_realignments"]) == 7  # 8 rows: 7 indexes, each takes back the offset
    assert all(abs(r["offset_mm"]) < 1.0 for r in d["belt_realignments"])


@pytest.mark.slow
def test_paper_success_rate_at_least_baseline(paper_result):
    assert paper_result.successes >= BASELINE_SUCCESSES
    failures = paper_result.failures()
    assert sum(failures.values()) == 40 - paper_result.successes
    for rec in paper_result.per_seedling:
        assert rec.cycle_time_s is not None and rec.t_start_s < rec.t_release_s
        assert rec.cycle_time_s == pytest.approx(rec.t_release_s - rec.t_start_s)
        if rec.outcome == Outcome.SUCCESS:
            # the servo squeezes at its force limit (6 N per jaw) while the pot is held
            assert rec.peak_grip_force_n == pytest.approx(6.0, rel=0.05)
            assert rec.lifted and rec.in_gripper_at_drop and rec.microsteps_lost == 0
    # every pot picked is a different one, and the five pickups of a row take its five pots
    pots = [r.pot for r in paper_result.per_seedling]
    assert sorted(pots) == list(range(40))


@pytest.mark.slow
def test_same_seed_gives_identical_json(tmp_path):
    """Same scenario and seed: the same JSON apart from wall time, in this process and in a
    fresh interpreter (no dependence on hash seeds, import order or leftover state)."""
    args = ["trial", str(PAPER_PATH), "--seedlings", "6", "--seed", "3", "--quiet", "--json"]
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
    assert a["seedlings"] == 6 and len(a["per_seedling"]) == 6
    assert set(a["failures"]) == {str(k) for k in FAILURE_KINDS}
    # another seed draws other pots, so the per-seedling numbers differ
    other = tmp_path / "other.json"
    assert main(["trial", "paper", "--seedlings", "6", "--seed", "4", "--quiet", "--json",
                 str(other)]) == 0  # fmt: skip
    assert json.loads(other.read_text())["per_seedling"] != a["per_seedling"]


@pytest.mark.slow
def test_raising_s_high_shortens_the_cycle():
    slow = run_trial(paper_config(5))
    fast = run_trial(paper_config(5, **{"taught.s_high_mm_s": 250.0}))
    # approach, retract and drop moves get faster; the Z lift and the dwells do not
    assert fast.to_dict()["cycle_time_s"] < slow.to_dict()["cycle_time_s"] - 0.1


@pytest.mark.slow
def test_an_index_too_fast_tips_the_pots_it_pushes():
    """The paper indexes a row in 0.6 s. In 0.3 s the ribs push the pots across the belt
    table hard enough to tip them: every pot of the second row is knocked out of its cell
    before its approach (`knocked_over`), the first row (never pushed) is picked whole."""
    result = run_trial(paper_config(10, **{"conveyor.index_time_s": 0.3}))
    first, second = result.per_seedling[:5], result.per_seedling[5:]
    assert all(r.outcome == Outcome.SUCCESS for r in first)
    assert all(r.outcome == Outcome.KNOCKED_OVER and r.knocked_before for r in second)


@pytest.mark.slow
def test_approach_too_low_strikes_the_belt_and_the_bridge_clears_the_rims():
    """The paper approaches at Z_low = 34 mm. At 22 mm the jaw tips (22.5 mm below the grip
    centre) reach into the belt: they strike it, a motor slips, and the open-loop arm stays
    off position, so the success rate collapses. At 28 mm the jaws' side plates stand clear
    of the rims and the bridge (68 mm over the grip centre) passes 96 mm over the belt: it
    brushes only the tallest shoots, which lean out of its way and survive, and every pot
    lands (1 shoot touched, 7 deg, of 10 when written)."""
    good = run_trial(paper_config(10))
    low = run_trial(paper_config(10, **{"taught.z_low_mm": 22.0}))
    assert good.success_rate == 1.0
    assert max(r.peak_stem_bend_deg for r in good.per_seedling) < 20.0
    assert low.success_rate <= 0.5
    failures = low.failures()
    struck = ("not_gripped", "knocked_over", "slipped", "lost_steps", "position_lost")
    assert sum(failures[k] for k in struck) >= 4
    edge = run_trial(paper_config(10, **{"taught.z_low_mm": 28.0}))
    assert edge.success_rate == 1.0
    assert all(r.shoot_pressed_deg < 20.0 for r in edge.per_seedling)


def test_rejected_move_is_recorded_and_nothing_after_it_runs(tmp_path):
    """Without the preflight, the SGF itself refuses an unreachable grip point (error:33):
    that seedling is 'move_rejected', the rest 'not_run', and the firmware fault is reported."""
    path = variant(tmp_path, {"grip_mm = [-45.0, 215.0]": "grip_mm = [-45.0, 330.0]"})
    config = assemble(load_scenario(path, {"scenario.seedlings": 5}), preflight=False)
    result = run_trial(config)
    outcomes = [r.outcome for r in result.per_seedling]
    assert outcomes == [Outcome.SUCCESS, Outcome.MOVE_REJECTED] + [Outcome.NOT_RUN] * 3
    assert "error:33 target position not reachable" in result.per_seedling[1].rejected_line
    assert result.fault is not None and result.valid
    assert result.attempted == 2  # one success, one rejected; three never ran
    # the rate counts the two picks started, the rejected one's start included
    d = result.to_dict()
    assert d["pick_pitch_picks"] == 1 and d["plants_per_hour"] == pytest.approx(
        3600 / (result.per_seedling[1].t_start_s - result.per_seedling[0].t_start_s)
    )


def test_invalid_physics_is_never_a_success():
    """Infinite forces injected mid-trial: the result is invalid, nothing is judged a
    success, and the seedling in progress is not run."""
    from transplanter.twin.sim import Twin

    class PoisonedTwin(Twin):
        def __post_init__(self):
            super().__post_init__()
            self.exchange_listeners.append(self.poison)

        @staticmethod
        def poison(tw):
            if tw.time > 3.0:
                tw.data.qfrc_applied[:] = np.inf

    result = run_trial(paper_config(1), twin_factory=PoisonedTwin)
    assert not result.valid and result.successes == 0
    assert "MuJoCo warning" in result.invalid_reason or "diverged" in result.invalid_reason
    assert result.per_seedling[0].outcome == Outcome.NOT_RUN


@pytest.mark.slow
def test_recorded_trial_reads_back(tmp_path, capsys):
    """A 2-seedling trial recorded to .rrd, read back with rerun's own API."""
    from transplanter.viewing.channels import channel_names
    from transplanter.viewing.playback import read_summary

    rrd, out = tmp_path / "two.rrd", tmp_path / "two.json"
    args = ["trial", "paper", "--seedlings", "2", "--record", str(rrd), "--json", str(out)]
    assert main([*args, "--quiet"]) == 0
    result = json.loads(out.read_text())
    summary = read_summary(rrd)
    entities = set(summary["entity_paths"])
    for body in ("link1", "link2", "passive1", "passive2", "gripper", "jaw_left", "platform",
                 "conveyor", "pot_0_0", "pot_7_4"):  # fmt: skip
        assert f"world/bodies/{body}" in entities, body
    t0, t1 = summary["sim_time_range"]
    assert t0 == 0.0
    assert t1 == pytest.approx(result["sim_time_s"], abs=1e-9)
    events = summary["events"]
    assert events["grasp"] == events["release"] == 2
    assert events["success"] + events.get("failure", 0) == 2
    assert events["sent"] == events["ack"] > 20
    assert set(summary["scalar_channels"]) == set(channel_names())
    assert "recording written to" in capsys.readouterr().out


@pytest.mark.slow
@pytest.mark.parametrize("rows", [24, 100])
def test_conveyors_up_to_the_schema_limit_run_a_trial(rows):
    """conveyor.rows up to the schema's 100 (500 pots) run a 5-seedling paper trial."""
    result = run_trial(paper_config(5, **{"conveyor.rows": rows}))
    assert result.valid and result.successes == 5


# -- injected faults ([faults]): each ends the run with its named error, nothing moves after --


def _fault_trial(seedlings: int = 1, **overrides):
    """A short trial with scenario overrides; the result and the twin it ran."""
    from transplanter.twin.sim import Twin

    twins = []

    def factory(cfg):
        twins.append(Twin(cfg))
        return twins[0]

    result = run_trial(paper_config(seedlings, **overrides), twin_factory=factory)
    return result, twins[0]


def _assert_stopped(result, twin, kind: str, t_fault: float) -> None:
    """The trial ended on the firmware fault of this kind at t_fault, and after it no line
    was sent and no stepper pulse was issued (the physics ran on for the settle time)."""
    assert result.valid and result.fault == twin.pgf.fault and result.fault_kind == kind
    d = result.to_dict()
    assert d["fault_kind"] == kind and d["fault"] == result.fault
    assert all(line.t_sent <= t_fault for line in twin.pgf.sent)
    assert twin.time > t_fault
    times = np.linspace(t_fault, twin.time, 20)
    pulses = twin.sgf.pulses_at(times)
    assert (pulses == pulses[0]).all()
    from transplanter.twin.report import format_summary

    assert re.search(rf"^fault kind +{kind}$", format_summary(result), re.MULTILINE)


def test_paper_without_faults_is_unchanged():
    """[faults] all off: the same outcomes and cycle times as before the faults existed
    (seed 1: 3.779 s and 3.365 s with the stepper torque laws), no fault."""
    result = run_trial(paper_config(2))
    assert result.fault is None and result.fault_kind is None
    assert [r.outcome for r in result.per_seedling] == [Outcome.SUCCESS] * 2
    assert [r.cycle_time_s for r in result.per_seedling] == pytest.approx([3.779, 3.365], abs=1e-9)
    assert result.to_dict()["fault_kind"] is None


def test_a_switch_stuck_closed_stops_homing_with_its_error():
    result, twin = _fault_trial(**{"faults.switch_stuck_closed": 2})
    home = twin.pgf.sent[-1]
    assert home.phase == "home" and home.reply.startswith(
        "error:68 homing failed: limit switch 2 (arm 2 home) still closed after the 96-step "
        "pull-off (it was already closed when homing began): the switch is stuck closed or "
        "its wiring is shorted"
    )
    assert result.fault == f"SGF refused 'N1 G28*18' (home): {home.reply}"
    _assert_stopped(result, twin, "switch_stuck_closed", home.t_reply)
    assert [r.outcome for r in result.per_seedling] == [Outcome.NOT_RUN]


def test_switch_4_stuck_closed_refuses_the_first_move_down():
    result, twin = _fault_trial(**{"faults.switch_stuck_closed": 4})
    line = twin.pgf.sent[-1]
    assert line.phase == "to_start" and line.reply.startswith(
        "error:70 limit switch 4 (Z down) reads closed at Z 159.000 mm"
    )
    _assert_stopped(result, twin, "switch_stuck_closed", line.t_reply)


def test_a_dead_switch_is_never_found_and_the_arm_stops():
    """Switch 1 unplugged: arm 1 seeks its 180 deg, slipping against its hard stop (steps
    lost, unnoticed without stall detection), and homing fails naming the switch."""
    result, twin = _fault_trial(**{"faults.switch_dead": 1})
    home = twin.pgf.sent[-1]
    assert home.reply.startswith(
        "error:69 homing failed: limit switch 1 (arm 1 home) not found: motor 1 travelled "
        "4800 steps (180.0 deg) towards it and it never closed; the switch is dead or unplugged"
    )
    assert result.lost_step_events  # the arm pushed against its hard stop
    _assert_stopped(result, twin, "switch_not_found", home.t_reply)


def test_a_lost_reply_ends_the_run_with_a_bus_timeout():
    result, twin = _fault_trial(**{"faults.lost_reply_line": 10})
    line = twin.pgf.sent[-1]
    assert len(twin.pgf.sent) == 10 and line.reply is None and line.phase == "close"
    assert result.fault == (
        f"bus timeout: no reply to line 10 {line.text!r} (close) within 30 s; check the "
        "serial cable and that the SGF is powered and running"
    )
    _assert_stopped(result, twin, "bus_timeout", line.t_sent + 30.0)
    assert [r.outcome for r in result.per_seedling] == [Outcome.NOT_RUN]


JAM = {
    "faults.jam_motor": 1,
    "faults.jam_at_s": 5.5,  # seedling 0 grips at about 5.3 s: during its lift
    "faults.jam_duration_s": 100.0,
    "faults.jam_torque_nm": 0.6,  # more than the motor's 0.45 N m holding torque
}


def test_a_jam_with_stall_detection_stalls_the_motor_and_stops_the_machine():
    """The physics lets motor 1 lag beyond its pull-out and slip; the driver reports it, the
    SGF stops with error:67. The PGF re-homes and retries into the jam until it gives the
    seedling up, and the re-home after that stalls too: the run ends, motor_stalled."""
    result, twin = _fault_trial(**JAM, **{"recovery.stall_detection": True})
    last = twin.pgf.sent[-1]
    assert last.phase == "stall_rehome" and last.reply.startswith("error:67 motor 1 stalled at")
    assert result.fault == f"SGF refused {last.text!r} (stall_rehome): {last.reply}"
    events = result.lost_step_events
    assert events[0]["motor"] == 0 and events[0]["detected"]  # the jammed motor, stepped
    assert sum(e["motor"] == 0 and e["detected"] for e in events) >= 4  # at every retry
    assert all(motor == 0 for _, motor in twin.sgf.stalls)  # the SGF stops on motor 1 each time
    assert twin.pgf.abandoned == [0]
    _assert_stopped(result, twin, "motor_stalled", last.t_reply)


def test_a_jam_without_stall_detection_loses_steps_silently():
    """The paper's open-loop machine: the same jam costs steps, and nothing stops."""
    result, twin = _fault_trial(2, **JAM)
    assert result.fault is None and result.fault_kind is None and twin.pgf.done
    assert result.lost_step_events
    assert not any(e["detected"] for e in result.lost_step_events)
    assert result.lost_step_events[0]["motor"] == 0  # the jammed motor slips first
    assert result.per_seedling[1].outcome == Outcome.POSITION_LOST


@pytest.mark.slow
def test_a_bond_stronger_than_the_grip_keeps_the_pot_on_the_belt():
    """Every pot bonded. The jaws lift about 7 N by friction (6 N per jaw, friction 0.6): a
    60 N bond holds the pot down (unless the lift peels it off its edge, which the physics
    decides: 2 of 3 seeds at least), a 1 N bond is torn off every time."""
    strong = [
        run_trial(
            paper_config(1, **{"scenario.seed": seed, "pots.bond_share": 1.0,
                               "pots.bond_force_n": 60.0})
        ).per_seedling[0]
        for seed in (1, 2, 3)
    ]  # fmt: skip
    stuck = [r for r in strong if r.outcome == "stuck_to_belt"]
    assert len(stuck) >= 2 and all(r.stuck_to_belt for r in stuck)
    assert all(r.bond_force_n == pytest.approx(60.0) for r in strong)
    assert all(r.peak_grip_force_n > 5.0 for r in stuck)  # gripped, and still did not rise
    weak = run_trial(paper_config(2, **{"pots.bond_share": 1.0, "pots.bond_force_n": 1.0}))
    assert [r.outcome for r in weak.per_seedling] == ["success", "success"]
    assert all(r.bond_force_n == pytest.approx(1.0) for r in weak.per_seedling)


@pytest.mark.slow
def test_an_index_error_leaves_the_row_off_until_the_next_index_takes_it_back():
    base = run_trial(paper_config(11))
    off = run_trial(paper_config(11, **{"conveyor.index_error_sd_mm": 2.0}))
    assert [r["offset_mm"] for r in base.belt_realignments][1] == pytest.approx(0.0, abs=0.01)
    taken_back = off.belt_realignments[1]["offset_mm"]  # the first index's error
    assert 0.05 < abs(taken_back) < 8.0
    assert off.successes == base.successes == 11  # 2 mm along the approach: still gripped


@pytest.mark.slow
def test_a_row_the_index_left_far_off_is_missed_and_named_row_off():
    """conveyor.index_error_sd_mm = 15: the third row stops 18.8 mm and the fourth 19.3 mm
    off their places; a jaw comes down on each of their pots, and each of those failures is
    `row_off` (the belt did it), with the offset in its record. (At sd 10 mm, rows 12.5 and
    12.9 mm off, a jaw strikes each pot's side, and whether the struck pot still ends in the
    tube turns on the solver's path: sleep on and off split those ten pots differently
    between `row_off`, `damaged` and `success`; docs/edge_trials.md.)"""
    result = run_trial(paper_config(20, **{"conveyor.index_error_sd_mm": 15.0}))
    off_rows = result.per_seedling[10:20]
    assert all(r.row_off and abs(r.row_offset_mm) > 15.0 for r in off_rows)
    # a jaw strikes each pot's side; 9 of 10 named row_off when written, the other struck
    # pot tumbling out beside the tube (dropped_outside): none lands
    assert sum(r.outcome == Outcome.ROW_OFF for r in off_rows) >= 8
    assert not any(r.outcome == Outcome.SUCCESS for r in off_rows)
    assert all(abs(r.row_offset_mm) < 4.0 for r in result.per_seedling[:5])  # row 1: not off


@pytest.mark.slow
def test_frictionless_pots_are_never_carried():
    result = run_trial(paper_config(3, **{"pots.friction": 0.0, "pots.friction_sd": 0.0}))
    assert result.successes == 0
    assert {r.outcome for r in result.per_seedling} <= {"not_gripped", "knocked_over"}
    assert any(r.outcome == "not_gripped" for r in result.per_seedling)


def test_calibrated_paper_scenario_is_the_paper_with_the_fitted_friction():
    paper = assemble(load_scenario("paper"))
    calibrated = assemble(load_scenario("paper_calibrated"))
    assert calibrated.name == "paper_calibrated"
    assert calibrated.scene.pot_friction == pytest.approx(0.13598, abs=1e-5)
    assert dataclasses.replace(calibrated.scene, pot_friction=paper.scene.pot_friction) == (
        paper.scene
    )
    for part in ("machine", "gripper_servo", "wrist_servo", "judge", "faults", "seedlings"):
        assert getattr(calibrated, part) == getattr(paper, part), part


@pytest.mark.slow
def test_calibrated_paper_scenario_gives_the_papers_success_one_pot_at_a_time():
    """paper_calibrated (pots.friction fitted by `transplanter calibrate` to the paper's
    112/120): seeds 1-3 pooled inside the paper's 95 % interval at the 3.5 s cycle (113/120
    when fitted), and every failure is the mechanism the fit stands for: a pot whose jaw
    friction cannot carry it slides out of the jaws (`not_gripped` as they rise, `slipped`
    on the way), one at a time, no motor ever slips."""
    successes = 0
    for seed in (1, 2, 3):
        config = assemble(load_scenario("paper_calibrated", {"scenario.seed": seed}))
        result = run_trial(config)
        successes += result.successes
        assert result.to_dict()["cycle_time_s"] == pytest.approx(3.5, abs=0.1)
        assert {k for k, v in result.failures().items() if v} <= {"not_gripped", "slipped"}
        assert not result.lost_step_events
        friction = PotBatch.draw(config.scene, seed).friction
        for rec in result.per_seedling:
            # about 0.04 lifts a 45-55 g pot with 6 N per jaw (friction on both jaws)
            if rec.outcome in (Outcome.NOT_GRIPPED, Outcome.SLIPPED):
                assert friction[rec.pot] < 0.06, (seed, rec.pot, friction[rec.pot])
            else:
                assert friction[rec.pot] > 0.035, (seed, rec.pot, friction[rec.pot])
    assert 0.87 <= successes / 120 <= 0.97, successes  # the paper: 112/120, 87.4-96.6 %


@pytest.mark.slow
def test_canopy_contact_lets_the_jaws_push_neighbours_over():
    """With the leaves touching the jaws (stiff leaves: 100 ms), the jaws coming down beside
    a pot push its neighbours by their leaves and knock some over; a pot whose leaves a jaw
    had pushed before its turn and that is then found knocked over is `tipped_by_leaf`
    (paper and paper_calibrated leave the mechanism off: their regression tests above)."""
    result = run_trial(
        paper_config(10, **{"pots.canopy_contact": True, "pots.canopy_timeconst_ms": 100.0})
    )
    failures = result.failures()
    # 2 knocked_over, 4 pots with pushed leaves failing otherwise, 1 success of 10 when
    # written (the stepper torque laws; 1 tipped_by_leaf and 3 knocked_over before them)
    assert failures["tipped_by_leaf"] + failures["knocked_over"] >= 2
    assert sum(r.canopy_pushed for r in result.per_seedling) >= 3
    assert result.successes <= 8
    for rec in result.per_seedling:
        assert (rec.outcome == Outcome.TIPPED_BY_LEAF) == (rec.knocked_before and rec.canopy_pushed)


@pytest.mark.slow
def test_fast_moves_at_2_g_slide_the_slippery_pots_out_of_the_jaws():
    """paper_calibrated leaves the grip little margin (~0.04 friction lifts a pot at rest,
    ~0.1 while the arm accelerates it sideways at 2 g): at 500 mm/s and 20,000 mm/s^2 the
    ramps last long enough for the slipperiest pots to slide out on the way to the tube
    (`slipped`); the paper's speeds lose only the pots too slippery to lift (37/40)."""
    config = assemble(
        load_scenario(
            "paper_calibrated",
            {"taught.s_high_mm_s": 500.0, "motion.accel_mm_s2": 20000.0, "scenario.seed": 1},
        )
    )
    result = run_trial(config)
    failures = result.failures()
    assert failures["slipped"] >= 3  # 7 when written (30/40)
    assert result.successes <= 34
    assert result.to_dict()["cycle_time_s"] < 2.7  # 2.661 s against the paper's 3.496 s


@pytest.mark.slow
def test_paper_trial_reports_the_moves_z_slowed(paper_result):
    """The paper's S_l (60 mm/s) is above what Z's motor can step (50 mm/s at 20,000
    steps/s), and moves with a Z part at S_h are held to Z's rate too: the firmware obeys,
    and the results say so (summary and JSON), nothing is clipped silently."""
    warnings = paper_result.to_dict()["warnings"]
    assert any(w.startswith("40 moves asked for 60 mm/s cruised at 50.0 mm/s") for w in warnings)
    assert all("motor 3 reaches its top step rate" in w for w in warnings), warnings
    from transplanter.twin.report import format_summary

    assert "warning " in format_summary(paper_result)


@pytest.mark.slow
def test_a_soaked_pot_gives_under_the_jaws_and_is_not_held():
    """pots.soft_share: the jaws close into a soaked pot whose wall gives 40 mm before it
    resists, the servo reaches its commanded opening and the squeeze falls from 6 N to
    about 0.2 N: the pot stays on the belt (`soft_pot`); the firm pots are held as ever."""
    config = paper_config(6, **{"pots.soft_share": 0.5, "pots.soft_wall_mm": 40.0})
    result = run_trial(config)
    soft = [r for r in result.per_seedling if r.soft]
    firm = [r for r in result.per_seedling if not r.soft]
    assert soft and firm  # 4 and 2 when written
    for rec in soft:
        assert rec.outcome == Outcome.SOFT_POT
        assert rec.peak_grip_force_n < 0.5
    for rec in firm:
        assert rec.outcome == Outcome.SUCCESS
        assert rec.peak_grip_force_n == pytest.approx(6.0, rel=0.05)


@pytest.mark.slow
def test_paper_seedlings_are_not_damaged(paper_result):
    """At the paper's speeds a shoot sways a few degrees in the jaws (7.3 deg mean when
    written, 22.8 at most), far from metrics.damage_bend_deg (45): no seedling is damaged,
    as the paper saw ("without any damage")."""
    bends = [r.peak_stem_bend_deg for r in paper_result.per_seedling]
    assert all(0.5 < b < 30.0 for b in bends), bends
    assert sum(bends) / len(bends) < 10.0
    assert paper_result.failures()["damaged"] == 0
    assert paper_result.to_dict()["max_stem_bend_deg"] == max(bends)  # all 40 in the tube


@pytest.mark.slow
def test_the_twin_shows_the_followed_shoots_bend_for_the_recording():
    """Twin.stem_bend_deg (the recording's seedling/stem_bend_deg channel) is the bend of the
    shoots the judge follows: it rises while a pot is carried and its peak is the record's."""

    class Watch:
        def __init__(self):
            self.values = []

        def attach(self, twin, records):
            pass

        def step(self, twin):
            self.values.append(twin.stem_bend_deg)

        def finish(self, twin, interrupted):
            pass

        def abort(self):
            pass

    watch = Watch()
    result = run_trial(paper_config(2), observers=[watch])
    peak = max(r.peak_stem_bend_deg for r in result.per_seedling)
    assert 1.0 < max(watch.values) <= peak + 1e-9
    assert max(watch.values) > 0.8 * peak  # sampled every 10 ms, the peak within substeps
    assert watch.values[0] == 0.0 and watch.values[-1] < 1.0  # nothing followed at the ends


@pytest.mark.slow
def test_fast_moves_whip_soft_shoots_past_their_damage_limit():
    """Shoots that all sway at 2 Hz (soft, tall seedlings): at 500 mm/s and 2 g each start and
    stop kicks them past 45 deg and every pot lands in the tube with a damaged seedling
    (`damaged`, a failure); at the paper's speeds the same shoots bend about 15 deg, one whose
    leaves the jaws hit 36 deg: none is damaged."""
    soft = {"pots.stem_sway_hz": 2.0, "pots.stem_sway_sd_hz": 0.0}
    fast = run_trial(
        paper_config(8, **soft, **{"taught.s_high_mm_s": 500.0, "motion.accel_mm_s2": 20000.0})
    )
    assert fast.successes == 0
    for rec in fast.per_seedling:
        assert rec.outcome == Outcome.DAMAGED  # in the tube: lifted, carried and dropped
        assert rec.lifted and rec.in_gripper_at_drop
        assert rec.peak_stem_bend_deg > 45.0  # 49-58 deg when written
    slow = run_trial(paper_config(8, **soft))
    assert slow.successes == 8
    slow_bends = sorted(r.peak_stem_bend_deg for r in slow.per_seedling)
    assert slow_bends[-2] < 20.0  # 14-16 deg when written
    assert slow_bends[-1] < 45.0  # 36 deg: the second pot, whose leaves the jaws hit


@pytest.mark.slow
def test_crooked_pots_are_straightened_by_the_jaws_and_whip_their_seedlings():
    """pots.crooked_share: a wall leaning 10-20 deg over its foot is pulled upright when the
    jaws close on it and swings as it is lifted, so its shoot bends far more than on a
    nearly straight pot (median about 35 against 5 deg when written); the record carries the
    pot's lean. (With the bridge high over the rim nothing stops a leaning pot from tipping
    further in the jaws: some land outside the tube, and one knocks over the pot behind it,
    which has no target pot at its turn.)"""
    config = paper_config(10, **{"pots.crooked_share": 1.0, "pots.crooked_max_deg": 20.0})
    result = run_trial(config)
    records = [r for r in result.per_seedling if r.pot is not None]
    crook = np.array([r.crook_deg for r in records])
    bend = np.array([r.peak_stem_bend_deg for r in records])
    pots = np.array([r.pot for r in records])
    drawn = PotBatch.draw(config.scene, config.seed).crook[pots]
    np.testing.assert_allclose(crook, np.degrees(drawn), rtol=1e-12)
    bent, straight = bend[crook > 10.0], bend[crook < 5.0]
    assert bent.size >= 3 and straight.size >= 2
    assert np.median(bent) > 20.0
    assert np.median(bent) > 3 * np.median(straight)
