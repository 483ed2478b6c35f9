"""The judge: each seedling's outcome comes from the physics at the moments that decide it."""

import numpy as np
import pytest

from conftest import paper_config, variant
from transplanter.config import assemble
from transplanter.judge import Judge
from transplanter.results import EventKind, Outcome, SeedlingRecord
from transplanter.scenario import load_scenario
from transplanter.sim import Twin
from transplanter.trial import run_trial


def _judged_twin(config):
    twin = Twin(config)
    records = [SeedlingRecord(i, i % twin.machine.eeprom.m_pp) for i in range(config.seedlings)]
    events = []
    judge = Judge(twin, config.judge, records, lambda *e: events.append(e))
    twin.line_listeners.append(judge.on_line)
    return twin, judge, records, events


def test_a_pickup_aimed_at_no_cell_is_no_pot(tmp_path):
    """Pickup 1 taught 40 mm beside the row's first cell: no pot was ever placed there, so
    the gripper closes on air and the seedling is 'no_pot', not a knocked-over pot."""
    path = variant(
        tmp_path,
        {
            "approach_mm = [-90.0, 180.0]": "approach_mm = [-130.0, 180.0]",
            "grip_mm = [-90.0, 215.0]": "grip_mm = [-130.0, 215.0]",
        },
    )
    result = run_trial(assemble(load_scenario(path, {"scenario.seedlings": 2})))
    first, second = result.per_seedling
    assert first.outcome == Outcome.NO_POT and first.pot is None
    assert first.peak_grip_force_n == 0.0  # the jaws closed on air
    assert second.outcome == Outcome.SUCCESS
    assert result.failures()["knocked_over"] == 0


def test_a_pot_taken_out_of_its_cell_is_knocked_over():
    """The first pot is thrown off the belt before the arm comes for it: its cell had a pot,
    so the seedling is knocked over (the pot left its cell), not 'no_pot'."""
    config = paper_config(1)
    twin, judge, records, events = _judged_twin(config)
    pot = twin.scene.pot_qpos_adr[0]
    moved = []

    def push_aside(tw):
        if not moved:
            tw.data.qpos[pot] -= 1.0  # a metre aside, off the belt
            moved.append(tw.time)

    twin.exchange_listeners.append(push_aside)
    twin.step_until(10.0)
    judge.finish(twin.time, valid=True)
    assert records[0].outcome == Outcome.KNOCKED_OVER
    failures = [e for e in events if e[1] == EventKind.FAILURE]
    assert failures and failures[0][3] == 0 and "knocked_over" in failures[0][2]


def test_failure_kind_takes_the_first_failed_check():
    rec = SeedlingRecord(0, 0, knocked_before=True, microsteps_lost=64, lifted=False)
    assert Judge.failure_kind(rec) == Outcome.KNOCKED_OVER
    rec.knocked_before = False
    assert Judge.failure_kind(rec) == Outcome.LOST_STEPS
    rec.microsteps_lost = 0
    assert Judge.failure_kind(rec) == Outcome.NOT_GRIPPED
    rec.lifted, rec.in_gripper_at_drop = True, False
    assert Judge.failure_kind(rec) == Outcome.SLIPPED
    rec.in_gripper_at_drop = True
    assert Judge.failure_kind(rec) == Outcome.DROPPED_OUTSIDE


@pytest.mark.slow
def test_each_cycle_picks_the_pot_the_conveyor_brought():
    """Across a conveyor index the judge follows the rows: seedlings 5-9 take row 1's pots."""
    result = run_trial(paper_config(10))
    assert [r.outcome for r in result.per_seedling] == [Outcome.SUCCESS] * 10
    assert [r.pot for r in result.per_seedling] == list(range(10))
    assert np.all([r.peak_grip_force_n > 5.0 for r in result.per_seedling])


@pytest.mark.slow
def test_lost_steps_name_their_cause_and_the_seedlings_they_cost():
    """At Z_low = 28 mm the palm and jaws strike pots and ribs and motors slip. Every
    lost-step event names what the machine touched; a seedling failed in the cycle of a strike
    is lost_steps, a later one whose arm was still off position is position_lost, pointing at
    the first strike since homing."""
    result = run_trial(paper_config(20, **{"taught.z_low_mm": 28.0}))
    events = result.lost_step_events
    assert events, "a 28 mm approach strikes the pots and slips a motor"
    for e in events:
        assert e["microsteps"] != 0 and e["motor"] in (0, 1, 2)
        assert e["contacts"], "a slip at a strike has contacts on the machine"
    for r in result.per_seedling:
        if r.outcome == Outcome.POSITION_LOST:
            assert r.position_error_microsteps > 0
            assert events[r.lost_step_event]["t_s"] < r.t_start_s
        if r.outcome == Outcome.LOST_STEPS:
            assert r.t_start_s <= events[r.lost_step_event]["t_s"] <= r.t_release_s
    if result.failures()["position_lost"]:
        assert result.failures_clustered and result.to_dict()["success_rate_ci95"] is None


@pytest.mark.slow
def test_rehoming_counts_in_the_cycle_and_restores_the_position():
    """recovery.rehome_every_cycles = 2: cycles 2 and 4 start with G28 and take over 2 s
    longer; every pot still lands. At the 28 mm edge with a re-home before every cycle, no
    seedling can fail for a strike in an earlier cycle (position_lost)."""
    result = run_trial(paper_config(5, **{"recovery.rehome_every_cycles": 2}))
    assert result.successes == 5
    cycles = [r.cycle_time_s for r in result.per_seedling]
    assert min(cycles[2], cycles[4]) > max(cycles[0], cycles[1], cycles[3]) + 2.0
    edge = run_trial(
        paper_config(15, **{"taught.z_low_mm": 28.0, "recovery.rehome_every_cycles": 1})
    )
    assert edge.failures()["position_lost"] == 0
    assert all(r.position_error_microsteps == 0 for r in edge.per_seedling[1:])
