"""Render the pictures of the docs from the paper scenario (re-runnable).

Run: .venv/bin/python scripts/make_pictures.py   (needs pip install -e ".[video]")

One paper trial of one seedling (seed 1) runs with the firmware driving the physics, and a
trial observer (transplanter.viewing.video) films the `overview` camera:
- docs/img/machine.png: a still at 640x480 with shadows, mid-pick: the moment the lift
  line is acknowledged (homed, the pot gripped and raised to Z_up);
- docs/img/cycle.gif: the seedling's whole cycle (first line to the release dwell's end plus
  0.5 s) at 10 fps and 320x240 (rendered at 640x480, downscaled), with the simulated time.
Headless, MUJOCO_GL=egl is used unless MUJOCO_GL is set. Both files are written atomically.
"""

from __future__ import annotations

import io
import sys
import time
from pathlib import Path

from transplanter.viewing import video

video.prepare_gl()  # before MuJoCo is imported

import imageio.v3 as iio  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from transplanter import fileio  # noqa: E402
from transplanter.machine.pgf import LinePhase  # noqa: E402
from transplanter.scenario.assemble import assemble  # noqa: E402
from transplanter.scenario.schema import load_scenario  # noqa: E402
from transplanter.twin.sim import LineEventKind  # noqa: E402
from transplanter.twin.trial import run_trial  # noqa: E402

IMG = Path(__file__).resolve().parent.parent / "docs" / "img"
STILL_SIZE = (640, 480)
GIF_SIZE, GIF_FPS = (320, 240), 10.0


class _Pictures:
    """A trial observer: the still at the first lift's acknowledgement, the GIF's frames
    over seedling 0's cycle."""

    def __init__(self) -> None:
        self.clock = video._FrameClock(GIF_FPS)
        self.still: np.ndarray | None = None
        self.want_still = False
        self.frames: list[np.ndarray] = []

    def attach(self, twin, records) -> None:
        self.records = records
        # the decorated model (pot meshes, stems, leaves) with the physics state mirrored
        self.scene = twin.scene
        self.grabber = video.FrameGrabber(
            twin.scene.render_model, *STILL_SIZE, "overview", shadows=True
        )
        twin.line_listeners.append(self._on_line)

    def _on_line(self, event) -> None:
        line = event.line
        done = event.kind == LineEventKind.DONE
        if done and line.phase == LinePhase.LIFT and self.still is None:
            self.want_still = True

    def step(self, twin) -> None:
        if self.want_still:
            self.still = self.grabber.grab(self.scene.render_data(twin.data))
            self.want_still = False
        t = twin.time
        start, end = video.cycle_window(self.records, 0)
        if start is None or t < start - 1e-9 or (end is not None and t > end + 1e-9):
            return
        if self.clock.due(t):
            frame = self.grabber.grab(self.scene.render_data(twin.data))
            small = Image.fromarray(frame).resize(GIF_SIZE, Image.LANCZOS)
            self.frames.append(video.annotate(np.asarray(small), [f"t = {t:6.2f} s"]))

    def finish(self, twin, interrupted: bool) -> None:
        self.grabber.close()

    def abort(self) -> None:
        self.grabber.close()


def _write(path: Path, data: bytes) -> None:
    tmp = fileio.temp_beside(path)
    try:
        tmp.write_bytes(data)
    except BaseException:
        fileio.discard(tmp)
        raise
    fileio.commit(tmp, path)


def main() -> int:
    config = assemble(load_scenario("paper", {"scenario.seedlings": 1, "scenario.seed": 1}))
    pictures = _Pictures()
    t0 = time.perf_counter()
    result = run_trial(config, observers=[pictures])
    if pictures.still is None or not pictures.frames:
        print("the trial never lifted a pot: no pictures written", file=sys.stderr)
        return 1
    buf = io.BytesIO()
    Image.fromarray(pictures.still).save(buf, format="PNG", optimize=True)
    _write(IMG / "machine.png", buf.getvalue())
    gif = iio.imwrite("<bytes>", pictures.frames, extension=".gif", duration=100, loop=0)
    _write(IMG / "cycle.gif", gif)
    outcome = result.per_seedling[0].outcome
    print(
        f"docs/img/machine.png ({STILL_SIZE[0]}x{STILL_SIZE[1]}, {len(buf.getvalue()) >> 10} "
        f"KiB) and docs/img/cycle.gif ({len(pictures.frames)} frames at {GIF_FPS:g} fps, "
        f"{len(gif) >> 10} KiB); seedling 0: {outcome}; {time.perf_counter() - t0:.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
