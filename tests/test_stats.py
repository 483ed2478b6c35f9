"""Pooled success over trials: an interval from the spread between trials, seeds parsing."""

import pytest

from transplanter.studies.stats import parse_seeds, pooled_rate
from transplanter.twin.results import wilson_interval


def test_identical_trials_give_the_wilson_interval_over_all_picks():
    p = pooled_rate([40, 40, 40], [40, 40, 40])
    assert p.success_rate == 1.0 and p.successes == 120 and p.trials == 3
    assert p.ci95 == pytest.approx(wilson_interval(120, 120))
    assert p.method == "Wilson over all picks"


def test_a_cascade_widens_the_interval_beyond_independent_picks():
    """Five trials at an edge setting: one cascade (8/40) among good ones. The picks of a
    trial are not independent, so the cluster bootstrap is much wider than Wilson."""
    k, n = [39, 38, 8, 40, 37], [40] * 5
    p = pooled_rate(k, n)
    lo_w, hi_w = wilson_interval(sum(k), sum(n))
    assert p.success_rate == pytest.approx(162 / 200)
    assert p.ci95[0] < lo_w - 0.05  # the spread between trials reaches far lower
    assert p.ci95[0] <= p.success_rate <= p.ci95[1]
    assert "cluster bootstrap" in p.method
    assert pooled_rate(k, n) == p  # a fixed resampling seed: the same answer every time


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError):
        pooled_rate([41], [40])
    with pytest.raises(ValueError):
        pooled_rate([], [])


def test_parse_seeds():
    assert parse_seeds("41-44") == [41, 42, 43, 44]
    assert parse_seeds("1,3,5-7") == [1, 3, 5, 6, 7]
    for bad, needle in [
        ("4-1", "backwards"),
        ("1,1", "twice"),
        ("x", "not N or N-M"),
        ("-3", "not N or N-M"),
        ("１", "not N or N-M"),
        ("0-20000", "more than 10000"),
    ]:
        with pytest.raises(ValueError, match=needle):
            parse_seeds(bad)
