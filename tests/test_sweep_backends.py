"""transplanter.studies.backends: one run as a row (never an exception) and the backends by name."""

import os
import sys

import pytest

import transplanter.twin.trial
from transplanter.studies.backends import (
    WARNING_SEPARATOR,
    BackendMissing,
    InlineBackend,
    make_backend,
    run_one,
)
from transplanter.studies.grid import SweepRefused
from transplanter.twin.results import TrialResult


def _task(z_low_mm=34.0, seed=3):
    return {"scenario": "paper", "overrides": {}, "setting": {"taught.z_low_mm": z_low_mm},
            "seed": seed, "seedlings": 2}  # fmt: skip


def test_a_refused_setting_is_a_row_with_the_reason():
    row = run_one(_task(z_low_mm=61.0))  # above the paper's Z_up = 60 mm
    assert row["error"].startswith("setting refused: ")
    assert "z_low_mm" in row["error"]
    assert (row["taught.z_low_mm"], row["seed"], row["successes"]) == (61.0, 3, None)
    assert row["wall_time_s"] >= 0


def test_a_run_that_raises_is_a_row_with_its_error(monkeypatch):
    def boom(config):
        raise RuntimeError(f"solver exploded at seed {config.seed}")

    monkeypatch.setattr(transplanter.twin.trial, "run_trial", boom)
    row = run_one(_task())
    assert row["error"] == "RuntimeError: solver exploded at seed 3"
    assert row["successes"] is None and row["seed"] == 3


def test_a_trial_that_ran_out_of_time_is_not_called_invalid_physics(monkeypatch):
    reason = "the PGF did not finish within 120 s simulated"

    def timed_out(config):
        return TrialResult(
            scenario=config.name, seed=config.seed, per_seedling=[], sim_time_s=120.5,
            wall_time_s=1.0, valid=False, invalid_reason=reason,
        )  # fmt: skip

    monkeypatch.setattr(transplanter.twin.trial, "run_trial", timed_out)
    row = run_one(_task())
    assert row["error"] == f"trial not valid: {reason}"
    assert row["valid"] is False and row["sim_time_s"] == 120.5


def test_backends_by_name_and_their_refusals():
    assert isinstance(make_backend("inline", 1), InlineBackend)
    with pytest.raises(SweepRefused, match="choose one of process, ray, inline"):
        make_backend("dask", 2)
    with pytest.raises(SweepRefused, match="at least 1, got 0"):
        make_backend("process", 0)
    with pytest.raises(SweepRefused, match="use it with --backend ray"):
        make_backend("process", 2, address="head:6379")


def test_ray_missing_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(BackendMissing, match=r"pip install 'transplanter\[ray\]'"):
        make_backend("ray", 1)


def test_a_row_names_the_fault_by_kind_and_carries_the_warnings():
    """The row of a trial whose firmware stopped says why by kind (as the trial's JSON), and
    every row carries the trial summary's warnings in one cell."""
    dead = run_one({**_task(), "overrides": {"faults.switch_dead": 3}})
    assert dead["fault_kind"] == "switch_not_found"
    assert dead["error"].startswith("firmware fault: ") and "error:69" in dead["error"]
    assert dead["successes"] == 0
    paper = run_one(_task())
    assert paper["fault_kind"] is None and paper["error"] is None
    # the paper's Z moves ask for more than motor 3's top step rate (two warnings)
    warnings = paper["warnings"].split(WARNING_SEPARATOR)
    assert len(warnings) == 2
    assert all("motor 3 reaches its top step rate" in w for w in warnings)


def test_a_process_pool_far_larger_than_the_machine_is_refused():
    """--workers 10000 spawned a process (about 90 MB) per run."""
    from transplanter.studies.backends import MAX_WORKERS_PER_CPU, check_backend

    cpus = len(os.sched_getaffinity(0))
    check_backend("process", MAX_WORKERS_PER_CPU * cpus)
    with pytest.raises(SweepRefused, match=r"--workers 10000 is far more than this machine"):
        check_backend("process", 10000)
    check_backend("ray", 10000)  # a cluster's size is its own


def test_the_process_pool_submits_a_bounded_number_of_tasks_at_a_time(monkeypatch):
    """A long sweep used to submit every run before the first one started."""
    from transplanter.studies import backends

    submitted_before_first_row = []
    tasks_read = []

    def tasks():
        for i in range(50):
            tasks_read.append(i)
            yield {"i": i}

    monkeypatch.setattr(backends, "run_one", _echo)
    runner = backends.ProcessBackend(1)
    try:
        rows = runner.run(tasks())
        first = next(rows)
        submitted_before_first_row.append(len(tasks_read))
        rest = list(rows)
    finally:
        runner.close()
    assert submitted_before_first_row[0] <= backends.IN_FLIGHT_PER_WORKER + 1
    assert sorted(r["i"] for r in [first, *rest]) == list(range(50))


def _echo(task):
    return dict(task)
