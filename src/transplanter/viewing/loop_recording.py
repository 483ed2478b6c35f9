"""A rerun recording of a job run one physics step at a time (`transplanter.twin.loop.StepLoop`:
the delta's and the serial arm's pot jobs, `trial delta_pots|serial_arm_pots --record F.rrd`).

It records what any such job has: the moving bodies' poses on the recording rate's grid (the
model's geoms logged once), every actuator's force as a scalar channel (`actuators/<name>`,
the robot's drives and the effector's servos), and the job's events (each unit's verdict).
It only reads the state: the trial is the same with it or without it. A recording that
cannot be started or written leaves the trial running and says why in `error` (the command
exits 5), with no temporary file left behind.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

__all__ = ["LoopRecording"]


class LoopRecording:
    """Records a StepLoop's job to an .rrd (module docstring)."""

    def __init__(self, path: str | os.PathLike, rate_hz: float = 60.0) -> None:
        self.path, self.rate_hz = Path(path), float(rate_hz)
        self.recorder: Any = None
        self.loop: Any = None
        self.error: str | None = None

    def attach(self, loop: Any) -> None:
        """Start the recording at the loop's power-on state and watch every step after."""
        from transplanter.viewing.recording import TrialRecorder

        model = loop.model
        names = [f"actuators/{model.actuator(a).name or f'actuator{a}'}" for a in range(model.nu)]
        try:
            self.recorder = TrialRecorder(model, self.path, rate_hz=self.rate_hz,
                                          scalar_names=names)  # fmt: skip
        except Exception as exc:  # the trial goes on without it (exit status 5 at the end)
            self.error = f"the recording {str(self.path)!r} could not be started: {exc}"
            return
        self.loop = loop
        self.recorder.frame(0.0, loop.data, loop.data.actuator_force.copy())
        loop.after_step.append(self._look)

    def _look(self, _t: float) -> None:
        t = self.loop.time
        if self.recorder.due(t):
            self.recorder.frame(t, self.loop.data, self.loop.data.actuator_force.copy())

    def event(self, t: float, kind: str, text: str, unit: int | None = None) -> None:
        """A verdict or a fault at simulated time `t`."""
        if self.recorder is not None and self.error is None and math.isfinite(t):
            self.recorder.event(t, kind, text, unit)

    def finish(self, t: float) -> None:
        """The last state, then the file written (or the reason it was not)."""
        if self.recorder is None or self.error is not None:
            return
        from transplanter.viewing.recording import RecordingError

        try:
            self.recorder.frame(t, self.loop.data, self.loop.data.actuator_force.copy(),
                                force=True)  # fmt: skip
            self.recorder.close()
        except RecordingError as exc:
            self.error = str(exc)
        except Exception as exc:
            self.recorder.abort()
            self.error = f"the recording {str(self.path)!r} could not be written: {exc}"

    def abort(self) -> None:
        """Drop what was started (no file left behind)."""
        if self.recorder is not None:
            self.recorder.abort()
