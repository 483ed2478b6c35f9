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

from transplanter.viewing.live import SYNC_HZ, ViewerUnavailable

__all__ = ["LoopLiveViewer", "ViewerClosed"]


class ViewerClosed(KeyboardInterrupt):
    """The viewer's window was closed: the run stops as on Ctrl-C."""


class LoopLiveViewer:
    """Shows a StepLoop's job in `mujoco.viewer.launch_passive`, paced to `speed` x real
    time (module docstring)."""

    def __init__(self, speed: float = 1.0, camera: str = "overview") -> None:
        self.speed = speed
        self.camera = camera
        self.sync_every_s = speed / SYNC_HZ  # simulated s between viewer updates
        self.loop: Any = None
        self.handle: Any = None
        self.verdicts: list[str] = []
        self.successes = 0
        self.t_next = 0.0
        self.wall0 = 0.0
        self.next_sync_wall = 0.0
        self.syncs = 0
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
        self.wall0 = time.perf_counter()
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
        if t + 1e-12 < self.t_next:
            return
        self.t_next = t + self.sync_every_s
        handle = self.handle
        if not handle.is_running():
            self.closed_at = t
            raise ViewerClosed
        import mujoco

        now = time.perf_counter()
        if now >= self.next_sync_wall:
            left, right = self._texts(t)
            handle.set_texts(
                (mujoco.mjtFontScale.mjFONTSCALE_150, mujoco.mjtGridPos.mjGRID_TOPLEFT, left, right)
            )
            handle.sync()
            self.syncs += 1
            done = time.perf_counter()
            # at most half the wall time goes to viewer updates, so the physics keeps pace
            self.next_sync_wall = done + max(1.0 / SYNC_HZ, done - now)
            now = done
        ahead = t / self.speed - (now - self.wall0)
        if ahead > 0:
            time.sleep(ahead)

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
