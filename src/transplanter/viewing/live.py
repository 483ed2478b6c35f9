"""`transplanter view`: a trial shown live in MuJoCo's passive viewer.

`LiveViewer` is a trial observer (`transplanter.twin.trial.TrialObserver`): the trial's own loop
steps the physics with the firmware driving it, and every frame interval of simulated time
the viewer is synced and the loop waits until the wall clock catches up with simulated time
divided by the speed factor. The viewer's overlay (`Handle.set_texts`) shows the simulated
time, the seedlings done and the last verdict. Closing the window stops the trial as Ctrl-C
would (the seedlings judged until then are kept).
"""

from __future__ import annotations

import time
from typing import Any

from transplanter.errors import TransplanterError
from transplanter.twin.results import Outcome, SeedlingRecord

__all__ = ["LiveViewer", "MAX_SPEED", "Pacing", "ViewerUnavailable"]

MAX_SPEED = 100.0
SYNC_HZ = 60.0  # viewer updates per second of wall time


class ViewerUnavailable(TransplanterError, RuntimeError):
    """MuJoCo's viewer could not open a window."""


class Pacing:
    """When a live viewer is synced and how long the run waits for the wall clock, at
    `speed` x real time: a sync every SYNC_HZ-th of a wall second of simulated time at most,
    at most half the wall time spent on viewer updates, the run held back to the wall clock
    (the five-bar's trial and the loop's jobs share it)."""

    def __init__(self, speed: float) -> None:
        self.speed = speed
        self.sync_every_s = speed / SYNC_HZ  # simulated s between viewer updates
        self.t_next = 0.0
        self.wall0 = 0.0
        self.next_sync_wall = 0.0  # no viewer update before this wall time
        self.syncs = 0

    def start(self) -> None:
        self.wall0 = time.perf_counter()

    def due(self, t: float) -> bool:
        """Whether simulated time `t` is a frame's time (and the next one set)."""
        if t + 1e-12 < self.t_next:
            return False
        self.t_next = t + self.sync_every_s
        return True

    def sync(self, t: float, handle: Any, texts, before_sync=None) -> None:
        """Update the viewer (its overlay `texts()`: left and right columns; `before_sync`:
        what the drawn state needs first) unless that would take more than half the wall
        time, then wait until the wall clock reaches t / speed."""
        import mujoco

        now = time.perf_counter()
        if now >= self.next_sync_wall:
            left, right = texts()
            handle.set_texts(
                (mujoco.mjtFontScale.mjFONTSCALE_150, mujoco.mjtGridPos.mjGRID_TOPLEFT, left, right)
            )
            if before_sync is not None:
                before_sync()
            handle.sync()  # waits for the viewer's render loop (slow with software GL)
            self.syncs += 1
            done = time.perf_counter()
            self.next_sync_wall = done + max(1.0 / SYNC_HZ, done - now)
            now = done
        ahead = t / self.speed - (now - self.wall0)
        if ahead > 0:
            time.sleep(ahead)


class LiveViewer:
    """Shows the twin in `mujoco.viewer.launch_passive`, paced to `speed` x real time."""

    def __init__(self, speed: float = 1.0) -> None:
        self.speed = speed
        self.pacing = Pacing(speed)
        self.handle: Any = None
        self.records: list[SeedlingRecord] = []
        self.judged = 0
        self.closed = False
        self.closed_at = 0.0

    def attach(self, twin: Any, records: list[SeedlingRecord]) -> None:
        import mujoco.viewer

        self.records = records
        try:
            self.handle = mujoco.viewer.launch_passive(
                twin.scene.render_model,
                twin.scene.render_data(twin.data),
                show_left_ui=False,
                show_right_ui=False,
            )
        except Exception as exc:
            raise ViewerUnavailable(f"MuJoCo's viewer could not open a window: {exc}") from None
        cam = self.handle.cam
        cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
        cam.fixedcamid = mujoco.mj_name2id(twin.model, mujoco.mjtObj.mjOBJ_CAMERA, "overview")
        self.pacing.start()
        self.step(twin)

    def _texts(self, t: float) -> tuple[str, str]:
        recs = self.records
        while self.judged < len(recs) and recs[self.judged].outcome != Outcome.PENDING:
            self.judged += 1
        ok = sum(r.outcome == Outcome.SUCCESS for r in recs[: self.judged])
        left = ["simulated time", "seedlings judged", "successes", "last verdict", "speed"]
        last = "-"
        if self.judged:
            last = f"{recs[self.judged - 1].index}: {recs[self.judged - 1].outcome}"
        right = [f"{t:.2f} s", f"{self.judged} / {len(recs)}", f"{ok}", last, f"{self.speed:g}x"]
        return "\n".join(left), "\n".join(right)

    def step(self, twin: Any) -> None:
        t = twin.time
        if not self.pacing.due(t):
            return
        if not self.handle.is_running():
            self.closed, self.closed_at = True, t
            raise KeyboardInterrupt  # the trial stops as on Ctrl-C
        # the decorated model the viewer draws
        self.pacing.sync(t, self.handle, lambda: self._texts(t),
                         lambda: twin.scene.render_data(twin.data))  # fmt: skip

    def finish(self, twin: Any, interrupted: bool) -> None:
        if self.handle is not None and not (self.closed or interrupted):
            left, right = self._texts(twin.time)
            self.handle.set_texts(
                (None, None, left + "\ntrial", right + "\nfinished (close the window)")
            )
            twin.scene.render_data(twin.data)
            self.handle.sync()
            while self.handle.is_running():  # leave the last state up until closed
                time.sleep(0.1)
        if self.handle is not None:
            self.handle.close()

    def abort(self) -> None:
        if self.handle is not None:
            self.handle.close()
