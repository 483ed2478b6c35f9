"""Recording and filming the serial arm's pick-and-place job.

- `SerialRecording` records it to rerun (`trial serial_arm --record F.rrd`): the bodies'
  poses, and the chain's channels over time: each servo's pulse width, its shaft (the
  potentiometer) and the joint's angle; both ultrasonic sensors' readings; the fuzzy
  controller's output and the gripper command; the pads' squeeze on the tomato in the
  gripper. Events: every decision of the controller and every tomato's outcome.
- `SerialVideo` films it to an MP4 (`render serial_arm --out F.mp4`) from a named camera of
  the serial scene (`overview`, `gripper_closeup`: scene.serial_scene.CAMERAS) through the
  five-bar's `FrameGrabber` and `Mp4Writer`, a frame every 1 / fps s of simulated time, each
  captioned with the time, the tomato in progress, the controller's last decision (sensor 1
  and 2, the base angle -> the gripper angle and its term), the gripper servo's shaft angle
  and the pads' squeeze.

Both are observers of `twin.serial_arm.run_pick_place` (`attach(rig)`, `look(t)` after every
physics step, `event`, `finish`); they only read the state, so the trial's numbers are the
same with or without them.
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from transplanter.machine.fuzzy_gripper import NO_ECHO
from transplanter.viewing.video import Mp4Output

__all__ = ["SERIAL_CAMERAS", "SERVOS", "SerialRecording", "SerialVideo", "scalar_names"]

SERVOS = ("base", "shoulder", "elbow", "gripper")
SERIAL_CAMERAS = ("overview", "gripper_closeup")


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


class SerialVideo(Mp4Output):
    """Writes the serial arm's pick and place to an MP4 (`render serial_arm`): a frame at
    the first physics step at or after each k / fps s of simulated time. The lane's and the
    belt's faces (geom group 3, as the arm's collision shapes) are drawn with `groups`
    (default: the visual groups 0-2 and 3)."""

    def __init__(
        self,
        target: str | os.PathLike,
        width: int,
        height: int,
        fps: float,
        camera: str = "overview",
        shadows: bool = False,
    ) -> None:
        from transplanter.viewing import video

        self.video = video
        self._setup(target, width, height, fps, camera, shadows)
        # what the trial tells its observers (run_pick_place sets these)
        self.fuzzy_deg = math.nan
        self.squeeze_n = 0.0
        self.tomato: int | None = None
        self.decision: str | None = None
        self.outcomes: list[str] = []

    def attach(self, rig) -> None:
        video = self.video
        video.check_frames(*self.size, self.fps, rig.model.opt.timestep)
        self.rig = rig
        self.grabber = video.FrameGrabber(rig.model, *self.size, self.camera, self.shadows)
        self.grabber.option.geomgroup[3] = 1  # the lane and the belt (their faces collide)
        self.writer = video.Mp4Writer(self.target, self.size, self.fps, self.ffmpeg)

    def caption(self, t: float) -> list[str]:
        rig = self.rig
        lines = [f"t = {t:6.2f} s   " + ("homing" if self.tomato is None else
                                         f"tomato {self.tomato}")]  # fmt: skip
        if self.decision is None:
            lines.append("controller: no decision yet")
        else:  # "sensor 1 2.0 cm, sensor 2 2.6 cm, base 90.0 deg -> gripper 22.50 deg (small)"
            inputs, _, output = self.decision.partition(" -> ")
            lines += [inputs.replace("sensor ", "S"), f"-> {output}"]
        servo = math.degrees(float(rig.bank.shafts()[3]))
        lines.append(f"servo {servo:4.1f} deg, squeeze {self.squeeze_n:4.1f} N")
        if self.outcomes:
            lines.append(self.outcomes[-1])
        return lines

    def look(self, t: float, force: bool = False) -> None:
        if self.error is not None or not self.clock.due(t):
            return
        t0 = time.perf_counter()
        try:
            frame = self.video.annotate(self.grabber.grab(self.rig.data), self.caption(t))
            self.writer.append(frame)
        except Exception as exc:  # an encoder that died (disk full): the trial goes on
            self.error = f"the video could not be encoded: {exc}"
            self.writer.discard()
        self.render_s += time.perf_counter() - t0

    def event(self, t: float, kind: str, text: str) -> None:
        if kind == "controller":
            self.decision = text.split(": ", 1)[-1]
        elif kind in ("tomato", "failure"):
            self.outcomes.append(text)

    def finish(self, t: float) -> str | None:
        """The video written (or discarded with the reason in `error`); the error."""
        self._close(False, "the job ended before its first frame")
        return self.error
