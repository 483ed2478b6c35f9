"""Headless pick-and-drop trials: run the twin through a scenario's seedlings and judge them.

`run_trial(config)` builds a Twin, lets the judge follow it and returns a `TrialResult`;
with a recording path it also writes a rerun recording, and `observers` (`TrialObserver`:
video frames, failure clips, a live viewer) read the state after every physics step.
Presentation (progress bar, summary table, JSON files) lives in `transplanter.twin.report`, the
command line in `transplanter.cli`.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from transplanter import interrupts
from transplanter.scenario.assemble import TwinConfig
from transplanter.scene import kinds as scene_kinds
from transplanter.twin.judge import Judge
from transplanter.twin.results import Outcome, SeedlingRecord, TrialResult
from transplanter.twin.sim import SimulationInvalid, Twin
from transplanter.units import M_PER_MM
from transplanter.viewing import channels

__all__ = [
    "run_trial",
    "TrialInterrupted",
    "TrialObserver",
    "FIRMWARE_HORIZON_S",
]

# The PGF must finish within this much simulated time (s): a base plus a per-seedling budget
# about ten times a paper cycle, so only a hung firmware hits it.
FIRMWARE_HORIZON_S = (60.0, 30.0)

# Progress callback: (seedlings finished, simulated time s).
Progress = Callable[[int, float], None]


class TrialObserver(Protocol):
    """Watches a trial as it runs (frames for a video, failure clips, a live viewer).

    An observer only reads the twin's state: a trial gives the same results with or
    without observers. `attach` is called once the twin and the judge exist (an observer
    may add line listeners: they run after the judge's, so records are up to date), `step`
    after every physics step, `finish` once the judge gave its last verdicts (also after an
    interrupt or invalid physics), `abort` instead of `finish` when the trial raised."""

    def attach(self, twin: Twin, records: list[SeedlingRecord]) -> None: ...

    def step(self, twin: Twin) -> None: ...

    def finish(self, twin: Twin, interrupted: bool) -> None: ...

    def abort(self) -> None: ...


class TrialInterrupted(KeyboardInterrupt):
    """The user stopped the trial (Ctrl-C, or SIGTERM on the command line); `result` holds
    what was judged until then (the seedling in progress and later ones are not_run,
    `result.interrupted` is True). Outside the command line, a Ctrl-C that came while the
    finished trial was being closed is raised as TrialInterrupted too, its `result` whole
    (`result.interrupted` False)."""

    def __init__(self, result: TrialResult) -> None:
        super().__init__(f"interrupted after {result.judged} seedlings")
        self.result = result


def run_trial(
    config: TwinConfig,
    record_path: str | Path | None = None,
    record_rate_hz: float = 60.0,
    progress: Progress | None = None,
    twin_factory: Callable[[TwinConfig], Twin] = Twin,
    observers: Sequence[TrialObserver] = (),
    horizon_s: float | None = None,
) -> TrialResult:
    """Run the configured seedlings through the whole twin and measure what happens.

    `twin_factory` builds the Twin (a subclass may add observers or disturbances);
    `observers` watch every physics step without changing the physics (TrialObserver);
    `horizon_s` replaces the simulated time the program must finish in (FIRMWARE_HORIZON_S;
    `math.inf` for a remote host's session).

    Stop signals (interrupts.held) are held while the trial is set up (the twin built, the
    files created) until the loop runs, and from the end of the loop until the result is
    built: a Ctrl-C there never leaves a temporary file or loses a finished trial, and one
    during the set-up stops the trial as its loop starts (nothing judged, `TrialInterrupted`
    with the whole result). A recording that cannot be started (a full disk) records
    nothing: the trial runs, its result's `recording_error` says why."""
    t_wall = time.perf_counter()
    recorder, recording_error = None, None
    with interrupts.held():
        twin = twin_factory(config)
        m_pp = twin.machine.eeprom.m_pp
        records = [SeedlingRecord(index=i, pickup=i % m_pp) for i in range(config.seedlings)]
        if record_path is not None:
            from transplanter.viewing.recording import RecordingError, TrialRecorder

            try:
                recorder = TrialRecorder(
                    twin.scene.render_model,
                    record_path,
                    rate_hz=record_rate_hz,
                    scalar_names=channels.channel_names(),
                )
            except RecordingError as exc:  # nothing was left; the results still stand
                recording_error = str(exc)
        try:
            judge_cls = scene_kinds.judge_class(config.scene.workcell_kind)  # the job's judge
            event = recorder.event if recorder is not None else None
            judge = judge_cls(twin, config.judge, records, event)
            twin.line_listeners.append(judge.on_line)
            monitor: Any = judge.monitor if recorder is None else _RecordingMonitor(judge, recorder)
            every = 1  # the judge keeps its own periods in simulated time
            if recorder is not None:
                monitor.record(twin, np.zeros(3, dtype=np.int64))  # the power-on state, t = 0
        except BaseException:
            _abort((), recorder)  # an unexpected error leaves no temporary file behind
            raise
        recording_monitor = monitor
        if observers:
            _attach(observers, twin, records, recorder)
            monitor, every = _ObservingMonitor(monitor, every, observers), 1
    valid, reason, interrupted = True, None, False
    try:
        interrupts.raise_pending()  # a stop signal held while the files were set up
        horizon = FIRMWARE_HORIZON_S[0] + FIRMWARE_HORIZON_S[1] * len(records)
        if horizon_s is not None:  # a remote host decides how long it runs
            horizon = horizon_s
        while not (twin.pgf.done or twin.pgf.fault) and twin.time < horizon:
            twin.step_until(min(twin.time + 1.0, horizon), monitor=monitor, monitor_every=every)
            if progress is not None:
                finished = sum(
                    r.outcome != Outcome.PENDING or r.t_release_s is not None for r in records
                )
                progress(finished, twin.time)
        twin.step_until(
            twin.time + config.judge.settle_s,
            monitor=monitor,
            monitor_every=every,
            stop_when_done=False,
        )
        if not (twin.pgf.done or twin.pgf.fault):
            valid, reason = False, f"the PGF did not finish within {horizon:.0f} s simulated"
    except SimulationInvalid as exc:
        valid, reason = False, str(exc)
    except KeyboardInterrupt:
        interrupted = True
    except BaseException:
        _abort(observers, recorder)  # an unexpected error leaves no temporary file behind
        raise
    with interrupts.held():
        result = _finish_trial(
            config, twin, judge, records, observers, recorder, recording_monitor, t_wall,
            valid, reason, interrupted, recording_error,
        )  # fmt: skip
    if interrupted:
        raise TrialInterrupted(result)
    if not interrupts.commanded() and interrupts.take_pending() is not None:
        raise TrialInterrupted(result)  # no command line acts on it: the caller hears of it
    return result


def _finish_trial(
    config: TwinConfig,
    twin: Twin,
    judge: Judge,
    records: list[SeedlingRecord],
    observers: Sequence[TrialObserver],
    recorder: Any,
    recording_monitor: Any,
    t_wall: float,
    valid: bool,
    reason: str | None,
    interrupted: bool,
    recording_error: str | None = None,
) -> TrialResult:
    """The last verdicts, the observers finished, the recording closed and the result
    (`recording_error`: why a recording that could not be started was not made)."""
    judge.finish(twin.time, valid and not interrupted)
    try:
        for observer in observers:
            observer.finish(twin, interrupted)
    except BaseException:
        _abort(observers, recorder)
        raise
    if recorder is not None:
        recording_error = _finish_recording(recorder, recording_monitor, twin, interrupted)
    return TrialResult(
        scenario=config.name,
        seed=config.seed,
        per_seedling=records,
        sim_time_s=twin.time,
        wall_time_s=time.perf_counter() - t_wall,
        valid=valid,
        invalid_reason=reason,
        fault=twin.pgf.fault or getattr(twin.pgf, "machine_fault", None),  # a remote host's
        fault_kind=twin.pgf.fault_kind,
        interrupted=interrupted,
        recording_error=recording_error,
        lost_step_events=[dataclasses.asdict(e) for e in twin.lost_step_events],
        belt_realignments=[
            {"t_s": t, "offset_mm": offset / M_PER_MM} for t, offset in twin.belt_realignments
        ],
        overrides=dict(config.overrides),
        warnings=twin.sgf.speed_warnings(),
        motors=twin.motors.report().to_dict(),
    )


def _attach(
    observers: Sequence[TrialObserver], twin: Twin, records: list[SeedlingRecord], recorder: Any
) -> None:
    """Attach every observer; if one cannot start (no GL context), none leaves a file."""
    attached: list[TrialObserver] = []
    try:
        for observer in observers:
            attached.append(observer)
            observer.attach(twin, records)
    except BaseException:
        _abort(attached, recorder)
        raise


def _abort(observers: Sequence[TrialObserver], recorder: Any) -> None:
    """Every observer and the recorder drop what they started (no file left behind)."""
    for observer in observers:
        observer.abort()
    if recorder is not None:
        recorder.abort()


class _ObservingMonitor:
    """Runs the trial's own monitor on its schedule and every observer after every step."""

    def __init__(self, inner: Any, inner_every: int, observers: Sequence[TrialObserver]) -> None:
        self.inner, self.inner_every = inner, inner_every
        self.steps = [o.step for o in observers]

    def __call__(self, twin: Twin, i: int) -> None:
        if twin.k % self.inner_every == 0:
            self.inner(twin, i)
        for step in self.steps:
            step(twin)


def _finish_recording(recorder: Any, monitor: Any, twin: Twin, interrupted: bool) -> str | None:
    """Close the recording (an interrupted one goes to its own `.partial.rrd` name, never
    over a complete file); the reason if it could not be written."""
    from transplanter.viewing.recording import RecordingError

    try:
        if twin.block is not None:
            monitor.record(twin, twin.block.pulses[-1], force=True)
        if interrupted:  # a name derived from the user's: a link there is replaced, not followed
            path = Path(recorder.path)
            recorder.close(path.with_name(path.stem + ".partial.rrd"), follow=False)
        else:
            recorder.close()
    except RecordingError as exc:
        return str(exc)
    except Exception as exc:  # a frame that could not be buffered: the file is incomplete
        recorder.abort()
        return f"the recording {str(recorder.path)!r} could not be written: {exc}"
    return None


class _RecordingMonitor:
    """Feeds the recorder its frames (poses and scalar channels) while the judge monitors."""

    def __init__(self, judge: Judge, recorder: Any) -> None:
        self.judge, self.recorder = judge, recorder
        self.pulses = np.zeros(3, dtype=np.int64)
        self.t_pulses = 0.0

    def __call__(self, twin: Twin, i: int) -> None:
        # called every physics step so that frames fall on the recording rate's grid
        self.judge.monitor(twin, i)
        if self.recorder.due(twin.time):
            self.record(twin, twin.block.pulses[i])

    def record(self, twin: Twin, pulses: np.ndarray, force: bool = False) -> None:
        t = twin.time
        dt = t - self.t_pulses
        rates = np.abs(pulses - self.pulses) / dt if dt > 0 else np.zeros(3)
        self.pulses, self.t_pulses = pulses.copy(), t
        # the recording draws the render model: a windowed scene's has a body per pot, placed
        # where the window says (Scene.render_data); otherwise it has the physics' bodies
        scene = twin.scene
        data = twin.data if scene.window is None else scene.render_data(twin.data)
        self.recorder.frame(t, data, channels.sample(twin, rates), force=force)
