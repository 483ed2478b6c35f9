"""Presentation: the summary table and text safe for a terminal."""

import re

import pytest

from transplanter.twin.report import format_summary, printable
from transplanter.twin.results import Outcome, SeedlingRecord, TrialResult


def test_summary_shows_rate_interval_and_the_failure_kinds_that_occurred():
    """The answer first, then only the kinds that occurred (the JSON keeps every kind)."""
    records = [SeedlingRecord(i, i % 5, outcome=Outcome.SUCCESS, t_start_s=4.0 + 3.6 * i)
               for i in range(39)]  # fmt: skip
    records.append(SeedlingRecord(39, 4, outcome=Outcome.NO_POT, cycle_time_s=3.5))
    result = TrialResult("paper", 1, records, sim_time_s=147.0, wall_time_s=7.0)
    text = format_summary(result)
    assert "97.5 % (39/40), 95 % CI 87.1-99.6 %" in text
    assert "failures: no_pot           1" in text
    assert [x for x in text.splitlines() if x.startswith("failures")] == [
        "failures: no_pot           1"
    ]
    assert result.to_dict()["failures"]["knocked_over"] == 0  # every kind in the JSON
    assert "21.0x" in text.splitlines()[10]
    # the throughput second, at the pick pitch over whole rows (seedling 35's start is the
    # last at pickup 0: 35 picks of 3.6 s), the homing before the first (4 s) left out
    assert text.splitlines()[4] == (
        "plants per hour            1000 (a pick every 3.600 s start to start, over 35 picks "
        "in whole rows: cycles, indexes and recoveries; the homing before the first, 4.00 s, "
        "left out)"
    )
    clean = [SeedlingRecord(i, i % 5, outcome=Outcome.SUCCESS) for i in range(40)]
    text = format_summary(TrialResult("paper", 1, clean, sim_time_s=147.0, wall_time_s=7.0))
    assert "failures:                  none" in text


def test_the_damage_leads_beside_success_throughput_and_cycle():
    """The summary's lead: success, throughput, cycle, then the damage (the seedlings whose
    shoot was bent too far or crushed, and the largest bend), before the times."""
    records = [SeedlingRecord(i, i % 5, outcome=Outcome.SUCCESS, peak_stem_bend_deg=8.0)
               for i in range(37)]  # fmt: skip
    records += [
        SeedlingRecord(37, 2, outcome=Outcome.DAMAGED, peak_stem_bend_deg=41.5),
        SeedlingRecord(38, 3, outcome=Outcome.SHOOT_CRUSHED, peak_stem_bend_deg=12.0),
        SeedlingRecord(39, 4, outcome=Outcome.NOT_GRIPPED),
    ]
    result = TrialResult("paper", 1, records, sim_time_s=147.0, wall_time_s=7.0)
    lines = format_summary(result).splitlines()
    labels = [line.split("  ")[0] for line in lines]
    assert labels[3:8] == [
        "success rate", "plants per hour", "placed per hour", "cycle time", "damage"
    ]  # fmt: skip
    bend = result.to_dict()["max_stem_bend_deg"]
    assert lines[7] == (
        "damage                     2/40 seedlings (5.0 %: damaged 1, shoot_crushed 1); "
        f"largest shoot bend {bend:.1f} deg"
    )
    clean = [SeedlingRecord(i, i % 5, outcome=Outcome.SUCCESS) for i in range(40)]
    text = format_summary(TrialResult("paper", 1, clean, sim_time_s=147.0, wall_time_s=7.0))
    assert "damage                     none (no shoot bent past metrics.damage_bend_deg or " in text


def test_control_characters_are_shown_escaped():
    assert printable("paper\x1b[2J\u2028x") == "paper\\x1b[2J\\u2028x"
    assert printable("plain text (ok)") == "plain text (ok)"
    records = [SeedlingRecord(0, 0, outcome=Outcome.SUCCESS)]
    text = format_summary(TrialResult("evil\x1b]0;x\x07", 1, records, 1.0, 1.0))
    assert "\x1b" not in text and "evil\\x1b]0;x\\x07" in text


def test_long_work_is_estimated_from_the_pots_on_the_belt():
    from transplanter.twin.report import SEEDLING_WALL_S, estimate_line

    assert estimate_line(40) is None  # the paper trial: seconds
    line = estimate_line(1000)  # 1000 seedlings of the paper's belt: ~4 min
    assert line.startswith(f"about {1000 * SEEDLING_WALL_S / 60:.0f} min of work")
    # a body per pot on 100 rows (500 pots): 2.2 s a seedling measured, (500/40)^0.93 x 0.25 s
    assert "22 min" in estimate_line(500, pots=500) and "~2.6 s each" in estimate_line(500, 500)
    assert "on 2 cores" in estimate_line(10_000, workers=2)
    assert "days" in estimate_line(2_000_000)


def _announced(line: str) -> tuple[float, float]:
    """The seconds of work and the seconds a seedling an estimate line announces."""
    amount, unit = re.search(r"about ([\d.]+) (min|h|days) of work", line).groups()
    seconds = float(amount) * {"min": 60, "h": 3600, "days": 86400}[unit]
    return seconds, float(re.search(r"~([\d.]+) s each", line).group(1))


def test_the_estimate_counts_the_window_of_live_rows(monkeypatch, capsys, tmp_path):
    """The README's soak (100 rows, live_rows 12: 60 pots are bodies) was announced as 1.8 h
    at 13 s a seedling; it measures 0.25-0.49 s a seedling (benchmarks/bench_belt.py). The
    announcements of `trial`, `trial --seeds` and `sweep` are within 2x of that."""
    from transplanter.cli import main, trials
    from transplanter.studies import sweep
    from transplanter.twin.report import estimate_line

    def stop(*args, **kwargs):
        raise KeyboardInterrupt  # the estimate is printed before this: nothing runs

    monkeypatch.setattr(trials, "_run", stop)
    monkeypatch.setattr(sweep, "run_sweep", stop)
    soak = ["paper", "--set", "conveyor.rows=100"]
    for argv, seedlings in (
        (["trial", *soak, "--seedlings", "500"], 500),
        (["trial", *soak, "--seeds", "1-5", "--seedlings", "100"], 500),
        (["sweep", *soak, "--vary", "taught.z_low_mm=20,22", "--seeds", "1-5",
          "--seedlings", "50", "--out", str(tmp_path / "s")], 500),
    ):  # fmt: skip
        assert main(argv) == 130
        line = next(x for x in capsys.readouterr().err.splitlines() if "of work" in x)
        seconds, each = _announced(line)
        assert 0.49 / 2 <= each <= 2 * 0.25, line
        assert seedlings * 0.49 / 2 <= seconds <= seedlings * 0.25 * 2, line
    # the 40-seedling paper trial (8 rows, every pot a body: 0.21-0.25 s a seedling measured)
    assert main(["trial", "paper"]) == 130
    assert "of work" not in capsys.readouterr().err  # seconds of work: not announced
    seconds, each = _announced(estimate_line(1000, 40))
    assert 0.25 / 2 <= each <= 2 * 0.21 and 1000 * 0.25 / 2 <= seconds <= 1000 * 0.21 * 2


def test_one_bar_runs_over_the_seedlings_of_every_seed(capsys):
    from transplanter.twin.report import seeds_bar

    assert seeds_bar(10, enabled=False) is None
    bar = seeds_bar(6, enabled=True)
    first, second = bar.for_trial(1, 0), bar.for_trial(2, 3)
    for done in (1, 2, 3):
        first(done, done * 3.5)
    assert bar.bar.n == 3
    bar.write("       1        3/3  100.0 %  no         -")
    for done in (1, 2, 3):
        second(done, done * 3.5)
    assert bar.bar.n == 6 and "seed 2" in bar.bar.postfix
    bar.close()
    assert "3/3" in capsys.readouterr().out  # the rows go to stdout above the bar


def test_placed_per_hour_is_the_whole_runs_yield_beside_the_picks_pace():
    """A long run's shift in one number: the seedlings placed an hour of the whole run, which
    a decay pulls down while the picks keep their pace (plants per hour)."""
    records = [
        SeedlingRecord(
            i,
            i % 5,
            outcome=Outcome.SUCCESS if i < 10 else Outcome.POSITION_LOST,
            t_start_s=4.0 + 3.6 * i,
        )  # fmt: skip
        for i in range(40)
    ]
    result = TrialResult("paper", 1, records, sim_time_s=147.6, wall_time_s=7.0)
    d = result.to_dict()
    assert d["placed_per_hour"] == pytest.approx(3600 * 10 / 147.6)
    assert d["plants_per_hour"] == pytest.approx(1000.0)  # a pick every 3.6 s, placed or not
    text = format_summary(result)
    assert "placed per hour            244 over the whole run (10 placed in 147.6 s: " in text
    assert "placed_per_hour" in d["definitions"]
