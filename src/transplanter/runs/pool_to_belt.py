"""The serial arm's run on the pool and belt (`[workcell] kind = "pool_to_belt"`, seed 004):
the paper's ten targets (Tables 3-5), its 18 gripper trials (Table 6) and the pick and place
of the pool's tomatoes (`transplanter.twin.serial_arm`), printed as tables beside the
paper's numbers; with `--seeds` the pick and place pooled. Its pick and place is filmed by
`viewing.serial_arm.SerialVideo` and recorded by `SerialRecording`."""

from __future__ import annotations

import math
from typing import Any

from transplanter.twin.serial_arm import (
    DEFINITIONS,
    PAPER_MEAN_ERRORS_CM,
    PAPER_MEAN_JOINT_ERRORS_PCT,
)

__all__ = [
    "DEFINITIONS", "FILMED", "REFUSED_OPTIONS", "UNIT",
    "check", "export", "filmer", "key_points",
    "format_tables", "line", "pool", "recorder", "row", "run",
    "study", "summary", "total", "viewer",
]  # fmt: skip

FILMED = "the pick and place"
UNIT = "tomato"
_WHOLE = "the serial arm's job has tomatoes, not seedlings or cells; it is filmed whole"
REFUSED_OPTIONS = {
    "--clips-of-failures": "--clips-of-failures: not available for the serial arm's trial "
    "(docs/serial_arm.md); film it: transplanter render SCENARIO --out run.mp4",
    "--eeprom": "--eeprom: not available for the serial arm's trial (docs/serial_arm.md): its "
    "host's program comes from the scenario",
    "--no-preflight": "--no-preflight: the serial arm's controller checks every point itself "
    "(docs/serial_arm.md); nothing to leave out",
    "--seedlings-of": f"render refused: --seedlings-of: {_WHOLE}",
    "--cells-of": f"render refused: --cells-of: {_WHOLE}",
}


def _num(v, fmt: str = "{:.2f}") -> str:
    return "-" if v is None else fmt.format(v)


def format_tables(r) -> str:
    """The ten-target table (the twin's reached point and errors beside the paper's) and the
    18-case gripper table, then the pick-and-place line."""
    out = [
        f"serial arm (seed {r.seed}): the paper's ten targets (cm, paper frame: x forward, "
        "y up, z sideways)",
        f"{'no':>2}  {'commanded':>14}  {'twin reached':>20}  {'paper measured':>16}  "
        f"{'twin error x y z':>20}  {'joints deg':>22}  {'joint err %':>18}",
    ]
    for i, row in enumerate(r.targets, 1):
        cmd = " ".join(f"{v:g}" for v in row.commanded_cm)
        got = " ".join(f"{v:.3f}" for v in row.reached_cm)
        paper = " ".join(f"{v:g}" for v in row.paper_reached_cm)
        err = " ".join(f"{v:.3f}" for v in row.error_cm)
        joints = " ".join(f"{v:.2f}" for v in row.joints_deg)
        pct = " ".join(_num(v) for v in row.joint_error_pct)
        out.append(f"{i:>2}  {cmd:>14}  {got:>20}  {paper:>16}  {err:>20}  {joints:>22}  {pct:>18}")
    mean = " ".join(_num(v, "{:.3f}") for v in r.mean_error_cm)
    pct = " ".join(_num(v) for v in r.mean_joint_error_pct)
    out.append(
        f"mean error per axis: twin {mean} cm, paper "
        + " ".join(f"{v:g}" for v in PAPER_MEAN_ERRORS_CM)
        + f" cm; per joint: twin {pct} %, paper "
        + " ".join(f"{v:g}" for v in PAPER_MEAN_JOINT_ERRORS_PCT)
        + " %"
    )
    out.append("")
    out.append("the paper's 18 gripper trials (Table 6): the controller's angle in its range")
    out.append(
        f"{'row':>3}  {'sensor 1':>13}  {'sensor 2 set':>12}  {'read':>6}  {'base deg':>8}  "
        f"{'angle deg':>9}  {'term':>6}  {'paper term':>10}  {'in range':>8}  {'reached':>7}"
    )
    for c in r.gripper_cases:
        s1 = "no echo" if c.sensor1_cm is None else f"{c.sensor1_cm:.2f} cm"
        s1 = f"{'Detected' if c.sensor1_detected else 'No det.'} {s1}"
        out.append(
            f"{c.row:>3}  {s1[:13]:>13}  {c.sensor2_set_cm:>9.2f} cm  {_num(c.sensor2_cm):>6}  "
            f"{c.base_deg:>8.1f}  {c.angle_deg:>9.2f}  {str(c.term):>6}  {c.expected_term:>10}  "
            f"{'yes' if c.in_range else 'NO':>8}  {c.gripper_deg:>7.2f}"
        )
    out.append(f"{r.cases_in_range}/{len(r.gripper_cases)} angles in the rule's range")
    out.append("")
    p = r.pick_totals
    if p:
        kinds = ", ".join(f"{k} {v}" for k, v in p["outcomes"].items()) or "none"
        out.append(
            f"pick and place: {p['successes']}/{p['picked']} tomatoes onto the belt ({kinds}); "
            f"cycle {p['cycle_time_s']:.2f} s, {p['tomatoes_per_hour']:g} tomatoes/h; peak "
            f"squeeze {p['peak_squeeze_n']:.2f} N"
        )
    for job, error in r.errors.items():
        out.append(f"{job}: {error}")
    return "\n".join(out)


def check(scenario) -> None:
    from transplanter.machine.servo_drives import frame_steps
    from transplanter.scenario.assemble import require_awake
    from transplanter.twin.serial_arm import require_own_motion

    frame_steps(scenario.physics.timestep_s)
    require_awake(scenario, "the serial arm's trial")
    require_own_motion(scenario, "the serial arm's trial")


def total(scenario) -> int:
    return scenario.pool_to_belt.count


def run(scenario, seed, *, progress=None, observers=()):
    """The three jobs (`twin.serial_arm.run_serial_arm`); one observer at most watches the
    pick and place (a SerialRecording or a SerialVideo)."""
    from transplanter.twin.serial_arm import run_serial_arm

    if len(observers) > 1:
        raise ValueError("the serial arm's pick and place takes one observer at a time")
    recording = observers[0] if observers else None
    return run_serial_arm(scenario, seed, recording=recording, progress=progress)


def line(r) -> str:
    p = r.pick_totals
    if not p:
        return f"seed {r.seed}: no pick and place" + "".join(
            f"; {job}: {error}" for job, error in r.errors.items()
        )
    kinds = ", ".join(f"{k} {v}" for k, v in p["outcomes"].items()) or "none"
    return (
        f"seed {r.seed}: {p['successes']}/{p['picked']} tomatoes onto the belt ({kinds}); "
        f"cycle {p['cycle_time_s']:.2f} s, {p['tomatoes_per_hour']:g} tomatoes/h; peak "
        f"squeeze {p['peak_squeeze_n']:.2f} N; wall {r.wall_s:.1f} s"
    )


summary = format_tables


def pool(results, pooled) -> tuple[dict[str, Any], list[str]]:
    from transplanter.runs import pooled_line

    cycles = [r.pick_totals.get("cycle_time_s", math.nan) for r in results]
    cycles = [c for c in cycles if math.isfinite(c)]
    mean = sum(cycles) / len(cycles) if cycles else None
    return {"mean_cycle_time_s": mean}, [pooled_line(pooled, "tomatoes onto the belt")]


def study(scenario) -> dict[str, Any]:
    from transplanter.runs import read_sections

    return {
        "kind": "pool_to_belt",
        "fields": ("peak_squeeze_n", "fail_bruised", "fail_dropped", "fail_missed"),
        "means": ("plants_per_hour", "peak_squeeze_n"),
        "sections": read_sections(scenario),
        "unit": "tomatoes",
        "more": "pool_to_belt.count x seeds",
        "damage": ("fail_bruised",),
    }


def row(scenario, seed: int, out: dict[str, Any]) -> None:
    """The pick and place alone as a study row: tomatoes on the belt over those picked."""
    import time

    from transplanter.machine.servo_drives import frame_steps
    from transplanter.runs import finite as _finite
    from transplanter.twin.motors import motor_columns
    from transplanter.twin.serial_arm import run_pick_place

    frame_steps(scenario.physics.timestep_s)  # ValueError: a refused setting
    t0 = time.perf_counter()
    records, totals, error, valid = run_pick_place(scenario, seed)
    picked = totals["picked"]
    cycle = totals["cycle_time_s"]
    out.update(
        successes=totals["successes"] if picked else None,
        seedlings=picked or None,
        success_rate=totals["success_rate"] if picked else None,
        cycle_time_s=_finite(cycle),
        cycle_time_sd_s=None,
        cycles=max(picked - 1, 0),
        valid=valid,
        fault=error,
        sim_time_s=max((r.end_s or 0.0 for r in records), default=0.0),
        wall_time_s=time.perf_counter() - t0,
        warnings="",
        plants_per_hour=_finite(totals["tomatoes_per_hour"]),
        peak_squeeze_n=totals["peak_squeeze_n"],
        **motor_columns(totals.get("motors")),
        **{f"fail_{k}": totals["outcomes"].get(k, 0) for k in ("bruised", "dropped", "missed")},
    )
    if not picked:
        out["error"] = "no tomato picked"
    elif not valid:
        out["error"] = "trial not valid: MuJoCo warned"
    elif error:
        out["error"] = f"fault: {error}"


def recorder(scenario, path, rate_hz: float):
    from transplanter.viewing.serial_arm import SerialRecording

    return SerialRecording(path, rate_hz)


def filmer(scenario, target, size, fps, camera, shadows, subset):
    """A SerialVideo of the pick and place, its camera and frames checked in the job's
    scene before the trial runs (video.RenderRefused, video.GLUnavailable)."""
    from transplanter.twin.serial_arm import _compile, _scene
    from transplanter.viewing import video
    from transplanter.viewing.serial_arm import SerialVideo

    observer = SerialVideo(target, *size, fps, camera, shadows)
    spec, cfg = _scene(scenario, "pool_to_belt", tomatoes=0)
    model, _ = _compile(spec, cfg)
    video.check_frames(*size, fps, model.opt.timestep)
    video.FrameGrabber(model, *size, camera).close()
    return observer


def viewer(scenario, speed: float):
    from transplanter.scenario.schema import ScenarioError

    raise ScenarioError(
        "the serial arm's pool and belt have no live view yet: film them instead, "
        "transplanter render SCENARIO --out arm.mp4, or record them with trial --record "
        "arm.rrd and open it with transplanter replay"
    )


def export(scenario, target):
    """The pick and place's scene (the arm, its gripper, the pool's tomatoes and the belt),
    meshes in assets/ beside it; the targets' and the bench's scenes are this arm alone."""
    from transplanter.scene.effectors import fuzzy_gripper
    from transplanter.scene.export import export_spec
    from transplanter.twin.serial_arm import _scene

    check(scenario)
    spec, _ = _scene(scenario, "pool_to_belt", seed=scenario.seed)
    return export_spec(spec, target, mount=fuzzy_gripper.MOUNT)


def key_points(scenario) -> dict[str, Any]:
    """The pool's and belt's key points (`scenario.reach`; workcell frame, m): a middle
    tomato's centre at the pool's station and over the belt where it is released, and a
    largest tomato's diameter above each."""
    import numpy as np

    from transplanter.scene.workcells import pool_to_belt

    wc = pool_to_belt.pool_config(scenario)
    up = np.array([0.0, 0.0, wc.diameter_max_m])
    station = np.asarray(pool_to_belt.station_xyz(wc), dtype=np.float64)
    place = np.asarray(pool_to_belt.place_xyz(wc), dtype=np.float64)
    return {
        "the pool's station": station,
        "above the station": station + up,
        "the release over the belt": place,
        "above the release": place + up,
    }
