"""`transplanter view` of a job on `twin.loop.StepLoop` (`view delta_pots`, `view
serial_arm_pots`): MuJoCo's passive viewer, paced to real time times the speed, as an
observer of the loop like `viewing.loop_video.LoopVideo` (attach, event, finish, abort), so
watching a run changes nothing in it (unless a body is dragged in the window). The overlay
shows the simulated time, the verdicts so far and the last one. Closing the window stops
the run (`ViewerClosed`).
"""

from __future__ import annotations

import time
from typing import Any

from transplanter.viewing.live import Pacing, ViewerUnavailable

__all__ = ["LoopLiveViewer", "ViewerClosed"]


class ViewerClosed(KeyboardInterrupt):
    """The viewer's window was closed: the run stops as on Ctrl-C."""


class LoopLiveViewer:
    """Shows a StepLoop's job in `mujoco.viewer.launch_passive`, paced to `speed` x real
    time (module docstring)."""

    def __init__(self, speed: float = 1.0, camera: str = "overview") -> None:
        self.speed = speed
        self.camera = camera
        self.pacing = Pacing(speed)
        self.loop: Any = None
        self.handle: Any = None
        self.verdicts: list[str] = []
        self.successes = 0
        self.closed_at: float | None = None
        self.error: str | None = None

    def attach(self, loop: Any) -> None:
        import mujoco
        import mujoco.viewer

        self.loop = loop
        try:
            self.handle = mujoco.viewer.launch_passive(
                loop.model, loop.data, show_left_ui=False, show_right_ui=False
            )
        except Exception as exc:
            raise ViewerUnavailable(f"MuJoCo's viewer could not open a window: {exc}") from None
        cam = mujoco.mj_name2id(loop.model, mujoco.mjtObj.mjOBJ_CAMERA, self.camera)
        if cam >= 0:
            self.handle.cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
            self.handle.cam.fixedcamid = cam
        self.pacing.start()
        loop.after_step.append(self._look)

    def event(self, t: float, kind: str, text: str, unit: int | None = None) -> None:
        if kind in ("success", "failure"):
            self.verdicts.append(text)
            self.successes += kind == "success"

    def _texts(self, t: float) -> tuple[str, str]:
        left = "simulated time\nverdicts\nsuccesses\nlast verdict\nspeed"
        last = self.verdicts[-1] if self.verdicts else "-"
        right = f"{t:.2f} s\n{len(self.verdicts)}\n{self.successes}\n{last}\n{self.speed:g}x"
        return left, right

    def _look(self, _t: float) -> None:
        t = self.loop.time
        if not self.pacing.due(t):
            return
        if not self.handle.is_running():
            self.closed_at = t
            raise ViewerClosed
        self.pacing.sync(t, self.handle, lambda: self._texts(t))

    def finish(self, t: float) -> str | None:
        """The run ended: the last state stays up until the window is closed."""
        if self.handle is not None:
            left, right = self._texts(t)
            self.handle.set_texts(
                (None, None, left + "\nrun", right + "\nfinished (close the window)")
            )
            self.handle.sync()
            while self.handle.is_running():
                time.sleep(0.1)
            self.handle.close()
        return None

    def abort(self) -> None:
        if self.handle is not None:
            self.handle.close()
