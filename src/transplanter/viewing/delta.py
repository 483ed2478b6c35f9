"""Recording and filming the delta's cull-and-refill trial (`transplanter trial delta_refill
--record F.rrd`, `transplanter render delta_refill --out clip.mp4`).

Both are observers of `twin.delta_refill.run_delta_refill` (`DeltaObserver`): the trial calls
them only at their frame times (`next_t`, a grid of 1 / rate s of simulated time) and they
only read its state, so the trial's numbers are the same with or without them.

- `DeltaRecording` feeds the five-bar's `TrialRecorder` (geometry from the compiled MjModel
  once, the moving bodies' poses per frame: the arms, rods, platform, claws and the job's free
  plugs) with the scalar channels of `scalar_names`, the tray's state as coloured markers over
  the job's cells (`world/tray_state`) and an event at each change of a cell's status.
- `DeltaVideo` renders a named camera (the scene's `overview` and `trays`, `claws_closeup` on
  the platform) into an MP4 through the five-bar's `FrameGrabber` and `Mp4Writer`, each frame
  captioned with the simulated time, the cell in progress and the last cell finished; `cells`
  films only those cells' work (first line to last line plus `CELL_TAIL_S`).

A serviced cell's status (`cell_status`): `to_cull` / `to_fill` before its work starts,
`culling` (its inferior plug not yet in the bin), `culled` (binned, the refill still in its
supply cell), `refilling` (until its last line is done), `refilled` (seated), `damaged`
(seated with a leaf torn), `failed` (its work ended with the culled plug out of the bin or the
refill not seated).
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from transplanter.scene.delta_scene import plug_name
from transplanter.viewing.video import Mp4Output
from transplanter.vision.grading import INFERIOR

__all__ = [
    "CELL_TAIL_S",
    "DELTA_CAMERAS",
    "STATUS_CODES",
    "DeltaRecording",
    "DeltaVideo",
    "cell_status",
    "run_observed",
    "scalar_names",
    "torn_plugs",
]

CELL_TAIL_S = 0.5
DELTA_CAMERAS = ("overview", "trays", "claws_closeup")
SEAT_TOL_M = 0.006  # as the trial's judge
STATUS_CODES = {
    "to_cull": 0,
    "to_fill": 1,
    "culling": 2,
    "culled": 3,
    "refilling": 4,
    "refilled": 5,
    "damaged": 6,
    "failed": 7,
}
"""The number each status is recorded as (`scalars/tray/cell_NNN`)."""
STATUS_RGBA = {
    "to_cull": (200, 60, 40, 255),
    "to_fill": (230, 200, 40, 255),
    "culling": (240, 140, 40, 255),
    "culled": (150, 150, 150, 255),
    "refilling": (80, 160, 240, 255),
    "refilled": (40, 200, 70, 255),
    "damaged": (200, 40, 200, 255),
    "failed": (20, 20, 20, 255),
}
ARM_NAMES = ("q1", "q2", "q3")


def scalar_names(ops) -> list[str]:
    """The recording's scalar channels for a job (`ops`: the trial's work list)."""
    names = []
    for q in ARM_NAMES:
        names += [f"joints/{q}_cmd_deg", f"joints/{q}_deg"]
    names += [f"platform/{a}_mm" for a in "xyz"]
    names += ["platform/tilt_deg"]
    names += [
        "claws/rotary_cmd_deg",
        "claws/rotary_deg",
        "claws/valve",
        "claws/stroke_left_mm",
        "claws/stroke_right_mm",
    ]
    names += [f"tray/cell_{op.cell:03d}" for op in ops]
    return names


def cell_status(view: Any, op: Any, torn: set[str]) -> str:
    """A serviced cell's status now (module docstring); `torn`: the plugs with a leaf torn."""
    marks, data, cfg = view.host.marks, view.data, view.cfg
    start, end = marks.get(f"cell{op.cell}_start"), marks.get(f"cell{op.cell}_end")
    if start is None:
        return "to_cull" if op.truth == INFERIOR else "to_fill"
    xy = cfg.cell_xy("planting", op.cell)
    culled = True
    if op.truth == INFERIOR:
        plug = view.physics[plug_name("planting", op.cell)]
        x, y, z = (float(v) for v in data.xpos[plug.body])
        half = cfg.bin_size_m / 2
        bx, by = cfg.bin_xy_m
        culled = abs(x - bx) < half and abs(y - by) < half and z < cfg.tray_top_m
    seated = False
    refill = None if op.supply is None else plug_name("supply", op.supply)
    if refill is not None:
        seated = view.physics[refill].seated_in(data, xy, SEAT_TOL_M)
    if end is not None and (not culled or not seated):
        return "failed"
    if not culled:
        return "culling"
    if end is None:
        if op.truth == INFERIOR and refill is not None and not seated:
            # culled until the refill leaves its supply cell
            supply_xy = cfg.cell_xy("supply", op.supply)
            if view.physics[refill].seated_in(data, supply_xy, SEAT_TOL_M):
                return "culled"
        return "refilling"
    return "damaged" if refill in torn else "refilled"


def torn_plugs(view: Any) -> set[str]:
    """The plugs with a leaf torn so far (their names: p003, s000)."""
    return {d.leaf.split("_", 1)[0] for d in view.leaves.damage}


class _Clock:
    """Frames at k / rate s of simulated time: the first look at or after each."""

    def __init__(self, rate_hz: float) -> None:
        self.rate = rate_hz
        self.next_t = 0.0

    def tick(self, t: float) -> None:
        self.next_t = (math.floor(t * self.rate + 1e-6) + 1) / self.rate - 1e-9


class DeltaRecording:
    """Records a delta trial to an .rrd (`trial delta_refill --record F.rrd`)."""

    def __init__(self, path: str | os.PathLike, rate_hz: float = 60.0) -> None:
        self.path, self.rate_hz = Path(path), rate_hz
        self.clock = _Clock(rate_hz)
        self.recorder: Any = None
        self.status: dict[int, str] = {}
        self.error: str | None = None

    @property
    def next_t(self) -> float:
        return self.clock.next_t

    def attach(self, view: Any) -> None:
        from transplanter.viewing.recording import TrialRecorder

        model = view.model
        try:
            self.recorder = TrialRecorder(
                model, self.path, rate_hz=self.rate_hz, scalar_names=scalar_names(view.ops)
            )
        except Exception as exc:  # the trial goes on without it (exit status 5 at the end)
            self.error = f"the recording {str(self.path)!r} could not be started: {exc}"
            self.clock.next_t = math.inf
            return
        self.arms = [model.jnt_qposadr[model.joint(n).id] for n in ARM_NAMES]
        self.platform = model.body("platform").id
        self.rotary = model.jnt_qposadr[model.joint("rotary").id]
        self.strokes = [model.jnt_qposadr[model.joint(n).id] for n in ("claw_left", "claw_right")]
        top = view.cfg.tray_top_m
        self.marker_xyz = np.array(
            [(*view.cfg.cell_xy("planting", op.cell), top + 0.004) for op in view.ops]
        ).reshape(-1, 3)
        self.labels = [f"cell {op.cell} ({op.truth})" for op in view.ops]
        self.look(view)

    def _scalars(self, view: Any) -> np.ndarray:
        data = view.data
        values = []
        for i, adr in enumerate(self.arms):
            values += [math.degrees(view.command[i]), math.degrees(data.qpos[adr])]
        values += list(data.xpos[self.platform] * 1e3)
        # the platform's tilt: the angle of its z axis from the world's
        values.append(math.degrees(math.acos(min(1.0, float(data.xmat[self.platform][8])))))
        ctrl = view.cycle.ctrl(view.t)
        values += [math.degrees(ctrl[0]), math.degrees(data.qpos[self.rotary]), np.sign(ctrl[1])]
        values += [data.qpos[a] * 1e3 for a in self.strokes]
        values += [STATUS_CODES[self.status[op.cell]] for op in view.ops]
        return np.array(values, dtype=np.float64)

    def _update_status(self, view: Any) -> bool:
        torn = torn_plugs(view)
        changed = False
        for op in view.ops:
            now = cell_status(view, op, torn)
            if self.status.get(op.cell) != now:
                changed = True
                self.status[op.cell] = now
                if view.t > 0:
                    kind = "failure" if now in ("failed", "damaged") else "cell"
                    self.recorder.event(view.t, kind, f"cell {op.cell} ({op.truth}): {now}")
        return changed

    def _log_tray(self, view: Any) -> None:
        import rerun as rr

        colors = [STATUS_RGBA[self.status[op.cell]] for op in view.ops]
        labels = [
            f"{lbl}: {self.status[op.cell]}" for lbl, op in zip(self.labels, view.ops, strict=True)
        ]
        self.recorder.log_at(
            view.t,
            "world/tray_state",
            rr.Points3D(self.marker_xyz, colors=colors, labels=labels, radii=0.008),
        )

    def look(self, view: Any, force: bool = False) -> None:
        if self.error is not None:
            self.clock.next_t = math.inf
            return
        try:
            if self._update_status(view) and view.ops:
                self._log_tray(view)
            self.recorder.frame(view.t, view.data, self._scalars(view), force=force)
        except Exception as exc:  # the trial goes on; the recording is lost
            self.error = f"the recording {str(self.path)!r} could not be written: {exc}"
            self.recorder.abort()
            self.clock.next_t = math.inf
            return
        self.clock.tick(view.t)

    def finish(self, view: Any, result: Any) -> None:
        """The last state (off the grid), the fault if any, and the file; sets
        result.recording_error when it could not be written."""
        from transplanter.viewing.recording import RecordingError

        if self.error is None:
            view.t = result.sim_time_s
            self.look(view, force=True)
        if self.error is None and result.fault is not None:
            self.recorder.event(view.t, "failure", f"fault: {result.fault}")
        if self.error is None:
            try:
                self.recorder.close()
            except RecordingError as exc:
                self.error = str(exc)
        result.recording_error = self.error

    def abort(self) -> None:
        if self.recorder is not None:
            self.recorder.abort()


def parse_cells(text: str) -> set[int]:
    """'12,40-42' -> planting cell indices (0-127, as the results' `cells[].index`)."""
    from transplanter.viewing.video import RenderRefused

    out: set[int] = set()
    for part in text.split(","):
        lo, dash, hi = part.strip().partition("-")
        if not (lo.isascii() and lo.isdigit()) or (dash and not (hi.isascii() and hi.isdigit())):
            raise RenderRefused(f"{text!r}: {part.strip()!r} is not N or N-M (cell indices)")
        a, b = int(lo), int(hi) if dash else int(lo)
        if b < a:
            raise RenderRefused(f"{text!r}: {part.strip()!r} runs backwards")
        out.update(range(a, b + 1))
    return out


class DeltaVideo(Mp4Output):
    """Writes a delta trial (or only the work of `cells`) to an MP4 (`render delta_refill`)."""

    def __init__(
        self,
        target: Path,
        width: int,
        height: int,
        fps: float,
        camera: str = "overview",
        cells: set[int] | None = None,
        shadows: bool = False,
    ) -> None:
        from transplanter.viewing import video

        self.video = video
        self.ffmpeg = video.require_imageio()
        self.target, self.size, self.fps = Path(target), (width, height), fps
        self.camera, self.cells, self.shadows = camera, cells, shadows
        self.clock = _Clock(fps)
        self.grabber: Any = None
        self.writer: Any = None
        self.error: str | None = None
        self.path: Path | None = None
        self.render_s = 0.0
        self.status: dict[int, str] = {}

    @property
    def next_t(self) -> float:
        return self.clock.next_t

    @property
    def frames(self) -> int:
        return self.writer.frames if self.writer is not None else 0

    def attach(self, view: Any) -> None:
        video = self.video
        video.check_frames(*self.size, self.fps, view.model.opt.timestep)
        job = [op.cell for op in view.ops]
        if self.cells is not None and not self.cells <= set(job):
            missing = ", ".join(str(c) for c in sorted(self.cells - set(job)))
            raise video.RenderRefused(
                f"--cells-of: cell(s) {missing} are not serviced by this job; its cells "
                f"are {', '.join(map(str, job)) or 'none'}"
            )
        self.grabber = video.FrameGrabber(view.model, *self.size, self.camera, self.shadows)
        self.writer = video.Mp4Writer(self.target, self.size, self.fps, self.ffmpeg)
        self.look(view)

    def _window(self, view: Any, cell: int) -> tuple[float | None, float | None]:
        marks = view.host.marks
        end = marks.get(f"cell{cell}_end")
        return marks.get(f"cell{cell}_start"), None if end is None else end + CELL_TAIL_S

    def _current(self, view: Any) -> Any:
        """The op whose work is in progress (or, before the next starts, whose tail is
        showing), else None."""
        for op in reversed(view.ops):
            start, end = self._window(view, op.cell)
            if start is not None and view.t >= start and (end is None or view.t <= end):
                return op
        return None

    def _wanted(self, view: Any) -> bool:
        if self.cells is None:
            return True
        for cell in self.cells:
            start, end = self._window(view, cell)
            if start is not None and view.t >= start and (end is None or view.t <= end):
                return True
        return False

    def caption(self, view: Any) -> list[str]:
        marks = view.host.marks
        lines = [f"t = {view.t:7.3f} s"]
        op = self._current(view)
        torn = torn_plugs(view)
        if op is not None:
            lines.append(f"cell {op.cell} ({op.truth}): {cell_status(view, op, torn)}")
        elif "start" not in marks:
            lines.append("homing" if "image" not in marks else "imaging")
        elif "end" in marks:
            lines.append("tray done")
        else:
            lines.append("between cells")
        done = [o for o in view.ops if f"cell{o.cell}_end" in marks]
        if done:
            last = done[-1]
            lines.append(f"cell {last.cell}: {cell_status(view, last, torn)}")
        return lines

    def look(self, view: Any) -> None:
        self.clock.tick(view.t)
        if self.error is not None or not self._wanted(view):
            return
        t0 = time.perf_counter()
        try:
            frame = self.video.annotate(self.grabber.grab(view.data), self.caption(view))
            self.writer.append(frame)
        except Exception as exc:  # an encoder that died (disk full): the trial goes on
            self.error = f"the video could not be encoded: {exc}"
            self.writer.discard()
            self.clock.next_t = math.inf
        self.render_s += time.perf_counter() - t0

    def finish(self, view: Any, result: Any) -> None:
        chosen = ", ".join(str(c) for c in sorted(self.cells or ()))
        self._close(False, f"cells {chosen} were never worked on")


def run_observed(sc, seed: int | None, observers: list) -> Any:
    """run_delta_refill with `observers`, each finished with the result (or aborted, leaving
    no file, when the trial or an observer raises: Ctrl-C, a refused camera)."""
    from transplanter.twin.delta_refill import run_delta_refill

    views: list[Any] = []

    class _Catch:  # keeps the view so that the observers can be finished with it
        next_t = math.inf

        def attach(self, view: Any) -> None:
            views.append(view)

        def look(self, view: Any) -> None:
            pass

    try:
        result = run_delta_refill(sc, seed, observers=[_Catch(), *observers])
    except BaseException:
        for o in observers:
            o.abort()
        raise
    for o in observers:
        o.finish(views[0], result)
    return result
