"""Videos of a trial: MuJoCo's offscreen renderer sampled on simulated time, encoded to MP4.

Two trial observers (`transplanter.twin.trial.TrialObserver`) read the twin after every physics
step and render only at frame times (a grid of 1/fps s of simulated time), so the physics is
never touched and a trial gives the same results with or without them:

- `VideoObserver` writes one MP4 of the trial (`transplanter render`), all of it or only the
  cycles of chosen seedlings;
- `FailureClips` keeps the frames of the seedling in progress (and of the last one until its
  verdict, which comes when the next approach is acknowledged) and writes a clip of each
  seedling judged a failure (`transplanter trial --clips-of-failures DIR`).

A seedling's cycle runs from its first line (`t_start_s`) to the end of its release dwell
(`t_release_s`) plus `CYCLE_TAIL_S`, so the pot is seen falling. Encoding needs the optional
`video` extra (imageio + imageio-ffmpeg); nothing here imports it, or MuJoCo's renderer, until
a video is asked for. `prepare_gl()` must run before MuJoCo is imported: it picks EGL for a
headless machine.
"""

from __future__ import annotations

import math
import os
import sys
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from transplanter import fileio
from transplanter.errors import TransplanterError
from transplanter.twin.results import Outcome, SeedlingRecord

__all__ = [
    "CYCLE_TAIL_S",
    "DEFAULT_CAMERA",
    "ClipInfo",
    "FailureClips",
    "FrameGrabber",
    "GLUnavailable",
    "Mp4Writer",
    "RenderRefused",
    "VideoObserver",
    "VideoUnavailable",
    "cycle_window",
    "has_display",
    "parse_indices",
    "parse_size",
    "prepare_gl",
    "require_imageio",
]

DEFAULT_CAMERA = "overview"
CYCLE_TAIL_S = 0.5  # s of a cycle shown after the release dwell (the pot falling)
MAX_FPS = 240.0
MAX_SIDE_PX = 4096
# Frames one failure clip keeps in memory (a rolling buffer: the oldest go first); at the
# default 320x240 this is over half a minute of a 15 fps clip, about nine paper cycles.
CLIP_BUFFER_BYTES = 128 << 20
INSTALL_HINT = "pip install 'transplanter[video]'"


class VideoUnavailable(TransplanterError, RuntimeError):
    """The optional video extra (imageio, imageio-ffmpeg) is not installed."""


class GLUnavailable(TransplanterError, RuntimeError):
    """No OpenGL context could be made for offscreen rendering."""


class RenderRefused(TransplanterError, ValueError):
    """A frame size, rate, camera or seedling list that cannot be used; says why."""


def has_display() -> bool:
    """Whether a window can open here (always assumed off Linux)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def prepare_gl() -> None:
    """Headless (MUJOCO_GL unset, no display), choose the offscreen backend this machine
    has: EGL (a GPU's or Mesa's) where libEGL is installed, else OSMesa where it is, else
    leave MuJoCo's default (a picture-taking job then refuses, naming both). MuJoCo reads
    MUJOCO_GL when it is first imported, so the command line calls this before that, for
    every command: `trial delta_refill` photographs its trays headless as `render` films."""
    if os.environ.get("MUJOCO_GL") or has_display():
        return
    import ctypes.util

    for backend, library in (("egl", "EGL"), ("osmesa", "OSMesa")):
        if ctypes.util.find_library(library) is not None:
            os.environ["MUJOCO_GL"] = backend
            return


def require_imageio() -> Any:
    """imageio-ffmpeg (the encoder and its ffmpeg binary), or VideoUnavailable saying what to
    install. imageio itself, the other half of the extra, reads videos and writes GIFs."""
    try:
        import imageio  # noqa: F401
        import imageio_ffmpeg
    except ImportError as exc:
        raise VideoUnavailable(
            f"writing video needs the optional video extra ({exc.name} is missing): {INSTALL_HINT}"
        ) from None
    return imageio_ffmpeg


def parse_size(text: str) -> tuple[int, int]:
    """'320x240' -> (320, 240); RenderRefused naming the problem."""
    w, x, h = text.lower().partition("x")
    if not (x and w.isascii() and h.isascii() and w.isdigit() and h.isdigit()):
        raise RenderRefused(f"{text!r}: write the size as WIDTHxHEIGHT in pixels, e.g. 320x240")
    return int(w), int(h)


def parse_indices(text: str, count: int) -> set[int]:
    """'23,24' or '3-5,9' -> seedling indices (0-based, as in the results), each below count;
    RenderRefused naming the bad part."""
    out: set[int] = set()
    for part in text.split(","):
        lo, dash, hi = part.strip().partition("-")
        if not (lo.isascii() and lo.isdigit()) or (dash and not (hi.isascii() and hi.isdigit())):
            raise RenderRefused(f"{text!r}: {part.strip()!r} is not N or N-M (seedling indices)")
        a, b = int(lo), int(hi) if dash else int(lo)
        if b < a:
            raise RenderRefused(f"{text!r}: {part.strip()!r} runs backwards")
        if b >= count:
            raise RenderRefused(
                f"{text!r}: seedling {b} is not in this trial (its seedlings are 0-{count - 1}; "
                "give --seedlings N for more)"
            )
        out.update(range(a, b + 1))
    return out


def check_frames(width: int, height: int, fps: float, timestep_s: float | None = None) -> None:
    """RenderRefused naming the problem for a frame size or rate that cannot be encoded."""
    for name, side in (("width", width), ("height", height)):
        if not 16 <= side <= MAX_SIDE_PX or side % 2:
            raise RenderRefused(
                f"{name} {side} px: give an even number from 16 to {MAX_SIDE_PX} "
                "(H.264 in yuv420p needs even sides)"
            )
    if not (math.isfinite(fps) and 0 < fps <= MAX_FPS):
        raise RenderRefused(f"fps {fps}: give a frame rate above 0 and at most {MAX_FPS:g}")
    if timestep_s is not None and fps * timestep_s > 1.0 + 1e-9:
        raise RenderRefused(
            f"fps {fps:g}: frames are taken at physics steps ({timestep_s:g} s), so at most "
            f"{1.0 / timestep_s:g} frames per second"
        )


def cycle_window(
    records: list[SeedlingRecord], index: int, tail_s: float = CYCLE_TAIL_S
) -> tuple[float | None, float | None]:
    """(start, end) of a seedling's cycle in simulated s: from its first line to its release
    dwell's end plus tail_s; a cycle never released ends where the next one starts. None
    where not known yet."""
    rec = records[index]
    if rec.t_start_s is None:
        return None, None
    if rec.t_release_s is not None:
        return rec.t_start_s, rec.t_release_s + tail_s
    if index + 1 < len(records) and records[index + 1].t_start_s is not None:
        return rec.t_start_s, records[index + 1].t_start_s
    return rec.t_start_s, None


def _in_window(window: tuple[float | None, float | None], t: float) -> bool:
    start, end = window
    return start is not None and t >= start - 1e-9 and (end is None or t <= end + 1e-9)


class FrameGrabber:
    """Renders a named camera of a model offscreen (MuJoCo's `Renderer`) into RGB arrays."""

    def __init__(
        self, model: Any, width: int, height: int, camera: str, shadows: bool = False
    ) -> None:
        import mujoco

        cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
        if cam < 0:
            names = [model.camera(i).name for i in range(model.ncam)]
            raise RenderRefused(f"no camera {camera!r} in the model; named cameras: {names}")
        self.camera = cam
        # The offscreen buffer is only drawn into: enlarging it changes no physics.
        vis = model.vis.global_
        vis.offwidth, vis.offheight = max(vis.offwidth, width), max(vis.offheight, height)
        from transplanter.scene import offscreen

        try:
            self.renderer = offscreen.renderer(model, height, width)
        except offscreen.NoOffscreenGL as exc:
            raise GLUnavailable(
                f"{exc}. Headless, use MUJOCO_GL=egl (needs libEGL: a GPU driver or Mesa's "
                "libegl1) or MUJOCO_GL=osmesa (libosmesa6); on a desktop, run with a display."
            ) from None
        self.option = mujoco.MjvOption()  # MuJoCo's defaults; an observer may show more groups
        flags = self.renderer.scene.flags
        # Shadows and reflections cost about 4x with software GL (Mesa llvmpipe).
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = shadows

    def grab(self, data: Any) -> np.ndarray:
        """The camera's view of the current state, (height, width, 3) uint8 (a new array)."""
        self.renderer.update_scene(data, camera=self.camera, scene_option=self.option)
        return self.renderer.render()

    def close(self) -> None:
        self.renderer.close()


_FONTS: dict[int, Any] = {}


def _font(size: int) -> Any:
    from PIL import ImageFont

    if size not in _FONTS:
        try:
            _FONTS[size] = ImageFont.load_default(size=size)
        except (TypeError, OSError, ImportError):  # Pillow without FreeType: the bitmap font
            _FONTS[size] = ImageFont.load_default()
    return _FONTS[size]


def annotate(frame: np.ndarray, lines: list[str]) -> np.ndarray:
    """The frame with lines of white, dark-outlined text in its top-left corner."""
    from PIL import Image, ImageDraw

    image = Image.fromarray(frame)
    size = max(9, frame.shape[0] // 18)
    draw = ImageDraw.Draw(image)
    draw.multiline_text(
        (max(2, size // 3), max(1, size // 4)),
        "\n".join(lines),
        font=_font(size),
        fill=(255, 255, 255),
        stroke_width=max(1, size // 10),
        stroke_fill=(0, 0, 0),
        spacing=max(1, size // 5),
    )
    return np.asarray(image)


class Mp4Writer:
    """An H.264 MP4 written atomically: frames go to a temporary file beside the target,
    which `commit` moves into place; `discard` (or any failure) leaves no file behind. A
    symlink at the target is written through (`follow`: the user's name) or replaced itself
    (a name the program derives: a failure clip's)."""

    def __init__(
        self, target: Path, size: tuple[int, int], fps: float, ffmpeg: Any, follow: bool = True
    ) -> None:
        self.target, self.size, self.fps, self.frames = Path(target), size, fps, 0
        self.follow = follow
        self.tmp = fileio.temp_beside(self.target)
        try:
            self._gen = ffmpeg.write_frames(
                str(self.tmp),
                size,  # (width, height)
                fps=fps,
                codec="libx264",
                pix_fmt_out="yuv420p",
                macro_block_size=1,  # sizes are checked even; never rescale
                ffmpeg_log_level="error",
                output_params=["-f", "mp4"],  # the temporary name has no .mp4 suffix
            )
            self._gen.send(None)  # starts ffmpeg
        except BaseException:
            fileio.discard(self.tmp)
            raise

    def append(self, frame: np.ndarray) -> None:
        self._gen.send(np.ascontiguousarray(frame))
        self.frames += 1

    def commit(self) -> Path:
        try:
            self._gen.close()  # waits for ffmpeg to finish the file
        except BaseException:
            fileio.discard(self.tmp)
            raise
        fileio.commit(self.tmp, self.target, follow=self.follow)
        return self.target

    def discard(self) -> None:
        try:
            self._gen.close()
        except Exception:  # the file is thrown away anyway
            pass
        fileio.discard(self.tmp)


class _FrameClock:
    """Frame k is taken at the first physics step at or after k / fps s of simulated time."""

    def __init__(self, fps: float) -> None:
        self.fps, self.k = fps, 0

    def due(self, t: float) -> bool:
        if t + 1e-9 < self.k / self.fps:
            return False
        self.k = math.floor(t * self.fps + 1e-9) + 1
        return True


class Mp4Output:
    """The end of a video observer's life, shared by the trials' videos: `grabber`,
    `writer`, `target`, `error` and `path` are the observer's."""

    grabber: Any
    writer: Any
    target: Path
    error: str | None
    path: Path | None

    def _setup(
        self, target: str | os.PathLike, width: int, height: int, fps: float, camera: str,
        shadows: bool,
    ) -> None:  # fmt: skip
        """The state every video observer starts with: the encoder checked, the frame size,
        rate and clock, the camera, nothing filmed yet."""
        self.ffmpeg = require_imageio()
        self.target, self.size, self.fps = Path(target), (width, height), float(fps)
        self.camera, self.shadows = camera, shadows
        self.clock = _FrameClock(self.fps)
        self.grabber = None
        self.writer = None
        self.error = None
        self.path = None  # the video, once written
        self.render_s = 0.0  # wall time spent rendering and encoding

    @property
    def frames(self) -> int:
        return self.writer.frames if self.writer is not None else 0

    def _close(self, interrupted: bool, nothing_filmed: str) -> None:
        """Commit the video, or discard it (interrupted, or no frame: `error` then says
        `nothing_filmed`); a write that fails is the `error`."""
        if self.grabber is not None:
            self.grabber.close()
        if self.error is not None or self.writer is None:
            return
        if interrupted:
            self.writer.discard()
            return
        if self.writer.frames == 0:
            self.writer.discard()
            self.error = f"no frame was filmed: {nothing_filmed}"
            return
        try:
            self.path = self.writer.commit()
        except Exception as exc:
            self.error = f"the video could not be written to {self.target}: {exc}"

    def abort(self) -> None:
        if self.writer is not None:
            self.writer.discard()
        if self.grabber is not None:
            self.grabber.close()


class VideoObserver(Mp4Output):
    """Writes the trial (or only the cycles of `seedlings`) to an MP4 (`transplanter render`).

    Frames carry the simulated time, the seedling in progress and the last verdict."""

    def __init__(
        self,
        target: Path,
        width: int,
        height: int,
        fps: float,
        camera: str = DEFAULT_CAMERA,
        seedlings: set[int] | None = None,
        shadows: bool = False,
    ) -> None:
        self._setup(target, width, height, fps, camera, shadows)
        self.seedlings = seedlings
        self.records: list[SeedlingRecord] = []
        self.latest: int | None = None  # the last seedling whose cycle started
        self.judged = 0  # records[:judged] all have a verdict

    def attach(self, twin: Any, records: list[SeedlingRecord]) -> None:
        check_frames(*self.size, self.fps, twin.dt)
        self.records = records
        self.grabber = FrameGrabber(twin.scene.render_model, *self.size, self.camera, self.shadows)
        self.writer = Mp4Writer(self.target, self.size, self.fps, self.ffmpeg)
        twin.line_listeners.append(self._on_line)
        self.step(twin)  # the power-on state at t = 0

    def _on_line(self, event: Any) -> None:
        s = event.line.seedling
        if s is not None and (self.latest is None or s > self.latest):
            self.latest = s

    def _wanted(self, t: float) -> bool:
        if self.seedlings is None:
            return True
        return any(_in_window(cycle_window(self.records, s), t) for s in self.seedlings)

    def _caption(self, t: float) -> list[str]:
        recs = self.records
        while self.judged < len(recs) and recs[self.judged].outcome != Outcome.PENDING:
            self.judged += 1
        lines = [f"t = {t:7.3f} s"]
        if self.latest is not None and _in_window(cycle_window(recs, self.latest), t):
            lines.append(f"seedling {self.latest}")
        else:
            lines.append("between cycles" if self.latest is not None else "homing")
        if self.judged:
            last = recs[self.judged - 1]
            lines.append(f"seedling {last.index}: {last.outcome}")
        return lines

    def step(self, twin: Any) -> None:
        t = twin.time
        if self.error is not None or not self.clock.due(t) or not self._wanted(t):
            return
        import time

        t0 = time.perf_counter()
        try:
            frame = annotate(self.grabber.grab(twin.scene.render_data(twin.data)), self._caption(t))
            self.writer.append(frame)
        except Exception as exc:  # an encoder that died (disk full): the trial goes on
            self.error = f"the video could not be encoded: {exc}"
            self.writer.discard()
        self.render_s += time.perf_counter() - t0

    def finish(self, twin: Any, interrupted: bool) -> None:
        chosen = ", ".join(str(s) for s in sorted(self.seedlings or ()))
        self._close(interrupted, f"seedlings {chosen} never started a cycle")


@dataclass
class ClipInfo:
    """A failure clip that was written."""

    seedling: int
    outcome: str
    path: str
    frames: int
    t_start_s: float
    t_end_s: float
    dropped_frames: int = 0  # the oldest frames the rolling buffer let go (a long cycle)


class FailureClips:
    """Writes `DIR/seedling_023_not_gripped.mp4` for each seedling judged a failure.

    Frames are rendered only inside a cycle and kept in a rolling buffer per seedling
    (at most CLIP_BUFFER_BYTES each; the cycle in progress and the finished one awaiting
    its verdict); success clips are dropped unwritten."""

    def __init__(
        self,
        directory: Path,
        width: int = 320,
        height: int = 240,
        fps: float = 15.0,
        camera: str = DEFAULT_CAMERA,
    ) -> None:
        self.ffmpeg = require_imageio()
        self.dir, self.size, self.fps, self.camera = Path(directory), (width, height), fps, camera
        self.clock = _FrameClock(fps)
        self.grabber: FrameGrabber | None = None
        self.records: list[SeedlingRecord] = []
        self.latest: int | None = None
        self.buffers: dict[int, deque[tuple[float, np.ndarray]]] = {}
        self.dropped: dict[int, int] = {}
        self.closed: set[int] = set()  # cycles whose frames are complete
        self.maxlen = max(2, CLIP_BUFFER_BYTES // (width * height * 3))
        self.clips: list[ClipInfo] = []
        self.error: str | None = None
        self.render_s = 0.0

    def attach(self, twin: Any, records: list[SeedlingRecord]) -> None:
        check_frames(*self.size, self.fps, twin.dt)
        self.records = records
        self.grabber = FrameGrabber(twin.scene.render_model, *self.size, self.camera)
        twin.line_listeners.append(self._on_line)

    def _on_line(self, event: Any) -> None:
        s = event.line.seedling
        if s is not None and (self.latest is None or s > self.latest):
            self.latest = s
        self._settle(event.t, final=False)

    def step(self, twin: Any) -> None:
        t = twin.time
        if self.latest is None or self.error is not None or not self.clock.due(t):
            return
        wanted = [
            s
            for s in {*self.buffers, self.latest}
            if s not in self.closed and _in_window(cycle_window(self.records, s), t)
        ]
        if not wanted:
            return
        import time

        t0 = time.perf_counter()
        frame = self.grabber.grab(twin.scene.render_data(twin.data))
        for s in wanted:
            buf = self.buffers.setdefault(s, deque(maxlen=self.maxlen))
            if len(buf) == buf.maxlen:
                self.dropped[s] = self.dropped.get(s, 0) + 1
            buf.append((t, frame))
        self.render_s += time.perf_counter() - t0

    def _settle(self, t: float, final: bool) -> None:
        """Close the cycles that have ended; write the judged failures, drop the rest."""
        for s in list(self.buffers):
            _, end = cycle_window(self.records, s)
            if not final and (end is None or t <= end):
                continue
            self.closed.add(s)
            outcome = self.records[s].outcome
            if outcome == Outcome.PENDING:
                continue  # its verdict comes when the next approach is acknowledged
            frames = self.buffers.pop(s)
            if outcome != Outcome.SUCCESS and self.error is None:
                self._write(s, outcome, frames)

    def _write(self, s: int, outcome: Outcome, frames: deque[tuple[float, np.ndarray]]) -> None:
        import time

        t0 = time.perf_counter()
        target = self.dir / f"seedling_{s:03d}_{outcome}.mp4"
        writer = None
        try:
            writer = Mp4Writer(target, self.size, self.fps, self.ffmpeg, follow=False)
            for t, frame in frames:
                writer.append(annotate(frame, [f"t = {t:7.3f} s", f"seedling {s}: {outcome}"]))
            writer.commit()
        except Exception as exc:
            if writer is not None:
                writer.discard()
            self.error = f"the clip {target} could not be written: {exc}"
            return
        finally:
            self.render_s += time.perf_counter() - t0
        self.clips.append(
            ClipInfo(s, str(outcome), str(target), len(frames), frames[0][0], frames[-1][0],
                     self.dropped.get(s, 0))
        )  # fmt: skip

    def finish(self, twin: Any, interrupted: bool) -> None:
        if self.grabber is not None:
            self.grabber.close()
        if interrupted:  # the cycles not judged yet have no verdict: no clip
            self.buffers.clear()
            return
        self._settle(twin.time, final=True)
        self.buffers.clear()

    def abort(self) -> None:
        self.buffers.clear()
        if self.grabber is not None:
            self.grabber.close()
