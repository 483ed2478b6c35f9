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
    assert d["seedlings_per_min"] == pytest.approx(3.0)  # 3 attempted in 60 s
    assert d["real_time_factor"] == pytest.approx(30.0)


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
