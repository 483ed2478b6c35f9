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


def test_the_interval_carries_no_floating_point_noise_into_settings_csv(tmp_path):
    """settings.csv wrote ci95_low as 2.7755575615628914e-17 for 0 of 6 (Wilson's centre
    minus its half width) and 10 of 10 has an upper end of 0.9999999999999999: the ends are
    clipped to [0, 1] and rounded where the interval is computed."""
    import csv

    from transplanter.studies.stats import SETTING_FIELDS, aggregate
    from transplanter.studies.sweep import write_csv_atomic

    assert wilson_interval(0, 6)[0] == pytest.approx(2.7755575615628914e-17, abs=0)
    assert wilson_interval(10, 10)[1] == 0.9999999999999999
    assert pooled_rate([0, 0, 0], [2, 2, 2]).ci95[0] == 0.0
    assert pooled_rate([5, 5], [5, 5]).ci95[1] == 1.0
    lo, hi = pooled_rate([39, 38, 8, 40, 37], [40] * 5).ci95
    assert 0.0 < lo < hi <= 1.0 and round(lo, 12) == lo and round(hi, 12) == hi
    run = {"error": None, "cycles": 1, "cycle_time_s": 3.5}
    rows = [{**run, "z": 20.0, "seed": s, "successes": 0, "seedlings": 2} for s in (1, 2, 3)]
    rows += [{**run, "z": 30.0, "seed": s, "successes": 5, "seedlings": 5} for s in (1, 2)]
    write_csv_atomic(tmp_path / "settings.csv", ("z", *SETTING_FIELDS), aggregate(rows, ["z"]))
    text = (tmp_path / "settings.csv").read_text()
    assert "e-" not in text and "0.99999" not in text
    table = list(csv.DictReader(text.splitlines()))
    assert [(r["ci95_low"], r["ci95_high"]) for r in table] == [
        ("0.0", "0.390334287902"),
        ("0.722467200137", "1.0"),
    ]


def test_the_seedlings_that_would_decide_a_rate_against_its_floor():
    """The smallest n whose Wilson interval at the rate clears the floor: 35 perfect picks
    rule out 10 % failures (35/38.8 > 0.9: the rule of three's 30, Wilson's a few more)."""
    from transplanter.studies.stats import seedlings_to_decide
    from transplanter.twin.results import wilson_interval

    n = seedlings_to_decide(1.0, 0.9)
    assert n == 35 and wilson_interval(35, 35)[0] >= 0.9 > wilson_interval(34, 34)[0]
    below = seedlings_to_decide(0.625, 0.9)
    assert wilson_interval(round(0.625 * below), below)[1] < 0.9
    near = seedlings_to_decide(0.883, 0.9)
    assert near > 1000 and wilson_interval(round(0.883 * near), near)[1] < 0.9
    assert seedlings_to_decide(0.9, 0.9) is None  # at the floor no number decides


def test_the_interval_of_a_mean_over_trials():
    """Student's t over the trials' values (454, 450, 454 plants/h: 452.7 +- 5.7); a
    planned cycle, the same every trial, gives a zero-width interval; one trial none."""
    from transplanter.studies.stats import mean_interval

    lo, hi = mean_interval([454.0, 450.0, 454.0])
    assert (lo + hi) / 2 == pytest.approx(452.667, abs=1e-3)
    assert hi - lo == pytest.approx(2 * 4.303 * (2.3094 / 3**0.5), rel=1e-3)
    assert mean_interval([1581.0, 1581.0, 1581.0]) == (1581.0, 1581.0)
    assert mean_interval([1581.0]) is None
