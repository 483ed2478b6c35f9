"""Running a sweep's tasks: one trial per task as `transplanter trial` judges it (`run_one`),
on a backend that yields the rows as they finish, in any order: `inline` (this process),
`process` (a spawn process pool) or `ray` (a Ray cluster)."""

from __future__ import annotations

import contextlib
import os
import signal
import time
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

from transplanter.scenario.schema import ScenarioError, load_scenario, with_units
from transplanter.studies.grid import SweepRefused
from transplanter.studies.jobs import WARNING_SEPARATOR, trial_row  # noqa: F401 (re-exported)
from transplanter.twin.results import FAILURE_KINDS

BACKENDS = ("process", "ray", "inline")

# Columns of a run's row after the varied keys.
RESULT_FIELDS = (
    "seed",
    "successes",
    "seedlings",
    "success_rate",
    "cycle_time_s",
    "cycle_time_sd_s",
    "cycles",
    "plants_per_hour",
    *(f"fail_{k}" for k in FAILURE_KINDS),
    "lost_step_events",
    "max_stem_bend_deg",
    "motor_energy_j",
    "peak_motor_torque_nm",
    "valid",
    "fault",
    "fault_kind",
    "sim_time_s",
    "wall_time_s",
    "warnings",
    "error",
)


class BackendMissing(SweepRefused):
    """The backend's package is not installed."""


def _empty_result() -> dict[str, Any]:
    return {f: None for f in RESULT_FIELDS if f != "seed"}


def run_one(task: Mapping[str, Any]) -> dict[str, Any]:
    """One trial as `transplanter trial` runs it, as a row: the varied values, the seed, the
    counts and times; a setting the scenario refuses or a trial that raised is a row with
    its `error` (never an exception)."""
    from transplanter.scenario.assemble import assemble
    from transplanter.studies.jobs import job_of, run_job
    from transplanter.twin.trial import run_trial

    row: dict[str, Any] = {**task["setting"], "seed": task["seed"], **_empty_result()}
    t0 = time.perf_counter()
    try:
        overrides = with_units(
            task["scenario"],
            {**task["overrides"], **task["setting"], "scenario.seed": task["seed"]},
            task["seedlings"],
        )
        scenario = load_scenario(task["scenario"], overrides)
        job = job_of(scenario)  # the delta's tray or the claws' bench (studies.jobs), or None
        config = None if job is not None else assemble(scenario, preflight=True)
    except ScenarioError as exc:
        row["error"] = f"setting refused: {exc}"
        row["wall_time_s"] = time.perf_counter() - t0
        return row
    if job is not None:
        return run_job(job, scenario, task["seed"], row, t0)
    try:
        result = run_trial(config)
    except Exception as exc:  # the physics or the firmware raised: a row, not a crash
        row["error"] = f"{type(exc).__name__}: {exc}"
        row["wall_time_s"] = time.perf_counter() - t0
        return row
    return trial_row(result, row)


class InlineBackend:
    """Runs the tasks one after another in this process (notebooks, tests)."""

    workers = 1

    def run(self, tasks: Iterable[Mapping[str, Any]]) -> Iterator[dict[str, Any]]:
        for task in tasks:
            yield run_one(task)

    def close(self) -> None:
        pass


def _ignore_stop_signals() -> None:
    # Ctrl-C goes to the whole process group, and so may SIGTERM (`timeout`, a scheduler):
    # the parent decides, and stops the workers itself (terminate: SIGKILL).
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


PR_SET_PDEATHSIG = 1  # prctl(2): the signal this process gets when its parent ends


def _die_with_parent(parent: int) -> None:
    """End this worker when `parent` (the process that made the pool) ends, however it ends:
    `kill -9` or the OOM killer give the parent no chance to stop its workers, which ignore
    SIGINT and SIGTERM and would wait on its queue forever (with them the resource tracker,
    whose pipe they hold). On Linux the kernel sends SIGKILL (prctl PR_SET_PDEATHSIG: on the
    end of the thread that started the worker, the one running the pool's tasks); elsewhere a
    daemon thread watches for the parent's end."""
    import sys

    if sys.platform.startswith("linux"):
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0:
            if os.getppid() != parent:  # it ended before the request was made
                os._exit(1)
            return
    import threading

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def _start_worker(parent: int | None = None) -> None:
    """A process-pool worker's start: it ends with its parent (`parent`'s pid), stop signals
    are ignored, and the trial's imports (about a second: MuJoCo, SciPy, the twin) done now,
    while the pool starts, not in its first task."""
    if parent is not None:
        _die_with_parent(parent)
    _ignore_stop_signals()
    import transplanter.scenario.assemble  # noqa: F401
    import transplanter.twin.trial  # noqa: F401


MAX_WORKERS_PER_CPU = 4
"""The process pool takes at most this many workers per CPU the process may run on (more only
wait for a core and hold memory: `--workers 10000` spawned 10,000 processes)."""
IN_FLIGHT_PER_WORKER = 2
"""Tasks submitted ahead per worker of the process pool (one running, one waiting)."""


class ProcessBackend:
    """A `ProcessPoolExecutor` of spawned processes (MuJoCo and fork do not mix), which end
    with this process however it ends (`_die_with_parent`)."""

    def __init__(self, workers: int) -> None:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        self.workers = workers
        self.pool = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_start_worker,
            initargs=(os.getpid(),),  # the workers end with this process (_die_with_parent)
        )

    def run(self, tasks: Iterable[Mapping[str, Any]]) -> Iterator[dict[str, Any]]:
        from concurrent.futures import FIRST_COMPLETED, wait

        # Streamed: at most IN_FLIGHT_PER_WORKER tasks per worker are submitted at a time, so a
        # long sweep starts at once and holds a bounded number of futures.
        queue = iter(tasks)
        pending: set = set()

        def top_up() -> None:
            while len(pending) < IN_FLIGHT_PER_WORKER * self.workers:
                task = next(queue, None)
                if task is None:
                    return
                pending.add(self.pool.submit(run_one, dict(task)))

        try:
            top_up()
            while pending:
                done, pending_left = wait(pending, return_when=FIRST_COMPLETED)
                pending.clear()
                pending.update(pending_left)
                for future in done:
                    yield future.result()
                top_up()
        finally:
            for future in pending:
                future.cancel()

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)

    def terminate(self) -> None:
        """Stop at once (Ctrl-C, SIGTERM): running trials are lost, finished rows are kept.
        The workers ignore both signals, so they are killed (none is left orphaned)."""
        processes = list(getattr(self.pool, "_processes", {}).values())
        self.pool.shutdown(wait=False, cancel_futures=True)
        for p in processes:
            p.kill()
        for p in processes:
            p.join(5)


class RayBackend:
    """Tasks on a Ray cluster (`address`) or a local one of `workers` CPUs."""

    def __init__(self, workers: int, address: str | None = None) -> None:
        try:
            import ray
        except ImportError:
            raise BackendMissing(
                "the ray backend needs Ray: pip install 'transplanter[ray]' (or use "
                "--backend process)"
            ) from None
        self.ray = ray
        self.workers = workers
        self.owns = not ray.is_initialized()
        if self.owns:
            if address is not None:
                ray.init(address=address, log_to_driver=False)
            else:
                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        self.remote = ray.remote(num_cpus=1, max_retries=0)(run_one)

    def run(self, tasks: Iterable[Mapping[str, Any]]) -> Iterator[dict[str, Any]]:
        ray = self.ray
        pending = [self.remote.remote(dict(t)) for t in tasks]
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    yield ray.get(ref)
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)

    def close(self) -> None:
        if self.owns:
            self.ray.shutdown()

    def terminate(self) -> None:
        self.close()


def check_backend(name: str, workers: int, address: str | None = None) -> None:
    """SweepRefused naming the problem if `make_backend` would refuse these options."""
    if name not in BACKENDS:
        raise SweepRefused(f"--backend {name!r}: choose one of {', '.join(BACKENDS)}")
    if workers < 1:
        raise SweepRefused(f"--workers must be at least 1, got {workers}")
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    most = MAX_WORKERS_PER_CPU * (cpus or 1)
    if name == "process" and workers > most:
        raise SweepRefused(
            f"--workers {workers} is far more than this machine's {cpus} CPUs: each worker is "
            f"a process of about 90 MB running trials on a core; use --workers auto ({cpus}), "
            f"at most {most}, or a Ray cluster (--backend ray --address ...) for more"
        )
    if address is not None and name != "ray":
        raise SweepRefused("--address names a Ray cluster: use it with --backend ray")


def make_backend(name: str, workers: int, address: str | None = None):
    """A backend by name: 'process' (default), 'ray' or 'inline'."""
    check_backend(name, workers, address)
    if name == "inline":
        return InlineBackend()
    if name == "ray":
        return RayBackend(workers, address)
    return ProcessBackend(workers)


def comparable(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Rows without their wall time: what must be identical whatever the backend."""
    return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in rows]


@contextlib.contextmanager
def backend_of(name: str, workers: int, address: str | None = None):
    """A backend, closed on the way out (terminated on Ctrl-C)."""
    runner = make_backend(name, workers, address)
    try:
        yield runner
    except KeyboardInterrupt:
        getattr(runner, "terminate", runner.close)()
        raise
    else:
        runner.close()
