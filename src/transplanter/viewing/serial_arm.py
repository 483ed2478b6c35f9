"""Recording the serial arm's pick-and-place job to rerun (`trial serial_arm --record F.rrd`):
the bodies' poses, and the chain's channels over time: each servo's pulse width, its shaft
(the potentiometer) and the joint's angle; both ultrasonic sensors' readings; the fuzzy
controller's output and the gripper command; the pads' squeeze on the tomato in the
gripper. Events: every decision of the controller and every tomato's outcome.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from transplanter.machine.fuzzy_gripper import NO_ECHO

__all__ = ["SERVOS", "SerialRecording", "scalar_names"]

SERVOS = ("base", "shoulder", "elbow", "gripper")


def scalar_names() -> list[str]:
    names = []
    for s in SERVOS:
        names += [f"servos/{s}/pulse_us", f"servos/{s}/shaft_deg", f"servos/{s}/joint_deg"]
    names += ["sensors/station_cm", "sensors/gripper_cm"]
    names += ["controller/fuzzy_deg", "controller/gripper_cmd_deg", "gripper/squeeze_n"]
    return names


class SerialRecording:
    """An observer of the serial arm's rig: `attach(rig)`, `look(t)` every step (it samples
    on its own grid), `event(t, kind, text)`, `finish(t)`; errors are kept, not raised (the
    trial goes on, the command reports them)."""

    def __init__(self, path: str | os.PathLike, rate_hz: float = 60.0) -> None:
        self.path, self.rate_hz = Path(path), float(rate_hz)
        self.recorder: Any = None
        self.error: str | None = None
        self.next_t = 0.0
        self.fuzzy_deg = math.nan
        self.squeeze_n = 0.0

    def attach(self, rig) -> None:
        from transplanter.viewing.recording import TrialRecorder

        self.rig = rig
        try:
            self.recorder = TrialRecorder(
                rig.model, self.path, rate_hz=self.rate_hz, scalar_names=scalar_names()
            )
        except Exception as exc:  # the trial goes on without it (exit status 5 at the end)
            self.error = f"the recording {str(self.path)!r} could not be started: {exc}"
            self.next_t = math.inf

    def _scalars(self) -> np.ndarray:
        rig = self.rig
        pulses = rig.last_pulses
        shafts = rig.bank.shafts()
        joints = [*rig.joints_rad(), math.radians(rig.gripper_deg())]
        values: list[float] = []
        for i in range(4):
            values += [float(pulses[i]), math.degrees(shafts[i]), math.degrees(joints[i])]
        for name in ("station", "gripper"):
            r = rig.rangers.get(name)
            values.append(math.nan if r is None or r.last_cm == NO_ECHO else float(r.last_cm))
        values += [self.fuzzy_deg, math.degrees(rig.outputs.gripper_rad), self.squeeze_n]
        return np.array(values, dtype=np.float64)

    def look(self, t: float, force: bool = False) -> None:
        if self.error is not None or (t < self.next_t - 1e-9 and not force):
            return
        try:
            self.recorder.frame(t, self.rig.data, self._scalars(), force=force)
        except Exception as exc:  # the trial goes on; the recording is lost
            self.error = f"the recording {str(self.path)!r} could not be written: {exc}"
            self.recorder.abort()
            self.next_t = math.inf
            return
        self.next_t = (math.floor(t * self.rate_hz + 1e-6) + 1) / self.rate_hz

    def event(self, t: float, kind: str, text: str) -> None:
        if self.error is None:
            self.recorder.event(t, kind, text)

    def finish(self, t: float) -> str | None:
        """The last state, the file; the error if it could not be written."""
        from transplanter.viewing.recording import RecordingError

        if self.error is None:
            self.look(t, force=True)
        if self.error is None:
            try:
                self.recorder.close()
            except RecordingError as exc:
                self.error = str(exc)
        return self.error
