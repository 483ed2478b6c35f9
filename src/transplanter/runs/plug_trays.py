"""The plug trays' run (`[workcell] kind = "plug_trays"`, seed 002's cull and refill): one
128-cell planting tray per seed, graded by the host (the drawn truth or the vision
pipeline), its inferior seedlings culled to the bin and its holes refilled from the supply
tray (`transplanter.twin.delta_refill`); with `--seeds` the serviced cells pooled, the
paper's rates averaged and the refills' leaf damage pooled with its interval."""

from __future__ import annotations

import math
from typing import Any

from transplanter.twin.delta_refill import DEFINITIONS

__all__ = [
    "DEFINITIONS", "FAILURES", "FILMED", "REFUSED_OPTIONS", "UNIT",
    "check", "export", "filmer", "key_points",
    "line", "pool", "recorder", "row", "run", "study", "summary",
    "total", "viewer",
]  # fmt: skip

FILMED = ""
UNIT = "cell"
REFUSED_OPTIONS = {
    "--clips-of-failures": "--clips-of-failures: not available for the delta's plug-tray trial "
    "(docs/delta.md); film the cells you want: transplanter render SCENARIO --cells-of I,J",
    "--eeprom": "--eeprom: not available for the delta's plug-tray trial (docs/delta.md): its "
    "host plans the tray's work from the grading",
    "--no-preflight": "--no-preflight: the delta's controller checks every move itself "
    "(docs/delta.md); nothing to leave out",
    "--seedlings-of": "render refused: the delta's job has cells, not seedlings: give --cells-of",
}

FAILURES = (
    "cull_dropped",
    "cull_left",
    "cull_jammed",
    "refill_dropped",
    "refill_jammed",
    "refill_not_seated",
    "refill_no_supply",
    "leaf_damage",
    "neighbour_leaf_damage",
    "drive_alarm",
    "controller_error",
)
"""The tray judge's failure kinds, each a study column `fail_<kind>`."""


def _grading_errors() -> tuple[type, ...]:
    from transplanter.twin.delta_grading import GradingFailed, GradingUnavailable

    return GradingUnavailable, GradingFailed


def check(scenario) -> None:
    from transplanter.scenario.assemble import require_awake
    from transplanter.twin.delta_refill import require_delta

    require_awake(scenario, "the delta's tray job")
    require_delta(scenario)


def total(scenario) -> None:
    return None  # the tray's cells to service: known once the host graded it


def run(scenario, seed, *, progress=None, observers=()):
    """One tray (`twin.delta_refill.run_delta_refill`); a grading that cannot be made (no
    OpenGL context for the pipeline's pictures, a picture it cannot grade) is refused as
    the scenario's (ScenarioError)."""
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.delta_refill import ProgressObserver
    from transplanter.viewing.delta import run_observed

    watch = [ProgressObserver(progress)] if progress is not None else []
    try:
        return run_observed(scenario, seed, [*observers, *watch])
    except _grading_errors() as exc:
        raise ScenarioError(str(exc)) from None


def line(r) -> str:
    ret = "-" if r.substrate_retention is None else f"{100 * r.substrate_retention:.1f} %"
    fails = ", ".join(f"{k} {v}" for k, v in sorted(r.failures.items())) or "none"
    est = ""
    if getattr(r, "rate_basis", "tray") == "whole_tray_estimate":
        est = f" (the whole tray's {r.cells_to_service} cells, from these {r.operations})"
    out = (
        f"seed {r.seed}: {r.operations} operations, {r.time_per_operation_s:.2f} s per "
        f"operation, {r.plants_per_hour:.1f} plants/h, {r.trays_per_hour:.2f} trays/h{est}, "
        f"leaf damage {100 * r.leaf_damage_rate:.2f} % of refills "
        f"({100 * r.tray_leaf_damage_rate:.2f} % of the tray), dropped {r.dropped}, "
        f"substrate retention {ret}; failures: {fails}; wall {r.wall_time_s:.1f} s"
    )
    g = r.grading
    if g.get("source") == "pipeline":
        p, s = g["planting"], g["supply"]
        out += (
            f"\n  graded by the pipeline: planting {p['correct']}/{p['cells']}, supply "
            f"{s['correct']}/{s['cells']} cells as their truth; recognition "
            f"{1000 * p['recognition_wall_s']:.0f} + {1000 * s['recognition_wall_s']:.0f} ms, "
            f"rendering {p['render_wall_s'] + s['render_wall_s']:.1f} s (wall)"
        )
    return out if r.fault is None else f"{out}\n  fault: {r.fault}"


summary = line


def _pooled_damage(results) -> dict[str, Any]:
    """Refill seedlings with a torn leaf over all trays, with the Wilson interval."""
    from transplanter.vision.metrics import wilson_interval

    picked = damaged = 0
    for r in results:
        for c in r.cells:
            if c.supply_index is not None and c.refilled != "nothing_picked":
                picked += 1
                damaged += bool(c.leaf_damage)
    lo, hi = wilson_interval(damaged, picked) if picked else (0.0, 1.0)
    return {
        "vision": results[0].vision,
        "pose_judgement": results[0].pose_judgement,
        "damaged": damaged,
        "picked": picked,
        "rate": damaged / picked if picked else 0.0,
        "ci95": [lo, hi],
    }


def _pooled_misgrades(results) -> dict[str, int]:
    """The misgrade failures (failures `misgrade_<kind>`) summed over the trays."""
    out: dict[str, int] = {}
    for r in results:
        for k, v in r.failures.items():
            if k.startswith("misgrade_"):
                out[k] = out.get(k, 0) + v
    return dict(sorted(out.items()))


def pool(results, pooled) -> tuple[dict[str, Any], list[str]]:
    payload: dict[str, Any] = {}
    for name in ("time_per_operation_s", "plants_per_hour", "trays_per_hour",
                 "leaf_damage_rate", "tray_leaf_damage_rate"):  # fmt: skip
        values = [getattr(r, name) for r in results if math.isfinite(getattr(r, name))]
        payload[f"mean_{name}"] = sum(values) / len(values) if values else None
    payload["pooled_leaf_damage"] = d = _pooled_damage(results)
    payload["pooled_misgrades"] = _pooled_misgrades(results)
    from transplanter.runs import pooled_line

    return payload, [
        pooled_line(pooled, "serviced cells done", over="trays"),
        f"leaf damage pooled over {len(results)} trays ({d['vision']} grading, pose "
        f"judgement {'on' if d['pose_judgement'] else 'off'}): "
        f"{d['damaged']}/{d['picked']} refills ({100 * d['rate']:.2f} %, 95 % Wilson "
        f"{100 * d['ci95'][0]:.1f}-{100 * d['ci95'][1]:.1f} %); misgrades: "
        + (", ".join(f"{k} {v}" for k, v in payload["pooled_misgrades"].items()) or "none"),
    ]


def study(scenario) -> dict[str, Any]:
    return {
        "kind": "plug_trays",
        "fields": (
            "substrate_retention",
            "leaf_damage_rate",
            "tray_leaf_damage_rate",
            "trays_per_hour",
            "dropped",
            *(f"fail_{k}" for k in FAILURES),
        ),
        "means": (
            "substrate_retention",
            "leaf_damage_rate",
            "tray_leaf_damage_rate",
            "plants_per_hour",
            "trays_per_hour",
        ),
        "sections": ("delta", "delta_refill", "plugs", "plug_claws", "bus", "vision"),
        "unit": "serviced cells",
        "more": "delta_refill.max_cells (0: every cell of a tray) x seeds",
        "damage": ("fail_leaf_damage",),
        "label": "time per operation",
        "pictures": lambda sc, varied: (
            "pipeline" in (sc.delta_refill.vision, *varied.get("delta_refill.vision", ()))
        ),
        "pictures_why": 'delta_refill.vision = "pipeline" photographs the trays in every run',
        "no_pictures": "or grade from the drawn truth: --set delta_refill.vision=truth",
    }


def _sd(values) -> float:
    m = sum(values) / len(values)
    return math.sqrt(sum((v - m) ** 2 for v in values) / (len(values) - 1))


def row(scenario, seed: int, out: dict[str, Any]) -> None:
    """One tray as a study row: its serviced cells done over those serviced, the time per
    operation (with the spread of the operations' spans), the rates, damage and drives."""
    from transplanter.runs import finite as _finite
    from transplanter.twin.delta_refill import FAULT_KINDS, run_delta_refill
    from transplanter.twin.motors import motor_columns

    r = run_delta_refill(scenario, seed)
    # each operation from the end of the one before (the first from the claws' arrival):
    # the spans whose mean is the time per operation
    ends = [c.end_s for c in r.cells if math.isfinite(c.end_s)]
    starts = [ends[-1] - r.work_time_s, *ends[:-1]] if ends else []
    spans = [b - a for a, b in zip(starts, ends, strict=True)]
    sd = float(_sd(spans)) if len(spans) > 1 and math.isfinite(r.work_time_s) else None
    out.update(
        successes=r.successes,
        seedlings=r.seedlings,
        success_rate=r.successes / r.seedlings if r.seedlings else None,
        cycle_time_s=r.time_per_operation_s if r.operations else None,
        cycle_time_sd_s=sd,
        cycles=r.operations,
        valid=r.valid,
        fault=r.fault,
        fault_kind=None
        if r.fault is None
        else next(
            (k for k in (*(k for k, _ in FAULT_KINDS), "controller_error") if k in r.failures),
            None,
        ),
        sim_time_s=r.sim_time_s,
        wall_time_s=r.wall_time_s,
        warnings="",
        substrate_retention=r.substrate_retention,
        leaf_damage_rate=r.leaf_damage_rate,
        tray_leaf_damage_rate=r.tray_leaf_damage_rate,
        plants_per_hour=_finite(r.plants_per_hour),
        trays_per_hour=_finite(r.trays_per_hour),
        dropped=r.dropped,
        **motor_columns(r.motors),
    )
    for kind in FAILURES:
        out[f"fail_{kind}"] = r.failures.get(kind, 0)
    if r.seedlings == 0:
        out.update(successes=None, seedlings=None, error="no cell to service on this tray")
    elif not r.valid:
        out["error"] = "trial not valid: MuJoCo warned or the job ran out of simulated time"
    elif r.fault:
        out["error"] = f"fault: {r.fault}"


def recorder(scenario, path, rate_hz: float):
    from transplanter.viewing.delta import DeltaRecording

    return DeltaRecording(path, rate_hz)


def filmer(scenario, target, size, fps, camera, shadows, subset):
    from transplanter.viewing import delta

    cells = None if subset is None else delta.parse_cells(subset)
    return delta.DeltaVideo(target, *size, fps, camera, cells, shadows)


def viewer(scenario, speed: float):
    from transplanter.scenario.schema import ScenarioError

    raise ScenarioError(
        "the delta's plug-tray job has no live view yet: film it instead, transplanter render "
        "SCENARIO --out tray.mp4 (--cells-of I,J for some cells), or record it with trial "
        "--record tray.rrd and open it with transplanter replay"
    )


def export(scenario, target):
    """The scene its trial builds for the scenario's seed (twin.delta_refill.job_spec: the
    job's cells come from the host's grading map), meshes in assets/ beside it."""
    from transplanter.scenario.schema import ScenarioError
    from transplanter.scene.delta_scene import export_spec
    from transplanter.twin.delta_refill import job_spec

    try:
        spec = job_spec(scenario)
    except _grading_errors() as exc:
        raise ScenarioError(str(exc)) from None
    return export_spec(spec, target)


def key_points(scenario) -> dict[str, Any]:
    """The trays' key points (`scenario.reach`; workcell frame, m, the claws' work height at
    0): every cell of both trays at the work height, the trays' corners at the lift height
    over them, the bin's drop spots at their release height."""
    import numpy as np

    from transplanter.scene.delta_scene import DeltaSceneConfig

    job = scenario.delta_refill
    cfg = DeltaSceneConfig(bin_xy_m=(job.bin_x_m, job.bin_y_m))
    n = cfg.geometry.cells
    out = {}
    for tray in ("planting", "supply"):
        for i in range(n):
            out[f"{tray} cell {i}"] = np.array([*cfg.cell_xy(tray, i), 0.0])
        for i in (0, cfg.geometry.cols - 1, n - cfg.geometry.cols, n - 1):
            out[f"above {tray} cell {i}"] = np.array([*cfg.cell_xy(tray, i), job.lift_m])
    for k in range(9):
        out[f"bin spot {k}"] = np.array([*cfg.bin_spot(k), job.bin_release_above_m])
    return out
