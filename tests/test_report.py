"""Presentation: the summary table and text safe for a terminal."""

from transplanter.twin.report import format_summary, printable
from transplanter.twin.results import Outcome, SeedlingRecord, TrialResult


def test_summary_shows_rate_interval_and_every_failure_kind():
    records = [SeedlingRecord(i, i % 5, outcome=Outcome.SUCCESS) for i in range(39)]
    records.append(SeedlingRecord(39, 4, outcome=Outcome.NO_POT, cycle_time_s=3.5))
    text = format_summary(TrialResult("paper", 1, records, sim_time_s=147.0, wall_time_s=7.0))
    assert "97.5 % (39/40), 95 % CI 87.1-99.6 %" in text
    assert "failures: no_pot           1" in text
    assert "21.0x" in text.splitlines()[8]


def test_control_characters_are_shown_escaped():
    assert printable("paper\x1b[2J\u2028x") == "paper\\x1b[2J\\u2028x"
    assert printable("plain text (ok)") == "plain text (ok)"
    records = [SeedlingRecord(0, 0, outcome=Outcome.SUCCESS)]
    text = format_summary(TrialResult("evil\x1b]0;x\x07", 1, records, 1.0, 1.0))
    assert "\x1b" not in text and "evil\\x1b]0;x\\x07" in text


def test_long_work_is_estimated_from_the_pots_on_the_belt():
    from transplanter.twin.report import SEEDLING_WALL_S, estimate_line

    assert estimate_line(40) is None  # the paper trial: seconds
    line = estimate_line(1000)  # 1000 seedlings of the paper's belt: ~3 min
    assert line.startswith(f"about {1000 * SEEDLING_WALL_S / 60:.0f} min of work")
    # 100 rows (500 pots): each seedling costs (500/40)^1.65 = 64 times as much
    assert "1.8 h" in estimate_line(500, pots=500) and "~13 s each" in estimate_line(500, 500)
    assert "on 2 cores" in estimate_line(10_000, workers=2)
    assert "days" in estimate_line(2_000_000)


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
