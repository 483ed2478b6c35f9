"""transplanter.studies.jobs: the jobs with their own run (transplanter.runs) through the
studies' `run_one` (the dispatch by the job kind's run), their rows and their refusals."""

import pytest

from transplanter.runs import plug_trays
from transplanter.scenario.schema import load_scenario
from transplanter.studies import jobs
from transplanter.studies.backends import RESULT_FIELDS, run_one
from transplanter.studies.grid import task
from transplanter.twin.results import FAILURE_KINDS

# the truth's grading map: no GL context needed
SMALL = {"delta_refill.image_delay_ms": 0.0, "delta_refill.vision": "truth"}
NO_SPREAD = {"plug_bench.vigour_cv_pct": 0.0, "plug_bench.moisture_band_pct": 0.0}


def test_jobs_by_workcell_kind():
    assert jobs.job_of(load_scenario("paper")) is None  # the five-bar's trial
    assert jobs.job_of(load_scenario("delta_refill")).kind == "plug_trays"
    assert jobs.job_of(load_scenario("plug_bench")).kind == "plug_bench"
    assert jobs.job_of(load_scenario("serial_arm")).kind == "pool_to_belt"
    # the five-bar's workcell with the serial arm on it: the arm's pot job, not the five-bar's
    assert jobs.job_of(load_scenario("serial_arm_pots")).kind == "serial4:conveyor_tube"


def test_the_serial_arms_jobs_are_rows_of_their_picks():
    row = run_one(task("serial_arm", {}, {}, 1, 2))  # 2 tomatoes: the job's units
    assert row["error"] is None, row["error"]
    assert (row["successes"], row["seedlings"], row["cycles"]) == (2, 2, 1)
    assert 8.5 < row["cycle_time_s"] < 10.0
    assert row["plants_per_hour"] == pytest.approx(3600 / row["cycle_time_s"], rel=1e-3)
    assert 8.0 < row["peak_squeeze_n"] < 20.0 and row["fail_dropped"] == 0
    step = run_one(task("serial_arm", {}, {"physics.timestep_ms": 0.3}, 1, 2))
    assert step["error"].startswith("setting refused: ") and "20 ms PWM frame" in step["error"]
    pots = run_one(task("serial_arm_pots", {}, {}, 2, 2))
    assert pots["error"] is None, pots["error"]
    assert pots["seedlings"] == 2 and pots["fail_no_pot"] == 0
    # the five-bar's row: every failure kind of the pot line's judge
    fails = sum(pots[f"fail_{k}"] for k in FAILURE_KINDS)
    assert pots["successes"] + fails == 2 and pots["max_stem_bend_deg"] > 0


def test_a_delta_tray_is_a_row_of_serviced_cells_not_a_five_bar_refusal():
    # before the dispatch every delta run was "setting refused: taught.drop_mm ..."
    row = run_one(task("delta_refill", SMALL, {"delta_refill.pose_judgement": True}, 10, 1))
    assert row["error"] is None, row["error"]
    assert set(RESULT_FIELDS) <= set(row) and set(
        jobs.job_of(load_scenario("delta_refill")).fields
    ) <= set(row)
    assert (row["successes"], row["seedlings"], row["cycles"]) == (1, 1, 1)
    # the work time: the claws' arrival at the cell to its end (the approach is the tray's)
    assert row["cycle_time_s"] == pytest.approx(3.543)
    assert row["cycle_time_sd_s"] is None  # one operation: no spread
    assert row["substrate_retention"] == pytest.approx(0.87946, abs=1e-5)
    assert row["leaf_damage_rate"] == 0.0 and row["dropped"] == 0
    assert all(row[f"fail_{k}"] == 0 for k in plug_trays.FAILURES)
    assert row["valid"] is True and row["fault"] is None


def test_a_setting_the_schema_refuses_is_a_row_with_the_reason():
    row = run_one(task("delta_refill", SMALL, {"plugs.moisture_pct": 150.0}, 1, 1))
    assert row["error"].startswith("setting refused: ") and "plugs.moisture_pct" in row["error"]
    assert row["successes"] is None


def test_the_bench_row_pools_its_seedlings():
    row = run_one(task("plug_bench", NO_SPREAD, {"plugs.moisture_pct": 65.0}, 1, 2))
    assert row["error"] is None
    assert (row["successes"], row["seedlings"], row["cycles"]) == (2, 2, 2)
    assert row["substrate_retention"] == pytest.approx(0.930099)  # docs/plug_claws.md: 93.0 %
    assert row["cycle_time_s"] == pytest.approx(1.469671)  # 0 and 90 deg (a 0.25 s swing)
    assert row["moisture_pct_drawn"] == 65.0


def test_a_job_that_raises_is_a_row_never_an_exception():
    def refuse(scenario, seed, row):
        raise ValueError("plugs.moisture_pct must lie in (0, 100)")

    def crash(scenario, seed, row):
        raise RuntimeError("boom")

    for run, text in ((refuse, "setting refused: plugs.moisture_pct"), (crash, "RuntimeError")):
        job = jobs.Job("x", ("retention",), (), (), run)
        row = jobs.run_job(job, None, 1, {"seed": 1, "error": None}, 0.0)
        assert row["error"].startswith(text) and row["retention"] is None
        assert row["wall_time_s"] > 0
