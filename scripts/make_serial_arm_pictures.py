"""Render the serial arm's pictures of docs/serial_arm.md from the serial_arm scenario
(re-runnable).

Run: .venv/bin/python scripts/make_serial_arm_pictures.py   (needs pip install -e ".[video]")

The pick and place of two tomatoes of the pool (seed 1, pool_to_belt.count = 2) runs through
the trial's own chain (twin.serial_arm.run_pick_place: host, bus, SGF, the 50 Hz servo
outputs, the servos, MuJoCo) with an observer of the rig (viewing.serial_arm's protocol)
that only reads its state:
- docs/img/serial_arm.png: a still at 640x480 from the `overview` camera, the first tomato
  lifted HOLD_LIFT_M above where it rested at the station;
- docs/img/serial_arm.gif: the first tomato's cycle (its pick's start to its end) from the
  `overview` camera, rendered at 640x480 and downscaled to 480x360, a frame every
  GIF_STEP_S of simulated time played at GIF_FPS fps, with the time, the controller's
  decision and the squeeze;
- docs/img/serial_arm_cycle.png: theta4 over both cycles: the gripper's commanded angle
  (the M280 lines), the gripper servo's shaft and the fingers' opening, the phases shaded
  (standby: the controller's Big for an empty gripper; gripping: its Small for a tomato
  between both sensors) over the paper's term ranges, and the pads' squeeze on a second axis.
Headless, MUJOCO_GL=egl is used unless MUJOCO_GL is set. The files are written atomically.
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
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from transplanter import fileio  # noqa: E402
from transplanter.machine.fuzzy_gripper import OUTPUT_RANGES_DEG  # noqa: E402
from transplanter.scenario.schema import load_scenario  # noqa: E402
from transplanter.twin.serial_arm import run_pick_place  # noqa: E402

IMG = Path(__file__).resolve().parent.parent / "docs" / "img"
SEED, TOMATOES = 1, 2
STILL_SIZE = (640, 480)
GIF_SIZE, GIF_STEP_S, GIF_FPS = (480, 360), 0.2, 10.0
HOLD_LIFT_M = 0.03
SAMPLE_S = 0.01


class _Pictures:
    """The still, the GIF's frames over the first cycle and the plot's samples."""

    def __init__(self) -> None:
        self.error: str | None = None
        self.fuzzy_deg, self.squeeze_n = math.nan, 0.0
        self.tomato: int | None = None
        self.decision = ""
        self.still: np.ndarray | None = None
        self.frames: list[np.ndarray] = []
        self.samples: list[tuple[float, float, float, float, float]] = []

    def attach(self, rig) -> None:
        self.rig = rig
        self.grabber = video.FrameGrabber(rig.model, *STILL_SIZE, "overview")
        self.grabber.option.geomgroup[3] = 1  # the lane and the belt
        self.body = rig.model.body("tomato00").id
        self.rest_z = float(rig.data.xpos[self.body][2])
        self.next_frame = 0.0
        self.next_sample = 0.0

    def look(self, t: float) -> None:
        rig = self.rig
        if t >= self.next_sample:
            self.next_sample += SAMPLE_S
            cmd = math.degrees(rig.outputs.gripper_rad)
            servo = math.degrees(float(rig.bank.shafts()[3]))
            self.samples.append((t, cmd, servo, rig.gripper_deg(), self.squeeze_n))
        z = float(rig.data.xpos[self.body][2])
        if self.still is None and self.tomato == 0 and z > self.rest_z + HOLD_LIFT_M:
            self.still = self.grabber.grab(rig.data)
        if self.tomato != 0 or t < self.next_frame:
            return
        self.next_frame = t + GIF_STEP_S
        frame = Image.fromarray(self.grabber.grab(rig.data)).resize(GIF_SIZE, Image.LANCZOS)
        inputs, _, output = self.decision.partition(" -> ")
        lines = [f"t = {t:5.2f} s   tomato 0"]
        if output:
            lines += [inputs.replace("sensor ", "S"), f"-> {output}"]
        lines.append(f"squeeze {self.squeeze_n:4.1f} N")
        self.frames.append(video.annotate(np.asarray(frame), lines))

    def event(self, t: float, kind: str, text: str) -> None:
        if kind == "controller":
            self.decision = text.split(": ", 1)[-1]

    def finish(self, t: float) -> None:
        self.grabber.close()


def _write(path: Path, data: bytes) -> None:
    tmp = fileio.temp_beside(path)
    try:
        tmp.write_bytes(data)
    except BaseException:
        fileio.discard(tmp)
        raise
    fileio.commit(tmp, path)


def _plot(samples, records) -> bytes:
    t, cmd, servo, fingers, squeeze = np.array(samples).T
    fig, ax = plt.subplots(figsize=(9, 4.2), dpi=110)
    colours = {"small": "#4c9be8", "medium": "#9bd18b", "big": "#f2b35e"}
    for term, (lo, hi) in OUTPUT_RANGES_DEG.items():
        ax.axhspan(lo, hi, color=colours.get(term, "0.8"), alpha=0.18, lw=0)
        ax.text(t[0] + 0.1, (lo + hi) / 2, f"{term.capitalize()} {lo:g}-{hi:g} deg",
                va="center", fontsize=8, color="0.3")  # fmt: skip
    gripping = cmd < OUTPUT_RANGES_DEG["big"][0]
    edges = np.flatnonzero(np.diff(gripping.astype(int)))
    bounds = [0, *(edges + 1), len(t)]
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        if gripping[a]:
            ax.axvspan(t[a], t[b - 1], color="0.5", alpha=0.12, lw=0)
            ax.text((t[a] + t[b - 1]) / 2, 62, "gripping", ha="center", fontsize=8)
        else:
            ax.text((t[a] + t[b - 1]) / 2, 62, "standby", ha="center", fontsize=8)
    ax.plot(t, cmd, color="k", lw=1.4, label="commanded theta4 (M280)")
    ax.plot(t, servo, color="tab:purple", lw=1.0, ls="--", label="gripper servo shaft")
    ax.plot(t, fingers, color="tab:red", lw=1.2, label="fingers' opening")
    ax.set_xlim(t[0], t[-1])
    ax.set_ylim(0, 66)
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel("theta4 (deg)")
    ax2 = ax.twinx()
    ax2.plot(t, squeeze, color="tab:green", lw=1.0, alpha=0.8, label="squeeze (one pad)")
    ax2.set_ylabel("squeeze (N)", color="tab:green")
    ax2.set_ylim(0, max(25.0, float(squeeze.max()) * 1.3))
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, loc="lower left", fontsize=8, framealpha=0.9)
    picks = ", ".join(f"tomato {r.index}: {r.grip_deg:.1f} deg ({r.grip_term}), {r.outcome}"
                      for r in records if r.grip_deg is not None)  # fmt: skip
    ax.set_title(f"theta4 through {len(records)} pick-and-place cycles (seed {SEED}): {picks}",
                 fontsize=9)  # fmt: skip
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


def main() -> int:
    scenario = load_scenario("serial_arm", {"pool_to_belt.count": TOMATOES})
    pictures = _Pictures()
    t0 = time.perf_counter()
    records, totals, error, valid = run_pick_place(scenario, SEED, pictures)
    if error is not None or pictures.still is None or not pictures.frames:
        print(f"the job did not lift its tomato ({error}): no pictures written", file=sys.stderr)
        return 1
    buf = io.BytesIO()
    Image.fromarray(pictures.still).save(buf, format="PNG", optimize=True)
    _write(IMG / "serial_arm.png", buf.getvalue())
    gif = iio.imwrite("<bytes>", pictures.frames, extension=".gif", duration=1000 / GIF_FPS, loop=0)
    _write(IMG / "serial_arm.gif", gif)
    plot = _plot(pictures.samples, records)
    _write(IMG / "serial_arm_cycle.png", plot)
    print(
        f"docs/img/serial_arm.png ({len(buf.getvalue()) >> 10} KiB), docs/img/serial_arm.gif "
        f"({len(pictures.frames)} frames at {GIF_FPS:g} fps, {len(gif) >> 10} KiB), "
        f"docs/img/serial_arm_cycle.png ({len(plot) >> 10} KiB); {totals['outcomes']}, valid "
        f"{valid}; {time.perf_counter() - t0:.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
