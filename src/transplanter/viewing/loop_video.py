"""An MP4 of a job on `twin.loop.StepLoop` (`transplanter render delta_pots`, `render
serial_arm_pots`): an observer as `viewing.loop_recording.LoopRecording` is (attach, event,
finish, abort), so filming a run changes nothing in it: a frame at the first physics step at
or after each k / fps s of simulated time, captioned with the time and the judge's last
verdict. It draws the physics model: the pots' collision shapes without their decor (the
seedlings' shoots are the judge's, not bodies).
"""

from __future__ import annotations

import os
import time
from typing import Any

from transplanter.viewing import video

__all__ = ["LoopVideo"]


class LoopVideo(video.Mp4Output):
    """Films a StepLoop's job (module docstring)."""

    def __init__(
        self,
        target: str | os.PathLike,
        width: int,
        height: int,
        fps: float,
        camera: str = video.DEFAULT_CAMERA,
        shadows: bool = False,
    ) -> None:
        self._setup(target, width, height, fps, camera, shadows)
        self.loop: Any = None
        self.verdicts: list[str] = []

    def attach(self, loop: Any) -> None:
        """Film the loop from its power-on state (video.RenderRefused: frames the timestep
        cannot give; video.GLUnavailable: no OpenGL context)."""
        video.check_frames(*self.size, self.fps, loop.model.opt.timestep)
        self.loop = loop
        self.grabber = video.FrameGrabber(loop.model, *self.size, self.camera, self.shadows)
        self.grabber.option.geomgroup[3] = 1  # the pots and the tube: their collision shapes
        self.writer = video.Mp4Writer(self.target, self.size, self.fps, self.ffmpeg)
        self._look(0.0)
        loop.after_step.append(self._look)

    def _caption(self, t: float) -> list[str]:
        lines = [f"t = {t:7.3f} s"]
        if self.verdicts:
            lines.append(self.verdicts[-1])
        return lines

    def _look(self, _t: float) -> None:
        t = self.loop.time
        if self.error is not None or not self.clock.due(t):
            return
        t0 = time.perf_counter()
        try:
            self.writer.append(video.annotate(self.grabber.grab(self.loop.data), self._caption(t)))
        except Exception as exc:  # an encoder that died (disk full): the job goes on
            self.error = f"the video could not be encoded: {exc}"
            self.writer.discard()
        self.render_s += time.perf_counter() - t0

    def event(self, t: float, kind: str, text: str, unit: int | None = None) -> None:
        if kind in ("success", "failure"):
            self.verdicts.append(text)

    def finish(self, t: float) -> str | None:
        """The video written (or discarded, the reason in `error`); the error."""
        self._close(False, "the job ended before its first frame")
        return self.error
