"""The pot line's run (`[workcell] kind = "conveyor_tube"`) for every robot whose host program
its job kind names (`JobKind.runner`: the robot's module, with its `check`, `scene_spec` and the
trial function): the pots picked row by row into the drop tube and judged seedling by
seedling by the pot line's judge (`transplanter.twin.pot_job`). The five-bar's PGF runs as
the twin's own trial (`transplanter.twin.trial`)."""

from __future__ import annotations

import importlib
import math
from typing import Any

from transplanter.twin.pot_job import DEFINITIONS
from transplanter.twin.results import DAMAGE_FIELDS

__all__ = [
    "DEFINITIONS", "FILMED", "REFUSED_OPTIONS", "UNIT",
    "check", "export", "filmer", "key_points",
    "line", "pool", "recorder", "row", "run", "study", "summary",
    "total", "viewer",
]  # fmt: skip

FILMED = "the pot job"
UNIT = "seedling"
REFUSED_OPTIONS = {
    "--clips-of-failures": "--clips-of-failures: not available for this robot's pot job "
    "(film it: transplanter render SCENARIO --out run.mp4)",
    "--eeprom": "--eeprom: an EEPROM image holds the five-bar's taught cycle; this robot's "
    "host program comes from the scenario (docs/compare.md)",
    "--no-preflight": "--no-preflight: this robot's pot job checks its placement before any "
    "step and has no taught points to leave unchecked",
    "--seedlings-of": "render refused: --seedlings-of: a pot job on the pot line is filmed "
    "whole; give --seedlings to film fewer",
    "--cells-of": "render refused: --cells-of: a pot job on the pot line is filmed whole; give "
    "--seedlings to film fewer",
}

POT_FIELDS = ("peak_squeeze_n",)
"""The pot jobs' own column beside the five-bar's trial row."""
POT_LINE_DAMAGE = DAMAGE_FIELDS  # the pot line judge's damaged seedlings (twin.results)


def _robot(scenario) -> tuple[Any, Any]:
    """(the robot's module, its trial function) from the job kind's runner."""
    from transplanter import kinds

    name = kinds.job(scenario.workcell.kind).runner(scenario.robot.kind)
    module_name, _, function = name.partition(":")
    module = importlib.import_module(module_name)
    return module, getattr(module, function)


def check(scenario) -> None:
    _robot(scenario)[0].check(scenario)


def total(scenario) -> int:
    return scenario.meta.seedlings


def run(scenario, seed, *, progress=None, observers=()):
    return _robot(scenario)[1](scenario, seed, progress=progress, observers=observers)


def line(r) -> str:
    """One pot job's result in a line (`twin.pot_job.PotJobResult`, any robot's)."""
    d = r.to_dict()
    kinds = ", ".join(f"{k} {v}" for k, v in d["outcomes"].items())
    cycle = "-" if not math.isfinite(r.cycle_time_s) else f"{r.cycle_time_s:.3f} s"
    planner = f", {d['planner']}" if "planner" in d else ""
    rate = "-" if d["plants_per_hour"] is None else f"{d['plants_per_hour']:.0f}"
    out = (
        f"{r.trial} (seed {r.seed}{planner}): {r.successes}/{r.seedlings} seedlings into the "
        f"tube ({100 * d['success_rate']:.1f} %; {kinds}); cycle {cycle}, "
        f"{rate} plants/h; largest shoot bend "
        f"{d['max_stem_bend_deg']:.1f} deg; peak squeeze {d['peak_squeeze_n']:.2f} N; "
        f"{r.sim_time_s:.1f} s simulated in {r.wall_s:.1f} s"
    )
    if r.fault:
        out += f"\n  fault: {r.fault}"
    return out


def summary(r) -> str:
    """The pot line's summary (as the five-bar's), then the run's line."""
    from transplanter.twin.report import format_summary

    return f"{format_summary(r)}\n{line(r)}"


def pool(results, pooled) -> tuple[dict[str, Any], list[str]]:
    from transplanter.runs import pooled_line

    cycles = [r.cycle_time_s for r in results if math.isfinite(r.cycle_time_s)]
    mean = sum(cycles) / len(cycles) if cycles else None
    return {"mean_cycle_time_s": mean}, [pooled_line(pooled, "seedlings into the tube")]


def study(scenario) -> dict[str, Any]:
    from transplanter.runs import read_sections

    return {
        "kind": f"{scenario.robot.kind}:{scenario.workcell.kind}",
        "fields": POT_FIELDS,
        "means": ("plants_per_hour", "peak_squeeze_n"),
        "sections": read_sections(scenario),
        "damage": POT_LINE_DAMAGE,
    }


def row(scenario, seed: int, out: dict[str, Any]) -> None:
    """A pot job's result as the five-bar's trial row (`studies.jobs.trial_row`'s columns),
    with the gripper's peak squeeze."""
    from transplanter.twin.results import trial_row

    r = run(scenario, seed)
    trial_row(r, out)
    out["peak_squeeze_n"] = round(r.peak_squeeze_n, 4)


def recorder(scenario, path, rate_hz: float):
    from transplanter.viewing.loop_recording import LoopRecording

    return LoopRecording(path, rate_hz)


def filmer(scenario, target, size, fps, camera, shadows, subset):
    from transplanter.viewing.loop_video import LoopVideo

    return LoopVideo(target, *size, fps, camera, shadows)


def viewer(scenario, speed: float):
    from transplanter.viewing.loop_live import LoopLiveViewer

    return LoopLiveViewer(speed)


def export(scenario, target):
    """The scene the robot's trial builds for the scenario's seed (its module's `scene_spec`),
    with the pots' decor, meshes in assets/ beside it; the effector's classes renamed at its
    mount (`scene.export.export_spec`)."""
    from transplanter import kinds
    from transplanter.scene.export import export_spec

    module = _robot(scenario)[0]
    module.check(scenario)
    spec = module.scene_spec(scenario, scenario.seed, decor=True)[0]
    scene = importlib.import_module(kinds.effector(scenario.effector.kind).SCENE)
    return export_spec(spec, target, mount=scene.MOUNT)


KEY_LIFT_M = 0.010
"""How far above a pot's top the key points over the cells and the tube lie (the tool clears
the neighbouring pots and the funnel's rim)."""


def key_points(scenario) -> dict[str, Any]:
    """The pot line's key points (`scenario.reach`; workcell frame, m): each pickup cell's
    pot at its mid-height and the point a pot's height above it, the funnel's centre a half
    pot above its rim and the point a pot's height above that: where any robot on the line
    must take its tool, whatever its grasp."""
    import numpy as np

    from transplanter.scene.geometry import cell_columns_x
    from transplanter.twin.serial_pots import line_config

    line = line_config(scenario)
    half, clear = line.pot_height_m / 2, line.pot_height_m + KEY_LIFT_M
    out = {}
    for col, x in enumerate(cell_columns_x(line)):
        grasp = np.array([x, line.pickup_row_y_m, half])
        out[f"pickup column {col + 1}"] = grasp
        out[f"above pickup column {col + 1}"] = grasp + [0.0, 0.0, clear]
    tube = np.array([*line.drop_tube_xy_m, line.funnel_top_z_m + half])
    out["over the drop tube"] = tube
    out["above the drop tube"] = tube + [0.0, 0.0, clear]
    return out
