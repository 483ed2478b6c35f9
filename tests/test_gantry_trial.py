"""The gantry on the pot line (scenarios/gantry_pots.toml), end to end: the PGF's taught
program over the bus to the SGF, its lines through the gantry's kinematics to stepper pulses,
the steppers' torque law on the belts and the screw, the pots judged by the pot line's one
judge; and a stepper that is asked to start faster than it can loses steps."""

from __future__ import annotations

import pytest

from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.twin.results import FAILURE_KINDS
from transplanter.twin.trial import run_trial


def _trial(seedlings: int, **overrides):
    scenario = load_scenario("gantry_pots", {"scenario.seedlings": seedlings, **overrides})
    return run_trial(assemble(scenario)).to_dict()


@pytest.fixture(scope="module")
def five():
    return _trial(5)


def test_the_gantry_places_the_pots_in_the_paper_cycle(five):
    assert five["valid"] and five["successes"] == 5
    assert five["lost_step_events"] == []
    # the same taught lines as the paper's five-bar: its cycle, set by the Z screw's step
    # rate and the taught speeds, not by the arm that draws them
    assert five["cycle_time_s"] == pytest.approx(3.496, abs=0.01)
    names = [d["name"] for d in five["motors"]["drives"]]
    assert names == ["x", "y", "z", "gripper", "wrist"]
    # the belts carry the carriage on X: a torque at the motor, below the 0.45 N m it holds
    x_peak = five["motors"]["drives"][0]["peak"]
    assert 0.05 < x_peak < 0.45


def test_the_pot_line_judge_judges_the_gantry_as_the_five_bar(five):
    assert set(five["failures"]) == set(FAILURE_KINDS)
    assert {"max_stem_bend_deg", "funnel_jams", "per_seedling", "placed_per_hour"} <= set(five)
    record = five["per_seedling"][0]
    assert record["outcome"] == "success"
    assert {"peak_stem_bend_deg", "shoot_pressed_deg", "peak_grip_force_n", "jam"} <= set(record)


def test_homing_faster_than_the_steppers_start_loses_steps():
    """G28 seeks at a constant step rate from rest: at 4000 microsteps/s (100 mm/s of belt)
    the X motor, carrying the Y beam, the carriage, the ram and the jaws (2.2 kg and its
    rotor), cannot follow its field from a standstill and slips a whole electrical cycle
    (4 full steps, 32 microsteps) at a time; at the packaged 1600 (40 mm/s) it follows."""
    fast = _trial(1, **{"gantry.homing_rate_xy_hz": 4000.0})
    slipped = fast["lost_step_events"]
    assert slipped and {e["motor"] for e in slipped} == {0}
    assert all(abs(e["microsteps"]) == 32 for e in slipped)
    assert all(e["t_s"] < 4.5 for e in slipped)  # in the homing, before the first pick


def test_the_pot_line_takes_the_gantry_with_the_jaws_only():
    from transplanter import kinds

    job = kinds.job("conveyor_tube")
    assert job.refusal("gantry", "parallel_jaw") is None
    assert job.runner("gantry") == ""  # the PGF's program: the twin's own trial
    assert job.refusal("gantry", "fuzzy_gripper") == (
        "the gantry robot does the pot line with the parallel_jaw effector only"
    )


def test_a_five_bar_key_on_the_gantry_is_refused_by_name():
    from transplanter.scenario.schema import ScenarioError

    with pytest.raises(ScenarioError, match=r"\[arm\] l0_mm \(read by the fivebar robot\)"):
        load_scenario("gantry_pots", {"arm.l0_mm": 60.0})
    with pytest.raises(ScenarioError, match=r"\[drives\] arm_belt_ratio \(read by the fivebar"):
        load_scenario("gantry_pots", {"drives.arm_belt_ratio": 4.0})
