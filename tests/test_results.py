"""Trial results: outcomes, the Wilson interval and the JSON form."""

import json
import math

import pytest

from transplanter.twin.results import (
    FAILURE_KINDS,
    Outcome,
    SeedlingRecord,
    TrialResult,
    wilson_interval,
)


def test_wilson_interval_known_values():
    lo, hi = wilson_interval(39, 40)
    assert lo == pytest.approx(0.8712, abs=1e-4) and hi == pytest.approx(0.9956, abs=1e-4)
    assert wilson_interval(0, 0) == (0.0, 1.0)
    lo, hi = wilson_interval(28, 30)  # the paper's 93.3 %
    assert lo < 28 / 30 < hi and math.isclose(lo, 0.7868, abs_tol=1e-3)
    lo, hi = wilson_interval(40, 40)
    assert hi == 1.0 and lo == pytest.approx(0.9124, abs=1e-4)


def _result(outcomes, sim_time_s=60.0):
    records = [SeedlingRecord(index=i, pickup=i % 5, outcome=o) for i, o in enumerate(outcomes)]
    return TrialResult("t", 1, records, sim_time_s=sim_time_s, wall_time_s=2.0)


def test_counts_and_rates_follow_the_outcomes():
    r = _result([Outcome.SUCCESS, Outcome.NO_POT, Outcome.SUCCESS, Outcome.NOT_RUN])
    assert r.successes == 2 and r.seedlings == 4 and r.success_rate == 0.5
    assert r.attempted == 3  # not_run seedlings never started
    failures = r.failures()
    assert failures["no_pot"] == 1 and failures["not_run"] == 1
    assert sum(failures.values()) == 2
    d = r.to_dict()
    assert d["plants_per_hour"] is None and d["pick_pitch_s"] is None  # no pick started
    assert d["real_time_factor"] == pytest.approx(30.0)


def _timed(starts, cols=5):
    records = [SeedlingRecord(index=i, pickup=i % cols, outcome=Outcome.SUCCESS, t_start_s=t)
               for i, t in enumerate(starts)]  # fmt: skip
    return TrialResult("t", 1, records, sim_time_s=starts[-1] + 3.0, wall_time_s=1.0)


def test_plants_per_hour_is_the_pitch_over_whole_rows_whatever_the_run_size():
    """A row of 5 picks of 3, 3, 3, 3 s and a 4 s last one with its index: 16 s a row,
    3.2 s a pick, 1125 an hour, from a run of 2, 3 or 8 rows and a partial one; the homing
    before the first pick (10 s here) is not counted."""
    row = [3.0, 3.0, 3.0, 3.0, 4.0]
    for n in (11, 17, 43):
        starts = [10.0 + sum((row * 9)[:i]) for i in range(n)]
        d = _timed(starts).to_dict()
        assert d["pick_pitch_s"] == pytest.approx(3.2) and d["pick_pitch_whole_rows"]
        assert d["plants_per_hour"] == pytest.approx(1125.0)
        assert d["pick_pitch_picks"] == 5 * ((n - 1) // 5)
        assert d["first_pick_start_s"] == 10.0
    # within one row: its picks alone, no index, said so
    d = _timed([10.0, 13.0, 16.0]).to_dict()
    assert d["pick_pitch_s"] == pytest.approx(3.0) and d["pick_pitch_whole_rows"] is False
    assert d["plants_per_hour"] == pytest.approx(1200.0) and d["pick_pitch_picks"] == 2
    assert _timed([10.0]).to_dict()["plants_per_hour"] is None  # one pick: no pitch


def test_failure_kinds_are_every_outcome_but_success_and_pending():
    assert Outcome.SUCCESS not in FAILURE_KINDS and Outcome.PENDING not in FAILURE_KINDS
    assert len(FAILURE_KINDS) == len(Outcome) - 2


def test_to_dict_is_plain_json():
    r = _result([Outcome.SUCCESS, Outcome.KNOCKED_OVER])
    text = json.dumps(r.to_dict(), sort_keys=True)
    back = json.loads(text)
    assert [s["outcome"] for s in back["per_seedling"]] == ["success", "knocked_over"]
    assert type(r.to_dict()["per_seedling"][0]["outcome"]) is str
    assert back["success_rate_ci95"] == list(wilson_interval(1, 2))
