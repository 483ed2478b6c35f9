"""Render the delta's pictures of docs/delta.md from the delta_refill scenario (re-runnable).

Run: .venv/bin/python scripts/make_delta_pictures.py   (needs pip install -e ".[video]")

One cell of the cull-and-refill job (seed 10: its first job cell, 3, is inferior: a removal to
the bin and a refill from the supply tray) runs with the controller and drives driving the
physics, and a trial observer (transplanter.viewing.delta's protocol) films it:
- docs/img/delta.png: a still at 640x480 from the `overview` camera (no shadows: the base
  would darken the trays under it), the moment the culled plug is lifted 50 mm clear of the
  tray;
- docs/img/delta_refill.gif: the cell's work (its first line to its last plus 0.5 s) from the
  `trays` camera at 320x240 (rendered at 640x480, downscaled), a frame every 0.25 s of
  simulated time played at 10 fps (2.5 x real time), with the time and the cell's status.
Headless, MUJOCO_GL=egl is used unless MUJOCO_GL is set. Both files are written atomically.
"""

from __future__ import annotations

import io
import math
import sys
import time
from pathlib import Path

from transplanter.viewing import video

video.prepare_gl()  # before MuJoCo is imported

import imageio.v3 as iio  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from transplanter import fileio  # noqa: E402
from transplanter.scenario.schema import load_scenario  # noqa: E402
from transplanter.scene.delta_scene import plug_name  # noqa: E402
from transplanter.viewing import delta  # noqa: E402

IMG = Path(__file__).resolve().parent.parent / "docs" / "img"
SEED = 10
STILL_SIZE = (640, 480)
GIF_SIZE, GIF_STEP_S, GIF_FPS = (320, 240), 0.25, 10.0
LIFTED_M = 0.05


class _Pictures:
    """The still when the culled plug is first LIFTED_M above the tray, the GIF's frames over
    the first cell's work."""

    def __init__(self) -> None:
        self.next_t = 0.0
        self.still: np.ndarray | None = None
        self.frames: list[np.ndarray] = []

    def attach(self, view) -> None:
        self.op = view.ops[0]
        self.plug = view.model.body(plug_name("planting", self.op.cell)).id
        self.top = view.cfg.tray_top_m
        self.stills = video.FrameGrabber(view.model, *STILL_SIZE, "overview")
        self.clip = video.FrameGrabber(view.model, *STILL_SIZE, "trays")

    def look(self, view) -> None:
        t = view.t
        self.next_t = t + view.model.opt.timestep  # every step: the still's moment
        if self.still is None and view.data.xpos[self.plug][2] > self.top + LIFTED_M:
            self.still = self.stills.grab(view.data)
        marks = view.host.marks
        start, end = marks.get(f"cell{self.op.cell}_start"), marks.get(f"cell{self.op.cell}_end")
        if start is None or t < start or (end is not None and t > end + delta.CELL_TAIL_S):
            return
        k = math.floor((t - start) / GIF_STEP_S + 1e-9)
        if k < len(self.frames):
            return
        frame = Image.fromarray(self.clip.grab(view.data)).resize(GIF_SIZE, Image.LANCZOS)
        status = delta.cell_status(view, self.op, delta.torn_plugs(view))
        lines = [f"t = {t:6.2f} s", f"cell {self.op.cell}: {status}"]
        self.frames.append(video.annotate(np.asarray(frame), lines))

    def finish(self, view, result) -> None:
        self.stills.close()
        self.clip.close()

    def abort(self) -> None:
        for g in ("stills", "clip"):
            if hasattr(self, g):
                getattr(self, g).close()


def _write(path: Path, data: bytes) -> None:
    tmp = fileio.temp_beside(path)
    try:
        tmp.write_bytes(data)
    except BaseException:
        fileio.discard(tmp)
        raise
    fileio.commit(tmp, path)


def main() -> int:
    scenario = load_scenario("delta_refill", {"delta_refill.max_cells": 1})
    pictures = _Pictures()
    t0 = time.perf_counter()
    result = delta.run_observed(scenario, SEED, [pictures])
    if pictures.still is None or not pictures.frames:
        print("the job never lifted its plug: no pictures written", file=sys.stderr)
        return 1
    buf = io.BytesIO()
    Image.fromarray(pictures.still).save(buf, format="PNG", optimize=True)
    _write(IMG / "delta.png", buf.getvalue())
    gif = iio.imwrite("<bytes>", pictures.frames, extension=".gif", duration=1000 / GIF_FPS, loop=0)
    _write(IMG / "delta_refill.gif", gif)
    cell = result.cells[0]
    print(
        f"docs/img/delta.png ({STILL_SIZE[0]}x{STILL_SIZE[1]}, {len(buf.getvalue()) >> 10} KiB) "
        f"and docs/img/delta_refill.gif ({len(pictures.frames)} frames at {GIF_FPS:g} fps, "
        f"{len(gif) >> 10} KiB); cell {cell.index}: culled {cell.culled}, refilled "
        f"{cell.refilled}; {time.perf_counter() - t0:.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
