"""`transplanter trial` for the delta's cull-and-refill job (`[workcell] kind =
"plug_trays"`): one tray per seed, headless (transplanter.twin.delta_refill); with --seeds the
pooled success rate over the serviced cells (studies.stats.pooled_rate) and the means of the
paper's three rates. The claws' bench (`[workcell] kind = "plug_bench"`,
transplanter.twin.plug_bench_trial) likewise: one run of `scenario.seedlings` picks per seed."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from transplanter.cli.common import (
    EXIT_REFUSED,
    _err,
    _finish,
    _progress,
    _seeds,
    _show,
    video_written,
)

__all__ = ["export", "render", "run_trial"]


def export(scenario, target: Path) -> Path:
    """`transplanter export` of the delta's job: the scene its trial builds for the
    scenario's seed (twin.delta_refill.job_spec), meshes in assets/ beside it."""
    from transplanter.scenario.schema import ScenarioError
    from transplanter.scene.delta_scene import export_spec
    from transplanter.twin.delta_grading import GradingFailed, GradingUnavailable
    from transplanter.twin.delta_refill import job_spec

    try:
        spec = job_spec(scenario)  # the job's cells come from the host's grading map
    except (GradingUnavailable, GradingFailed) as exc:
        raise ScenarioError(str(exc)) from None
    return export_spec(spec, target)


def summary_line(r) -> str:
    ret = "-" if r.substrate_retention is None else f"{100 * r.substrate_retention:.1f} %"
    fails = ", ".join(f"{k} {v}" for k, v in sorted(r.failures.items())) or "none"
    est = ""
    if getattr(r, "rate_basis", "tray") == "whole_tray_estimate":
        est = f" (the whole tray's {r.cells_to_service} cells, from these {r.operations})"
    line = (
        f"seed {r.seed}: {r.operations} operations, {r.time_per_operation_s:.2f} s per "
        f"operation, {r.plants_per_hour:.1f} plants/h, {r.trays_per_hour:.2f} trays/h{est}, "
        f"leaf damage {100 * r.leaf_damage_rate:.2f} % of refills "
        f"({100 * r.tray_leaf_damage_rate:.2f} % of the tray), dropped {r.dropped}, "
        f"substrate retention {ret}; failures: {fails}; wall {r.wall_time_s:.1f} s"
    )
    g = r.grading
    if g.get("source") == "pipeline":
        p, s = g["planting"], g["supply"]
        line += (
            f"\n  graded by the pipeline: planting {p['correct']}/{p['cells']}, supply "
            f"{s['correct']}/{s['cells']} cells as their truth; recognition "
            f"{1000 * p['recognition_wall_s']:.0f} + {1000 * s['recognition_wall_s']:.0f} ms, "
            f"rendering {p['render_wall_s'] + s['render_wall_s']:.1f} s (wall)"
        )
    return line if r.fault is None else f"{line}\n  fault: {r.fault}"


def bench_line(r) -> str:
    """One run of the claws' bench (transplanter.twin.plug_bench_trial)."""
    ret = "-" if r.substrate_retention is None else f"{100 * r.substrate_retention:.1f} %"
    return (
        f"seed {r.seed}: {r.successes}/{r.seedlings} seedlings arrived "
        f"({100 * r.success_rate:.1f} %), dropped {r.dropped}, substrate retention {ret}, "
        f"leaf damage {100 * r.leaf_damage_rate:.1f} %, {r.cycle_time_s:.3f} s per pick, "
        f"moisture drawn {r.moisture_pct:.1f} % on average; wall {r.wall_time_s:.1f} s"
    )


def _definitions(bench: bool = False) -> str:
    from transplanter.twin.delta_refill import DEFINITIONS

    if bench:
        from transplanter.twin.plug_bench_trial import DEFINITIONS

    return "\n".join(f"  {k}: {v}" for k, v in DEFINITIONS.items())


def run_trial(
    args: argparse.Namespace,
    overrides: dict[str, Any],
    json_path: Path | None,
    record_path: Path | None = None,
) -> int:
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.studies.stats import pooled_rate
    from transplanter.twin.delta_grading import GradingFailed, GradingUnavailable
    from transplanter.twin.delta_refill import run_delta_refill

    for option, value in (("--clips-of-failures", args.clips_of_failures),
                          ("--eeprom", args.eeprom)):  # fmt: skip
        if value is not None:
            _err(f"{option}: not available for the delta's plug-tray trial (docs/delta.md)")
            return EXIT_REFUSED
    if args.seeds is not None and args.seed is not None:
        _err("--seeds runs one trial per seed: drop --seed")
        return EXIT_REFUSED
    if args.seeds is not None and record_path is not None:
        _err("--seeds runs one trial per seed: drop --record (record one --seed)")
        return EXIT_REFUSED
    seeds = _seeds(args) if args.seeds is not None else [None]
    if seeds is None:
        return EXIT_REFUSED
    try:
        scenario = load_scenario(args.scenario, overrides)
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    bench = scenario.workcell.kind == "plug_bench"
    if bench and record_path is not None:
        _err("--record: not available for the claws' bench (docs/plug_claws.md)")
        return EXIT_REFUSED
    if bench:
        from transplanter.twin.plug_bench_trial import run_bench_trial
    from transplanter.twin.delta_refill import ProgressObserver
    from transplanter.twin.report import progress_bar

    results, outputs = [], []
    for seed in seeds:
        total = scenario.meta.seedlings if bench else None  # the tray's: once it is graded
        bar, update = progress_bar(total, _progress(args), "seedling" if bench else "cell")
        try:
            if bench:
                result = run_bench_trial(scenario, seed, progress=update)
            elif record_path is None:
                watch = [ProgressObserver(update)] if update is not None else []
                result = run_delta_refill(scenario, seed, observers=watch)
            else:
                from transplanter.viewing.delta import DeltaRecording, run_observed

                recording = DeltaRecording(record_path, args.record_rate)
                watch = [ProgressObserver(update)] if update is not None else []
                result = run_observed(scenario, seed, [recording, *watch])
        except (GradingUnavailable, GradingFailed, ScenarioError) as exc:
            _err(f"trial refused: {exc}")
            return EXIT_REFUSED
        finally:
            if bar is not None:
                bar.close()
        if record_path is not None:
            if result.recording_error is None:
                shown = _show(record_path)
                outputs.append(
                    (f"recording written to {shown} (view it with: transplanter replay {shown})",
                     None)
                )  # fmt: skip
        results.append(result)
        print(bench_line(result) if bench else summary_line(result))
    if args.seeds is None:
        payload: dict[str, Any] = results[0].to_dict()
    else:
        pooled = pooled_rate([r.successes for r in results], [r.seedlings for r in results])
        payload = {"trials": [r.to_dict() for r in results], "pooled": pooled.to_dict()}
        names = ("time_per_operation_s", "plants_per_hour", "trays_per_hour",
                 "leaf_damage_rate", "tray_leaf_damage_rate")  # fmt: skip
        if bench:
            names = ("cycle_time_s", "leaf_damage_rate")
        for name in names:
            values = [getattr(r, name) for r in results if math.isfinite(getattr(r, name))]
            payload[f"mean_{name}"] = sum(values) / len(values) if values else None
        if not bench:
            payload["pooled_leaf_damage"] = _pooled_damage(results)
            payload["pooled_misgrades"] = _pooled_misgrades(results)
        lo, hi = pooled.ci95
        what = "runs: {:.1f} % of seedlings arrived" if bench else (
            "trays: {:.1f} % of serviced cells done"
        )  # fmt: skip
        print(
            f"pooled over {pooled.trials} {what.format(100 * pooled.success_rate)} "
            f"({pooled.successes}/{pooled.seedlings}), 95 % CI "
            f"{100 * lo:.1f}-{100 * hi:.1f} % ({pooled.method})"
        )
        if not bench:
            d = payload["pooled_leaf_damage"]
            print(
                f"leaf damage pooled over {len(results)} trays ({d['vision']} grading, pose "
                f"judgement {'on' if d['pose_judgement'] else 'off'}): "
                f"{d['damaged']}/{d['picked']} refills ({100 * d['rate']:.2f} %, 95 % Wilson "
                f"{100 * d['ci95'][0]:.1f}-{100 * d['ci95'][1]:.1f} %); misgrades: "
                + (", ".join(f"{k} {v}" for k, v in payload["pooled_misgrades"].items()) or "none")
            )
    summary = "definitions:\n" + _definitions(bench)
    return _finish(args, results, summary, payload, json_path, outputs=outputs)


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


def render(
    args: argparse.Namespace, overrides: dict[str, Any], target: Path, json_path: Path | None
) -> int:
    """`transplanter render` of the delta's job: the trial as `trial` runs it (the same
    results) filmed by viewing.delta.DeltaVideo (--cells-of: only those cells' work)."""
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.viewing import delta, video

    if args.seedlings_of is not None:
        _err("render refused: the delta's job has cells, not seedlings: give --cells-of")
        return EXIT_REFUSED
    try:
        scenario = load_scenario(args.scenario, overrides)
        cells = None if args.cells_of is None else delta.parse_cells(args.cells_of)
        observer = delta.DeltaVideo(
            target, args.width, args.height, args.fps, args.camera, cells, args.shadows
        )
    except (ScenarioError, video.RenderRefused) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    from transplanter.twin.delta_grading import GradingFailed, GradingUnavailable

    try:
        result = delta.run_observed(scenario, None, [observer])
    except (
        video.GLUnavailable,
        video.RenderRefused,
        GradingUnavailable,
        GradingFailed,
        ScenarioError,
    ) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    print(summary_line(result))
    written = video_written(observer, args, target)
    return _finish(args, [result], None, result.to_dict(), json_path, outputs=[written])
