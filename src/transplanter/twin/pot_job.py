"""The pot line worked by a robot whose host is a generated program (`machine.host`) and whose
loop is `twin.loop.StepLoop`: the line's handles, the pot line's judge and the result.

The judge is the five-bar's (`twin.judge.Judge`: the seedlings' shoots, every failure kind,
damage), blind to the robot: it reads the machine through a `PotJobRig` and hears the pick
cycle as phases, which the job's host program reports where its own lines start and finish
them (`PotJob.sent`, `PotJob.done`: items the program yields, `machine.host.Call`):

- `APPROACH` sent: the cycle of a pot starts (the judge looks at its cell: a pot there,
  standing?); done: the gripper is down round it (the previous pot has had a whole move to
  land: it is judged);
- `CLOSE` done: the gripper's close is sent (from here the grip force is measured);
- `LIFT` done: the lift has ended (did the pot come up?);
- `TO_DROP` done: the gripper is over the tube (is the pot still in it?);
- `RELEASE` done: the open is sent; `RELEASE_WAIT` done: the pick has ended (its cycle time);
- `INDEX` done: the conveyor has indexed (the cells the judge looks at move one row).

The phases add no line to the program: a move's `ok` comes once its last step is out (the
SGF's FIFO), so the item after a move line reports its end, and the machine runs as it would
unjudged (an `M400` added to report a phase shifted the serial arm's timeline by a round trip
a pot, enough to change which of its marginal second grasps held).

A pot the host gives up on (its grasps all missed) or skips (its sensor read no pot) is judged
at once (`PotJob.give_up`, `PotJob.skipped`). The robot's own record of each pick (the
controller's inputs, the grip angle, the grasps tried) stays the job's (`PotJobResult.pots`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from transplanter.machine.host import Call
from transplanter.machine.pgf import LinePhase
from transplanter.scene.conveyor import INDEX_ERROR_STREAM, ConveyorDrive
from transplanter.scene.handles import GripperParts, PotLine
from transplanter.twin.judge import Judge
from transplanter.twin.results import DEFINITIONS as RESULT_DEFINITIONS
from transplanter.twin.results import EventKind, Outcome, SeedlingRecord, TrialResult

__all__ = [
    "DEFINITIONS",
    "INVALID",
    "PotJob",
    "PotJobResult",
    "PotJobRig",
    "close_observers",
    "event_sink",
    "pot_line",
    "reporter",
]

DEFINITIONS = RESULT_DEFINITIONS
"""What the pot job's numbers mean: the pot line's, whatever robot (`twin.results`)."""

INVALID = "MuJoCo warned or the job ran out of simulated time"
"""The invalid reason of a pot job's trial."""


def pot_line(model: mujoco.MjModel, line, pots, gripper: GripperParts) -> PotLine:
    """The pot line's handles on a compiled scene whose workcell is `conveyor_tube` (`line`:
    its scene config, `pots`: the PotBatch its populate drew), with the effector's parts."""
    from transplanter.scene.workcells.conveyor_tube import leaf_proxies

    return PotLine(model, line, pots, leaf_proxies(line, pots), gripper)


class PotJobRig:
    """The machine as the pot line's judge reads it (`twin.judge.PotRig`) for a robot on a
    `StepLoop`: its drives are servos that follow their command or raise an alarm (the
    delta's pulse-train servos, the hobby servos), so none loses position unnoticed: no lost
    steps, no stepper lag."""

    def __init__(self, loop, scene: PotLine, pickups_xy: Sequence[Any], lift_m: float):
        self.loop = loop
        self.model, self.data, self.scene = loop.model, loop.data, scene
        self.conveyor = ConveyorDrive(scene)
        self.pickups_xy = [tuple(float(v) for v in p[:2]) for p in pickups_xy]
        self.lift_m = float(lift_m)
        self.microsteps_lost = np.zeros(1, dtype=np.int64)
        self.lost_step_events: list = []
        self.stem_bend_deg = 0.0

    @property
    def k(self) -> int:
        return self.loop.k

    def max_motor_lag_full_steps(self) -> float:
        return 0.0


class PotJob:
    """The judge of a pot job on a `StepLoop` and the host program's items that report the
    cycle to it (module docstring). `pickups_xy`: each pickup column's grip point on the belt;
    `n`: the pots the job picks (the first n cells, row by row); `on_event(t, kind, text,
    seedling)`: the judge's event log (observers)."""

    def __init__(self, loop, scene: PotLine, config, pickups_xy, lift_m: float, n: int,
                 on_event=None, seed: int = 0):  # fmt: skip
        self.rig = PotJobRig(loop, scene, pickups_xy, lift_m)
        self._index_error_sd = scene.config.conveyor_index_error_sd_m
        self._index_rng = np.random.default_rng((seed, INDEX_ERROR_STREAM))
        cols = len(self.rig.pickups_xy)
        self.records = [SeedlingRecord(index=i, pickup=i % cols) for i in range(n)]
        self.judge = Judge(self.rig, config, self.records, on_event)
        self.conveyor = self.rig.conveyor
        loop.after_step.append(self._monitor)

    def index(self, t_event: float, total_s: float) -> None:
        """The controller started an index (M710) at `t_event`, lasting `total_s`: the rows
        that fit enter the physics (the window of live rows, `scene.live_rows`) and the drive
        moves the carriage one row pitch, off by the drawn index error
        (`conveyor.index_error_sd_mm`), as under the five-bar."""
        data = self.rig.data
        if self.rig.scene.window is not None:
            self.rig.scene.window.on_index(data)
        error = self._index_error_sd * self._index_rng.standard_normal()
        self.conveyor.start(data, t_event, total_s, error_m=error)

    def _monitor(self, _t: float) -> None:
        self.judge.monitor(self.rig, self.rig.loop.k)

    def sent(self, phase: LinePhase, seedling: int | None) -> Call:
        """The host item that tells the judge `phase` of `seedling`'s cycle starts now."""
        return Call(lambda t: self.judge.sent(phase, seedling, t))

    def done(self, phase: LinePhase, seedling: int | None) -> Call:
        """The host item that tells the judge the machine has finished `phase`."""
        return Call(lambda t: self.judge.done(phase, seedling, t))

    def give_up(self, seedling: int, why: str) -> Call:
        return Call(lambda t: self.judge.give_up(seedling, t, why))

    def skipped(self, seedling: int) -> Call:
        return Call(lambda t: self.judge.skipped(seedling, t))

    def finish(self, t: float, valid: bool) -> None:
        """Judge the last pots (on invalid physics, nothing more: not_run)."""
        self.judge.finish(t, valid)

    @property
    def done_count(self) -> int:
        """Pots judged or handed to the tube (their pick has ended): for progress."""
        return sum(r.outcome != Outcome.PENDING or r.t_release_s is not None for r in self.records)


@dataclass
class PotJobResult(TrialResult):
    """The pot line's result (`TrialResult`: the five-bar's layout, per-seedling records with
    its failure kinds and shoot damage) with the job's own: `trial` (its name), `pots` (the
    robot's record of each pick: `as_dict()` rows), `extra` (keys the job adds to the JSON),
    `definitions` (what its numbers mean)."""

    trial: str = ""
    pots: list = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)
    definitions: dict[str, str] = field(default_factory=lambda: dict(RESULT_DEFINITIONS))

    @property
    def wall_s(self) -> float:
        return self.wall_time_s

    @property
    def picked(self) -> list[SeedlingRecord]:
        """The seedlings whose pick the host started (not skipped for an empty cell)."""
        return [r for r in self.per_seedling if r.outcome not in (Outcome.NO_POT, Outcome.NOT_RUN)]

    @property
    def cycle_time_s(self) -> float:
        """Mean time from a pot's approach to the end of its release (nan: none released)."""
        cycles = self.cycle_times
        return float(cycles.mean()) if cycles.size else math.nan

    @property
    def outcomes(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for r in self.per_seedling:
            out[str(r.outcome)] = out.get(str(r.outcome), 0) + 1
        return dict(sorted(out.items()))

    @property
    def peak_squeeze_n(self) -> float:
        """The largest clamping force of one pad on a pot (N), over every pick."""
        return max((r.peak_grip_force_n for r in self.per_seedling), default=0.0)

    def to_dict(self) -> dict[str, Any]:
        return super().to_dict() | {
            "trial": self.trial,
            "outcomes": self.outcomes,
            "peak_squeeze_n": round(self.peak_squeeze_n, 4),
            "pots": [p.as_dict() for p in self.pots],
            **self.extra,
            "definitions": self.definitions,
        }


def event_sink(observers):
    """The judge's event log to every observer (`event(t, kind, text, seedling)`); None
    without observers."""
    if not observers:
        return None

    def sink(t: float, kind: EventKind, text: str, seedling: int | None) -> None:
        for observer in observers:
            observer.event(t, str(kind), text, seedling)

    return sink


def close_observers(observers, t: float) -> str | None:
    """The observers closed at `t`; the first one's error (None: written)."""
    for observer in observers:
        observer.finish(t)
    return next((o.error for o in observers if getattr(o, "error", None)), None)


def reporter(progress, pot_job: PotJob, dt: float):
    """A per-step hook calling `progress(done, sim_t)` once a simulated second with the pots
    whose pick has ended (judged, released or skipped)."""
    every = max(1, round(1.0 / dt))
    k = [0]

    def fn(t: float) -> None:
        k[0] += 1
        if k[0] % every == 0:
            progress(pot_job.done_count, t)

    return fn
