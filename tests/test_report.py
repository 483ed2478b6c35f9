"""Presentation: the summary table, output path checks and atomic JSON files."""

import json
import os

from transplanter.report import format_summary, output_problem, write_json_atomic
from transplanter.results import Outcome, SeedlingRecord, TrialResult


def test_json_is_readable_by_others_and_leaves_no_temp(tmp_path):
    umask = os.umask(0o022)
    try:
        write_json_atomic(tmp_path / "r.json", {"a": 1})
    finally:
        os.umask(umask)
    assert (tmp_path / "r.json").stat().st_mode & 0o777 == 0o644
    assert json.loads((tmp_path / "r.json").read_text()) == {"a": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_output_problems_are_named(tmp_path):
    assert output_problem(None, None) is None
    assert output_problem(tmp_path / "r.json", None) is None
    assert "is a directory" in output_problem(tmp_path, None)
    assert "does not exist" in output_problem(tmp_path / "no" / "r.json", None)
    assert "must end in .rrd" in output_problem(tmp_path / "r.txt", ".rrd")


def test_summary_shows_rate_interval_and_every_failure_kind():
    records = [SeedlingRecord(i, i % 5, outcome=Outcome.SUCCESS) for i in range(39)]
    records.append(SeedlingRecord(39, 4, outcome=Outcome.NO_POT, cycle_time_s=3.5))
    text = format_summary(TrialResult("paper", 1, records, sim_time_s=147.0, wall_time_s=7.0))
    assert "97.5 % (39/40), 95 % CI 87.1-99.6 %" in text
    assert "failures: no_pot           1" in text
    assert "21.0x" in text.splitlines()[8]
