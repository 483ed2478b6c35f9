"""transplanter.studies.backends: one run as a row (never an exception) and the backends by name."""

import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

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


# A process that starts a pool of two workers, prints their pids once both have started (the
# readiness signal) and waits; the test kills it with SIGKILL, as the OOM killer does.
_POOL_PARENT = """
import os, sys
from transplanter.studies.backends import ProcessBackend
runner = ProcessBackend(2)
futures = [runner.pool.submit(os.getpid) for _ in range(2)]
for f in futures:
    f.result()
print(*runner.pool._processes, flush=True)
sys.stdin.read()
"""


def _children(parent, word):
    """The pids of `parent`'s children whose command line holds `word`."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            ppid = int(stat.read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (stat.parent / "cmdline").read_bytes()
        except (OSError, ValueError, IndexError):
            continue
        if ppid == parent and word in cmdline:
            found.append(int(stat.parent.name))
    return found


@pytest.mark.skipif(not hasattr(os, "pidfd_open"), reason="waits on pidfds (Linux)")
def test_the_pool_workers_and_the_resource_tracker_die_with_a_killed_parent():
    """`kill -9` of a sweep, compare, tune or calibrate (the OOM killer) left its workers
    (about 150 MB each, ignoring SIGINT and SIGTERM) and the resource tracker idle forever."""
    import transplanter

    env = {**os.environ, "PYTHONPATH": str(Path(transplanter.__file__).parents[1])}
    parent = subprocess.Popen(
        [sys.executable, "-c", _POOL_PARENT], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL, env=env, text=True,
    )  # fmt: skip
    fds = {}
    try:
        workers = [int(pid) for pid in parent.stdout.readline().split()]  # both started
        assert len(workers) == 2, "the pool's two workers"
        tracker = _children(parent.pid, b"resource_tracker")
        assert len(tracker) == 1, "the resource tracker"
        assert sorted(_children(parent.pid, b"spawn_main")) == sorted(workers)
        fds = {pid: os.pidfd_open(pid) for pid in [*workers, *tracker]}  # never a reused pid
        parent.kill()
        parent.wait(30)
        deadline = time.monotonic() + 30
        for fd in fds.values():  # a pidfd is readable once its process has ended
            select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
        still = [pid for pid, fd in fds.items() if not _ended(fd)]
        assert not still, f"left running after their parent was killed: {still}"
    finally:
        parent.kill()
        parent.wait(30)
        for fd in fds.values():
            if not _ended(fd):  # today's code leaves them running: end them
                signal.pidfd_send_signal(fd, signal.SIGKILL)
            os.close(fd)


def _ended(pidfd):
    return bool(select.select([pidfd], [], [], 0)[0])
