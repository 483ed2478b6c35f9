"""The `transplanter` command: inverse kinematics, G-code planning, trials and replay.

Argument parsing and what is printed live here; the work is done by the domain modules
(`config.assemble`, `trial.run_trial`, `planner.plan_program`, `report`).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

DEFAULT_SCENARIO = "paper"  # the packaged paper scenario

EXIT_OK, EXIT_REFUSED, EXIT_INVALID_PHYSICS, EXIT_FIRMWARE_FAULT = 0, 2, 3, 4
EXIT_OUTPUT_FAILED = 5  # a result file or the recording could not be written
EXIT_INTERRUPTED = 130  # Ctrl-C, as shells report SIGINT
# A G-code program for `plan`: a 100k-move file is about 3 MB; anything far bigger is not one.
MAX_GCODE_FILE_BYTES = 64 << 20


_FLOAT_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:inf|nan)", re.I)
_INT_RE = re.compile(r"[+-]?\d+")


def ascii_float(text: str) -> float:
    """A number written in ASCII (Python's float() also takes Unicode digits such as '١٠')."""
    if not (text.isascii() and _FLOAT_RE.fullmatch(text.strip())):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (ASCII digits 0-9)")
    return float(text)


def ascii_int(text: str) -> int:
    """A whole number written in ASCII digits."""
    if not (text.isascii() and _INT_RE.fullmatch(text.strip())):
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number (ASCII digits 0-9)")
    return int(text)


def _scenario_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--scenario",
        default=DEFAULT_SCENARIO,
        help="scenario file, or the name of a packaged scenario (default: paper)",
    )
    _set_arg(parser)


def _set_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="SECTION.KEY=VALUE",
        help="override a scenario key in its file unit, e.g. --set taught.z_low_mm=30 "
        '(a TOML value: 30, true, [0, 140], "scurve"); repeatable',
    )


def _overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The --set options as {'section.key': value}; ScenarioError for a malformed one."""
    from transplanter.scenario.schema import ScenarioError, parse_value

    out: dict[str, Any] = {}
    for item in args.set:
        key, eq, text = item.partition("=")
        key = key.strip()
        if not eq or "." not in key:
            raise ScenarioError(f"--set {item!r}: write SECTION.KEY=VALUE")
        value = parse_value(text)  # a bare word is a string: --set motion.profile=scurve
        if key in out:
            raise ScenarioError(f"--set {key} is given twice")
        out[key] = value
    return out


def _seeds(args: argparse.Namespace) -> list[int] | None:
    """The --seeds list, or None after saying why it was refused."""
    from transplanter.studies.stats import parse_seeds

    try:
        return parse_seeds(args.seeds)
    except ValueError as exc:
        _err(f"--seeds: {exc}")
        return None


def _seedlings(args: argparse.Namespace, overrides: dict[str, Any]) -> int:
    """--seedlings, or the scenario's (with the --set overrides) when not given."""
    if args.seedlings is not None:
        return args.seedlings
    from transplanter.scenario.schema import load_scenario

    return load_scenario(args.scenario, overrides).meta.seedlings


def _machine(args: argparse.Namespace):
    """The machine of a scenario, or None after saying why it was refused."""
    from transplanter.scenario.assemble import machine_config
    from transplanter.scenario.schema import ScenarioError, load_scenario

    try:
        return machine_config(load_scenario(args.scenario, _overrides(args)))
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return None


def cmd_ik(args: argparse.Namespace) -> int:
    from transplanter.machine.kinematics import fivebar as kinematics

    machine = _machine(args)
    if machine is None:
        return 2
    x, y = args.x * 1e-3, args.y * 1e-3
    report = kinematics.check_points(
        machine.geometry, machine.limits, np.array([x]), np.array([y]), mode=machine.mode
    )
    if not report.ok[0]:
        print(f"({args.x:g}, {args.y:g}) mm cannot be reached: {report.reasons[0]}")
        return 1
    t1, t2 = float(report.theta1[0]), float(report.theta2[0])
    tr = float(kinematics.transmission_angle(machine.geometry, t1, t2, x, y))
    print(f"theta1 = {math.degrees(t1):.4f} deg")
    print(f"theta2 = {math.degrees(t2):.4f} deg")
    print(f"passive-link (transmission) angle = {math.degrees(tr):.4f} deg")
    return 0


def cmd_plan(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.machine.planner import PlanError, plan_program

    machine = _machine(args)
    if machine is None:
        return 2
    try:
        text = fileio.read_text_input(args.file, MAX_GCODE_FILE_BYTES, "G-code")
    except fileio.FileRefused as exc:
        _err(str(exc))
        return 1
    try:
        rows = plan_program(machine, text)  # split at newlines only
    except PlanError as exc:
        _err(f"{args.file}:{exc.line_no}: {exc}")
        return 1
    print(
        f"{'line':>5}  {'duration_s':>10}  {'steps_a':>8}  {'steps_b':>8}  {'steps_z':>8}  g-code"
    )
    total = 0.0
    totals = np.zeros(3, dtype=np.int64)
    for row in rows:
        total += row.duration_s
        totals += np.abs(row.steps)
        a, b, z = row.steps
        print(
            f"{row.line_no:>5}  {row.duration_s:>10.4f}  {a:>8d}  {b:>8d}  {z:>8d}  "
            f"{_show(row.text)}"
        )
    print(
        f"total  {total:>10.4f}  {totals[0]:>8d}  {totals[1]:>8d}  {totals[2]:>8d}  "
        f"({len(rows)} lines; step columns are net steps per line, total is |steps|)"
    )
    return 0


def _output_targets(args: argparse.Namespace) -> dict[str, Path | None] | None:
    """The checked --json and --record paths (None where not given), or None after saying
    why one is refused (trial and serve)."""
    from transplanter import fileio

    targets: dict[str, Path | None] = {"--json": None, "--record": None}
    for option, path, suffix in (("--json", args.json, None), ("--record", args.record, ".rrd")):
        if path is not None:
            try:
                targets[option] = fileio.check_output(path, suffix)
            except fileio.FileRefused as exc:
                _err(f"{option}: {exc}")
                return None
    return targets


def cmd_trial(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import format_summary, progress_bar
    from transplanter.twin.trial import TrialInterrupted, run_trial
    from transplanter.viewing.video import GLUnavailable, RenderRefused

    if not (math.isfinite(args.record_rate) and args.record_rate > 0):
        _err(f"--record-rate must be a finite number of Hz > 0, got {args.record_rate}")
        return EXIT_REFUSED
    clips = None
    if args.clips_of_failures is not None:
        if args.seeds is not None:
            _err("--clips-of-failures films one trial: drop --seeds (or give one --seed)")
            return EXIT_REFUSED
        clips = _failure_clips(args)
        if clips is None:
            return EXIT_REFUSED
    targets = _output_targets(args)
    if targets is None:
        return EXIT_REFUSED
    if not _read_eeprom(args):
        return EXIT_REFUSED
    try:
        overrides = _overrides(args)
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    if args.seedlings is not None:
        overrides["scenario.seedlings"] = args.seedlings
    if args.seed is not None:
        overrides["scenario.seed"] = args.seed
    if args.seeds is not None:
        if args.seed is not None or args.record is not None:
            _err("--seeds runs one trial per seed: drop --seed and --record (record one seed)")
            return EXIT_REFUSED
        seeds = _seeds(args)
        if seeds is None:
            return EXIT_REFUSED
        return _pooled_trials(args, overrides, seeds, targets["--json"])
    try:
        config = assemble(_trial_scenario(args, overrides), preflight=not args.no_preflight)
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    if clips is not None and not _clip_dir_ready(Path(args.clips_of_failures)):
        return EXIT_REFUSED
    bar, update = progress_bar(config.seedlings, not args.quiet and sys.stderr.isatty())
    interrupted = False
    try:
        result = run_trial(
            config, record_path=targets["--record"], record_rate_hz=args.record_rate,
            progress=update, observers=[clips] if clips is not None else (),
        )  # fmt: skip
    except TrialInterrupted as stop:
        result, interrupted = stop.result, True
    except (GLUnavailable, RenderRefused) as exc:
        _err(f"--clips-of-failures: {exc}")
        return EXIT_REFUSED
    finally:
        if bar is not None:
            bar.close()
    print(format_summary(result))
    status = EXIT_OK
    payload = result.to_dict()
    if clips is not None:
        payload["clips"] = [dataclasses.asdict(c) for c in clips.clips]
        _print_clips(clips, args.clips_of_failures)
        if clips.error is not None:
            _err(f"--clips-of-failures: {clips.error}")
            status = EXIT_OUTPUT_FAILED
    if targets["--json"] is not None:
        try:
            fileio.write_json_atomic(targets["--json"], payload)
            print(f"results written to {_show(args.json)}")
        except OSError as exc:
            _err(f"--json: the results could not be written to {_show(args.json)}: {exc}")
            status = EXIT_OUTPUT_FAILED
    if result.recording_error is not None:
        _err(f"--record: {result.recording_error}")
        status = EXIT_OUTPUT_FAILED
    elif args.record is not None:
        where = Path(args.record)
        if interrupted:
            where = where.with_name(where.stem + ".partial.rrd")
        shown = _show(where)
        print(f"recording written to {shown} (view it with: transplanter replay {shown})")
    if interrupted:
        _err(f"interrupted after {result.judged} seedlings")
        return EXIT_INTERRUPTED
    if status != EXIT_OK:
        return status
    if not result.valid:
        return EXIT_INVALID_PHYSICS
    return EXIT_FIRMWARE_FAULT if result.fault else EXIT_OK


def _read_eeprom(args: argparse.Namespace) -> bool:
    """Read `trial --eeprom FILE` (CRC checked) into args.eeprom_image (None without the
    option); False after saying why the image was refused."""
    from transplanter.machine.eeprom import EepromError, EepromImage

    args.eeprom_image = None
    if getattr(args, "eeprom", None) is None:
        return True
    try:
        args.eeprom_image = EepromImage.load(args.eeprom)
    except EepromError as exc:
        _err(f"--eeprom refused: {exc}")
        return False
    return True


def _trial_scenario(args: argparse.Namespace, overrides: dict[str, Any]):
    """The trial's scenario with its overrides and, with --eeprom, the image's taught data
    in place of its [taught] section (config.with_eeprom); ScenarioError when refused."""
    from transplanter.scenario.assemble import with_eeprom
    from transplanter.scenario.schema import load_scenario

    scenario = load_scenario(args.scenario, overrides)
    image = getattr(args, "eeprom_image", None)
    if image is not None:
        scenario = with_eeprom(scenario, image, str(args.eeprom))
    return scenario


def _failure_clips(args: argparse.Namespace):
    """The FailureClips observer of `trial --clips-of-failures DIR`, or None after saying
    why it was refused."""
    from transplanter.viewing import video

    try:
        width, height = video.parse_size(args.clip_size)
        video.check_frames(width, height, args.clip_fps)
        clips = video.FailureClips(
            args.clips_of_failures, width, height, args.clip_fps, args.clip_camera
        )
    except (video.VideoUnavailable, video.RenderRefused) as exc:
        _err(f"--clips-of-failures: {exc}")
        return None
    return clips


def _clip_dir_ready(directory: Path) -> bool:
    """Create the clips' directory and prove it writable, or say why not (False)."""
    from transplanter import fileio

    try:
        directory.mkdir(parents=True, exist_ok=True)
        fileio.discard(fileio.temp_beside(directory / "probe"))
    except OSError as exc:
        _err(f"--clips-of-failures: {_show(directory)} cannot hold the clips: {exc}")
        return False
    return True


def _print_clips(clips, directory) -> None:
    if not clips.clips:
        print(f"no failure clips: no seedling failed (or none was filmed) in {_show(directory)}")
        return
    print(f"{len(clips.clips)} failure clip(s) written to {_show(directory)}:")
    for c in clips.clips:
        cut = f", the first {c.dropped_frames} frames cut" if c.dropped_frames else ""
        print(
            f"  {_show(Path(c.path).name)}  ({c.frames} frames, t {c.t_start_s:.2f}-"
            f"{c.t_end_s:.2f} s{cut})"
        )


def _single_trial_config(args: argparse.Namespace):
    """The assembled config of one trial from SCENARIO, --set, --seedlings and --seed;
    ScenarioError when refused."""
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import load_scenario

    overrides = _overrides(args)
    if args.seedlings is not None:
        overrides["scenario.seedlings"] = args.seedlings
    if args.seed is not None:
        overrides["scenario.seed"] = args.seed
    return assemble(load_scenario(args.scenario, overrides), preflight=True)


def _trial_status(result) -> int:
    if not result.valid:
        return EXIT_INVALID_PHYSICS
    return EXIT_FIRMWARE_FAULT if result.fault else EXIT_OK


def cmd_render(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import format_summary, progress_bar
    from transplanter.twin.trial import TrialInterrupted, run_trial
    from transplanter.viewing import video

    try:
        video.require_imageio()
        video.check_frames(args.width, args.height, args.fps)
        target = fileio.check_output(args.out, ".mp4")
        json_target = None if args.json is None else fileio.check_output(args.json)
    except (video.VideoUnavailable, video.RenderRefused, fileio.FileRefused) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    try:
        config = _single_trial_config(args)
        seedlings = (
            None
            if args.seedlings_of is None
            else video.parse_indices(args.seedlings_of, config.seedlings)
        )
    except (ScenarioError, video.RenderRefused) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    observer = video.VideoObserver(
        target, args.width, args.height, args.fps, args.camera, seedlings, args.shadows
    )
    bar, update = progress_bar(config.seedlings, not args.quiet and sys.stderr.isatty())
    interrupted = False
    try:
        result = run_trial(config, progress=update, observers=[observer])
    except TrialInterrupted as stop:
        result, interrupted = stop.result, True
    except (video.GLUnavailable, video.RenderRefused) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    finally:
        if bar is not None:
            bar.close()
    print(format_summary(result))
    if json_target is not None:
        try:
            fileio.write_json_atomic(json_target, result.to_dict())
            print(f"results written to {_show(args.json)}")
        except OSError as exc:
            _err(f"--json: the results could not be written to {_show(args.json)}: {exc}")
            return EXIT_OUTPUT_FAILED
    if interrupted:
        _err(f"interrupted after {result.judged} seedlings; no video written")
        return EXIT_INTERRUPTED
    if observer.error is not None:
        _err(f"render: {observer.error}")
        return EXIT_OUTPUT_FAILED
    n = observer.frames
    rate = f", {n / observer.render_s:.1f} frames/s" if observer.render_s > 0 else ""
    print(
        f"video written to {_show(args.out)}: {n} frames at {args.fps:g} fps "
        f"({n / args.fps:.1f} s), {args.width}x{args.height}, camera {_show(args.camera)}; "
        f"rendering and encoding took {observer.render_s:.1f} s{rate}"
    )
    return _trial_status(result)


def cmd_view(args: argparse.Namespace) -> int:
    from transplanter.viewing import live, video

    if not (math.isfinite(args.speed) and 0 < args.speed <= live.MAX_SPEED):
        _err(f"--speed must be above 0 and at most {live.MAX_SPEED:g}, got {args.speed}")
        return EXIT_REFUSED
    if not video.has_display():
        _err(
            "view: no display (DISPLAY and WAYLAND_DISPLAY are unset), so no viewer window can "
            "open here. Film the trial instead: transplanter render SCENARIO --out clip.mp4 "
            f"(needs {video.INSTALL_HINT}), or run view on a machine with a display"
        )
        return EXIT_REFUSED
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import format_summary
    from transplanter.twin.trial import TrialInterrupted, run_trial

    try:
        config = _single_trial_config(args)
    except ScenarioError as exc:
        _err(f"view refused: {exc}")
        return EXIT_REFUSED
    observer = live.LiveViewer(args.speed)
    try:
        result = run_trial(config, observers=[observer])
    except TrialInterrupted as stop:
        result = stop.result
    except live.ViewerUnavailable as exc:
        _err(f"view: {exc}")
        return EXIT_REFUSED
    print(format_summary(result))
    if observer.closed:
        print(f"viewer closed at t = {observer.closed_at:.1f} s simulated")
        return EXIT_OK
    if result.interrupted:
        return EXIT_INTERRUPTED
    return _trial_status(result)


def _pooled_trials(args, overrides: dict[str, Any], seeds: list[int], json_path) -> int:
    """One trial per seed, each line printed as it finishes, then the pooled rate."""
    from transplanter import fileio
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import ScenarioError
    from transplanter.studies.stats import pooled_rate
    from transplanter.twin.trial import TrialInterrupted, run_trial

    try:
        configs = [
            assemble(
                _trial_scenario(args, {**overrides, "scenario.seed": seed}),
                preflight=not args.no_preflight,
            )
            for seed in seeds
        ]
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    results, interrupted = [], False
    for config in configs:
        try:
            result = run_trial(config)
        except TrialInterrupted:
            interrupted = True
            break
        results.append(result)
        d = result.to_dict()
        cluster = ", failures cluster" if d["failures_clustered"] else ""
        failed = {k: v for k, v in d["failures"].items() if v}
        print(
            f"seed {config.seed:>6}: {d['successes']}/{d['seedlings']} "
            f"({100 * d['success_rate']:.1f} %){cluster}  {failed or ''}"
        )
    payload: dict[str, Any] = {"trials": [r.to_dict() for r in results], "interrupted": interrupted}
    if results:
        pooled = pooled_rate([r.successes for r in results], [r.seedlings for r in results])
        payload["pooled"] = pooled.to_dict()
        lo, hi = pooled.ci95
        print(
            f"pooled over {pooled.trials} trial{'s' if pooled.trials != 1 else ''}: "
            f"{100 * pooled.success_rate:.1f} % "
            f"({pooled.successes}/{pooled.seedlings}), 95 % CI {100 * lo:.1f}-{100 * hi:.1f} % "
            f"({pooled.method})"
        )
    if json_path is not None:
        try:
            fileio.write_json_atomic(json_path, payload)
            print(f"results written to {_show(args.json)}")
        except OSError as exc:
            _err(f"--json: the results could not be written to {_show(args.json)}: {exc}")
            return EXIT_OUTPUT_FAILED
    if interrupted:
        _err(f"interrupted after {len(results)} trials")
        return EXIT_INTERRUPTED
    if not all(r.valid for r in results):
        return EXIT_INVALID_PHYSICS
    return EXIT_FIRMWARE_FAULT if any(r.fault for r in results) else EXIT_OK


def _workers(text: str) -> int:
    """--workers N or auto (every CPU of this machine)."""
    if text == "auto":
        return os.cpu_count() or 1
    n = ascii_int(text)
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: give at least 1 worker, or auto")
    return n


def cmd_sweep(args: argparse.Namespace) -> int:
    from transplanter.scenario.schema import ScenarioError
    from transplanter.studies.sweep import (
        SweepRefused,
        SweepSpec,
        check_backend,
        format_value,
        parse_vary,
        run_sweep,
    )

    seeds = _seeds(args)
    if seeds is None:
        return EXIT_REFUSED
    try:
        overrides = _overrides(args)
        axes = tuple(parse_vary(v) for v in args.vary)
        seedlings = _seedlings(args, overrides)
        spec = SweepSpec(args.scenario, axes, tuple(seeds), seedlings, overrides)
        spec.check()
        check_backend(args.backend, args.workers, args.address)
    except (ScenarioError, SweepRefused) as exc:
        _err(f"sweep refused: {exc}")
        return EXIT_REFUSED
    print(
        f"{spec.runs_total} runs: {len(spec.settings())} settings x {len(seeds)} seeds, "
        f"{seedlings} seedlings each, {args.workers} {args.backend} worker(s)"
    )
    try:
        report = run_sweep(
            spec, args.out, backend=args.backend, workers=args.workers, address=args.address,
            progress=not args.quiet and sys.stderr.isatty(),
        )  # fmt: skip
    except (ScenarioError, SweepRefused) as exc:
        _err(f"sweep refused: {exc}")
        return EXIT_REFUSED
    except OSError as exc:
        _err(f"--out: the results could not be written to {_show(args.out)}: {exc}")
        return EXIT_OUTPUT_FAILED
    if report.skipped:
        print(f"{report.skipped} runs were already in {_show(args.out)} (skipped)")
    width = max(len(k) for k in spec.keys)
    head = "  ".join(f"{k:>{width}}" for k in spec.keys)
    print(f"{head}  {'success':>16}  {'95 % CI':>13}  {'cycle s':>7}  errors")
    for a in report.settings:
        values = "  ".join(f"{format_value(a[k]):>{width}}" for k in spec.keys)
        if a["success_rate"] is None:
            print(f"{values}  {'-':>16}  {'-':>13}  {'-':>7}  {a['errors']}")
            continue
        rate = f"{100 * a['success_rate']:.1f} % ({a['successes']}/{a['seedlings']})"
        ci = f"{100 * a['ci95_low']:.1f}-{100 * a['ci95_high']:.1f} %"
        cycle = "-" if a["cycle_time_s"] is None else f"{a['cycle_time_s']:.3f}"
        print(f"{values}  {rate:>16}  {ci:>13}  {cycle:>7}  {a['errors']}")
    failed = [r for r in report.rows if r["error"] is not None]
    for r in failed[:5]:
        where = " ".join(f"{k}={format_value(r[k])}" for k in spec.keys)
        _err(f"run {where} seed {r['seed']}: {r['error']}")
    if len(failed) > 5:
        _err(f"... and {len(failed) - 5} more runs with an error (see runs.csv)")
    print(f"results in {_show(args.out)}: runs.jsonl, runs.csv, settings.csv, sweep.json")
    if report.plots:
        print("plots: " + ", ".join(_show(p.name) for p in report.plots))
    if report.plot_error:
        _err(f"the plots could not be written: {report.plot_error}")
        return EXIT_OUTPUT_FAILED
    if report.interrupted:
        _err(f"interrupted after {len(report.rows)} of {report.total} runs; rerun the same "
             "command to finish (finished runs are kept)")  # fmt: skip
        return EXIT_INTERRUPTED
    return EXIT_OK


def _search_spec(args: argparse.Namespace, seeds: list[int], ranges: list[str], option: str):
    """The checked TuneSpec of `tune` (--param) and `calibrate` (--fit): the scenario with
    --set, the KEY=LO..HI ranges, the seeds and seedlings (default: the scenario's);
    ScenarioError or SweepRefused when refused."""
    from transplanter.studies.sweep import parse_param_range
    from transplanter.studies.tune import Param, TuneSpec

    overrides = _overrides(args)
    params = tuple(Param(*parse_param_range(text, option)) for text in ranges)
    seedlings = _seedlings(args, overrides)
    spec = TuneSpec(
        args.scenario, params, tuple(seeds), seedlings, overrides, args.sampler_seed, option
    )
    spec.check()
    return spec


def cmd_tune(args: argparse.Namespace) -> int:
    from transplanter.scenario.schema import ScenarioError
    from transplanter.studies.sweep import SweepRefused, format_value
    from transplanter.studies.tune import run_tune

    seeds = _seeds(args)
    if seeds is None:
        return EXIT_REFUSED
    if args.trials < 1:
        _err(f"--trials must be at least 1, got {args.trials}")
        return EXIT_REFUSED
    try:
        spec = _search_spec(args, seeds, args.param, "--param")
        report = run_tune(
            spec, args.trials, args.storage, args.study, args.out, workers=args.workers,
            progress=not args.quiet and sys.stderr.isatty(),
        )  # fmt: skip
    except (ScenarioError, SweepRefused) as exc:
        _err(f"tune refused: {exc}")
        return EXIT_REFUSED
    except OSError as exc:
        _err(f"the results could not be written: {exc}")
        return EXIT_OUTPUT_FAILED
    print(
        f"study {_show(args.study)}: {report.finished} trials ({report.ran} run now), "
        f"{len(report.front)} on the Pareto front"
    )
    keys = [p.key for p in spec.params]
    for row in report.front:
        values = " ".join(f"{k}={format_value(row[k])}" for k in keys)
        print(
            f"  trial {row['trial']:>4}: {values}  success {100 * row['success_rate']:.1f} % "
            f"(lower 95 % bound {100 * row['ci95_low']:.1f} %), cycle {row['cycle_time_s']:.3f} s"
        )
    print("files: " + ", ".join(_show(p) for p in report.files))
    if report.chosen is not None:
        print(
            f"run the chosen point with: transplanter trial {_show(Path(args.out) / 'tuned.toml')}"
        )
    print(f"browse the study with: optuna-dashboard {_show(report.storage)}")
    if report.interrupted:
        _err("interrupted; rerun the same command to go on (finished trials are kept)")
        return EXIT_INTERRUPTED
    return EXIT_OK


def cmd_calibrate(args: argparse.Namespace) -> int:
    from transplanter.scenario.schema import ScenarioError
    from transplanter.studies.calibrate import (
        CalibrationSpec,
        Observation,
        format_summary,
        parse_observed,
        run_calibrate,
    )
    from transplanter.studies.sweep import SweepRefused, check_backend

    seeds = _seeds(args)
    if seeds is None:
        return EXIT_REFUSED
    try:
        if not args.fit:
            raise SweepRefused("give at least one --fit KEY=LO..HI (the keys to fit)")
        observed = Observation(
            *parse_observed(args.observed), cycle_s=args.cycle_s, cycle_tol_s=args.cycle_tol_s
        )
        search = _search_spec(args, seeds, args.fit, "--fit")
        check_backend(args.backend, args.workers, args.address)
        spec = CalibrationSpec(search, observed)
        report = run_calibrate(
            spec, args.trials, args.out, storage=args.storage, study_name=args.study,
            workers=args.workers, backend=args.backend, address=args.address,
            progress=not args.quiet and sys.stderr.isatty(),
        )  # fmt: skip
    except (ScenarioError, SweepRefused) as exc:
        _err(f"calibrate refused: {exc}")
        return EXIT_REFUSED
    except OSError as exc:
        _err(f"the results could not be written: {exc}")
        return EXIT_OUTPUT_FAILED
    print(f"study {_show(args.study)}: {report.finished} trials ({report.ran} run now)")
    print(format_summary(report))
    print("files: " + ", ".join(_show(p) for p in report.files))
    if report.best is not None:
        print(
            "run the calibrated twin with: transplanter trial "
            f"{_show(Path(args.out) / 'calibrated.toml')}"
        )
    if report.interrupted:
        resume = "; rerun the same command to go on" if args.storage is not None else ""
        _err(f"interrupted; the files hold the trials that finished{resume}")
        return EXIT_INTERRUPTED
    return EXIT_OK


def _show(path) -> str:
    from transplanter.twin.report import printable

    return printable(str(path))


def _err(message: str) -> None:
    from transplanter.twin.report import printable

    print(printable(message), file=sys.stderr)


def cmd_export(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.scene import export_scene

    try:
        overrides = _overrides(args)
        if args.seed is not None:
            overrides["scenario.seed"] = args.seed
        config = assemble(load_scenario(args.scenario, overrides), preflight=False)
        path = export_scene(config.scene, config.seed, args.out)
    except (ScenarioError, fileio.FileRefused) as exc:
        _err(f"export refused: {exc}")
        return EXIT_REFUSED
    print(f"scene of {_show(config.name)} (seed {config.seed}) written to {_show(path)}")
    print(f"view it with: python -m mujoco.viewer --mjcf {_show(path)}")
    return EXIT_OK


def cmd_hmi(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.machine.eeprom import EepromError, EepromImage
    from transplanter.machine.hmi import (
        MAX_KEY_SCRIPT_BYTES,
        Hmi,
        KeyScriptError,
        parse_keys,
        run_keys,
        run_terminal,
    )

    if args.keys is not None and args.keys_file is not None:
        _err("give the keys either with --keys or with --keys-file, not both")
        return EXIT_REFUSED
    try:
        target = fileio.check_output(args.out, ".eeprom")
    except fileio.FileRefused as exc:
        _err(f"--out: {exc}")
        return EXIT_REFUSED
    try:
        if args.keys is not None:
            keys = parse_keys(args.keys, "--keys")
        elif args.keys_file is not None:
            text = fileio.read_text_input(args.keys_file, MAX_KEY_SCRIPT_BYTES, "key script")
            keys = parse_keys(text, str(args.keys_file))
        else:
            keys = None
    except (KeyScriptError, fileio.FileRefused) as exc:
        _err(f"hmi refused: {exc}")
        return EXIT_REFUSED
    if keys is None and not (sys.stdin.isatty() and sys.stdout.isatty()):
        _err(
            "hmi: no terminal for the interactive keypad; give the keys with --keys '...' or "
            "--keys-file FILE"
        )
        return EXIT_REFUSED
    image = None
    if args.start_from is not None:
        try:
            image = EepromImage.load(args.start_from)
        except EepromError as exc:
            _err(f"--from refused: {exc}")
            return EXIT_REFUSED
    machine = _machine(args)
    if machine is None:
        return EXIT_REFUSED
    hmi = Hmi(machine, target, image)
    if keys is None:
        run_terminal(hmi)
    else:
        if args.show_screens:
            print(f"power-on (homed at t = {hmi.port.t:.2f} s)\n{hmi.lcd_text()}")

        def show(i: int, key: str, h: Hmi) -> None:
            print(f"key {i + 1}: {key}\n{h.lcd_text()}")

        run_keys(hmi, keys, show if args.show_screens else None)
        if not args.show_screens:
            print(hmi.lcd_text())
    if hmi.refused:
        print(f"refused: {_show(hmi.last_refusal)}")
    if hmi.writes:
        print(
            f"EEPROM image written to {_show(args.out)} (M_pp {hmi.data.m_pp}); run it with: "
            f"transplanter trial {_show(args.scenario)} --eeprom {_show(args.out)}"
        )
        return EXIT_OK
    if keys is not None:
        _err(
            "the key sequence ended without writing the EEPROM image (menu 6 Write EEPROM, then #)"
        )
        return 1
    print("no EEPROM image written")
    return EXIT_OK


def cmd_replay(args: argparse.Namespace) -> int:
    from transplanter.viewing.playback import replay

    return replay(args.file)


def cmd_serve(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.machine.marlin import LineNoise
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import format_summary
    from transplanter.twin.serve import PtyEndpoint, RemoteHost, SerialEndpoint, format_stats
    from transplanter.twin.sim import Twin
    from transplanter.twin.trial import TrialInterrupted, run_trial

    if not (0 <= args.inject_errors <= 1):
        _err(f"--inject-errors is the share of lines with a byte error, 0..1: {args.inject_errors}")
        return EXIT_REFUSED
    if not (math.isfinite(args.keepalive_s) and args.keepalive_s >= 0):
        _err(f"--keepalive-s must be >= 0 s (0: none), got {args.keepalive_s}")
        return EXIT_REFUSED
    targets = _output_targets(args)
    if targets is None:
        return EXIT_REFUSED
    try:
        config = _single_trial_config(args)
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    try:
        endpoint = PtyEndpoint() if args.port is None else SerialEndpoint(args.port, args.baud)
    except Exception as exc:  # pyserial's SerialException, or no pty on this system
        _err(f"cannot open {args.port or 'a pseudo-terminal'}: {exc}")
        return EXIT_REFUSED
    noise = LineNoise(args.inject_errors, args.inject_seed) if args.inject_errors > 0 else None
    host = RemoteHost(
        endpoint, config.machine, realtime=args.realtime, until_done=args.until_done,
        keepalive_s=args.keepalive_s, noise=noise,
    )  # fmt: skip
    mode = "real time" if args.realtime else "as fast as the handshake allows"
    print(f"serving {config.name} on {endpoint.path} ({mode}); connect a host there", flush=True)
    interrupted = False
    try:
        result = run_trial(
            config, record_path=targets["--record"], record_rate_hz=args.record_rate,
            twin_factory=lambda c: Twin(c, remote=host), horizon_s=math.inf,
        )  # fmt: skip
    except TrialInterrupted as stop:
        result, interrupted = stop.result, True
    finally:
        endpoint.close()
    stats = host.stats()
    print(format_summary(result))
    print(format_stats(stats))
    status = EXIT_OK
    if targets["--json"] is not None:
        payload = result.to_dict()
        payload["serial"] = stats.to_dict()
        try:
            fileio.write_json_atomic(targets["--json"], payload)
            print(f"results written to {_show(args.json)}")
        except OSError as exc:
            _err(f"--json: the results could not be written to {_show(args.json)}: {exc}")
            status = EXIT_OUTPUT_FAILED
    if result.recording_error is not None:
        _err(f"--record: {result.recording_error}")
        status = EXIT_OUTPUT_FAILED
    if interrupted:
        return EXIT_INTERRUPTED
    if status != EXIT_OK:
        return status
    return _trial_status(result)  # 4: the machine stopped (a stall, a homing failure)


def cmd_pgf(args: argparse.Namespace) -> int:
    from transplanter.machine.pgf import PGF
    from transplanter.machine.serial_host import SerialPGF
    from transplanter.scenario.assemble import machine_config
    from transplanter.scenario.schema import ScenarioError, load_scenario

    try:
        overrides = _overrides(args)
        if args.seedlings is not None:
            overrides["scenario.seedlings"] = args.seedlings
        machine = machine_config(load_scenario(args.scenario, overrides))
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    try:
        import serial

        port = serial.Serial(args.port, baudrate=args.baud, timeout=0)
    except Exception as exc:  # SerialException: no such device, busy, no permission
        _err(f"cannot open {args.port}: {exc}")
        return EXIT_REFUSED
    pgf = PGF(machine.eeprom, machine.pgf)
    total = len(pgf.program)
    print(f"streaming {total} lines of the taught cycle to {args.port}", flush=True)
    try:
        run = SerialPGF(pgf, port, name=args.port).run()
    finally:
        port.close()
    print(
        f"{run.lines_sent} lines sent, {run.resends} resent after line errors, "
        f"{run.wall_time_s:.1f} s"
    )
    if run.fault is not None:
        _err(f"PGF stopped: {run.fault}")
        return EXIT_FIRMWARE_FAULT
    print("done: every line acknowledged")
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="transplanter",
        description="MuJoCo digital twin of a five-bar pot-seedling transplanter.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("ik", help="joint angles for a point of the plane (mm)")
    p.add_argument("x", type=ascii_float, help="x in mm")
    p.add_argument("y", type=ascii_float, help="y in mm")
    _scenario_arg(p)
    p.set_defaults(func=cmd_ik)

    p = sub.add_parser("plan", help="plan a G-code file: duration and steps of every line")
    p.add_argument("file", type=Path)
    _scenario_arg(p)
    p.set_defaults(func=cmd_plan)

    p = sub.add_parser(
        "trial",
        help="run a headless pick-and-drop trial",
        epilog="exit status: 0 done, 2 scenario or output path refused, 3 the trial is not valid "
        "(a MuJoCo warning or divergence, or the program did not finish in its simulated "
        "time: 60 s + 30 s per seedling), 4 the firmware faulted (a line was refused), 5 a "
        "result file or the recording could not be written, 130 interrupted (Ctrl-C)",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    _set_arg(p)
    p.add_argument("--seedlings", type=ascii_int, default=None, help="override scenario.seedlings")
    p.add_argument("--seed", type=ascii_int, default=None, help="override scenario.seed")
    p.add_argument(
        "--seeds",
        default=None,
        help="one trial per seed ('41-44', '1,3,5-7') and the pooled success rate with an "
        "interval from the spread between trials",
    )
    p.add_argument("--json", type=Path, default=None, help="write results to this JSON file")
    p.add_argument("--record", type=Path, default=None, help="write a rerun .rrd recording")
    p.add_argument(
        "--record-rate", type=ascii_float, default=60.0, help="recording rate in Hz (> 0)"
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument(
        "--no-preflight",
        action="store_true",
        help="skip the check of every taught point and move before the trial: the SGF then "
        "refuses an unreachable move itself (exit status 4), as the real firmware would",
    )
    p.add_argument(
        "--eeprom",
        type=Path,
        default=None,
        metavar="FILE",
        help="run from an EEPROM image (as `transplanter hmi` writes it; CRC checked): its "
        "taught data replace the scenario's [taught] section, and the results' overrides "
        "name the image",
    )
    p.add_argument(
        "--clips-of-failures",
        type=Path,
        default=None,
        metavar="DIR",
        help="write an MP4 of every failed seedling's pick (approach to drop) to "
        "DIR/seedling_023_not_gripped.mp4 (needs pip install 'transplanter[video]'); "
        "the results are the same as without",
    )
    p.add_argument(
        "--clip-fps", type=ascii_float, default=15.0, help="frame rate of the clips (15)"
    )
    p.add_argument("--clip-size", default="320x240", help="clip size WIDTHxHEIGHT (320x240)")
    p.add_argument(
        "--clip-camera",
        default="overview",
        help="named camera of the clips: overview, funnel, gripper_closeup (overview)",
    )
    p.set_defaults(func=cmd_trial)

    p = sub.add_parser(
        "render",
        help="run a trial headless and write it as an MP4 video",
        description="Runs the trial as `transplanter trial` does (same results) and films a "
        "named camera with MuJoCo's offscreen renderer at --fps frames per second of "
        "simulated time; each frame shows the simulated time, the seedling in progress and "
        "the last verdict. Headless, MUJOCO_GL=egl is used unless MUJOCO_GL is set. Needs "
        "pip install 'transplanter[video]'.",
        epilog="exit status: 0 done, 2 refused (options, scenario, output path, no video "
        "extra, no OpenGL context), 3 invalid physics, 4 firmware fault, 5 the video could "
        "not be written, 130 interrupted (no video is written)",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    p.add_argument("--out", type=Path, required=True, help="the .mp4 file to write")
    p.add_argument("--json", type=Path, default=None, help="write the trial's results to JSON")
    p.add_argument(
        "--seedlings-of",
        default=None,
        metavar="I,J-K",
        help="film only the cycles of these seedlings (0-based, as in the results: '23,24'), "
        "each from its first line to the release plus 0.5 s",
    )
    p.add_argument(
        "--camera",
        default="overview",
        help="named camera: overview, funnel, gripper_closeup (overview)",
    )
    p.add_argument("--fps", type=ascii_float, default=30.0, help="frames per second (30)")
    p.add_argument("--width", type=ascii_int, default=640, help="frame width in px (640)")
    p.add_argument("--height", type=ascii_int, default=480, help="frame height in px (480)")
    p.add_argument("--shadows", action="store_true", help="draw shadows and reflections (slower)")
    p.add_argument("--seedlings", type=ascii_int, default=None, help="override scenario.seedlings")
    p.add_argument("--seed", type=ascii_int, default=None, help="override scenario.seed")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _set_arg(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser(
        "view",
        help="watch a trial live in MuJoCo's viewer (needs a display)",
        description="Runs the trial with the firmware driving the physics and shows it in "
        "MuJoCo's passive viewer, paced to real time times --speed; the overlay shows the "
        "simulated time, the seedlings done and the last verdict. Closing the window stops "
        "the trial. Dragging bodies in the viewer pushes them: the results then differ "
        "from `transplanter trial`.",
        epilog="exit status: 0 done or window closed, 2 refused (no display, scenario), 3 "
        "invalid physics, 4 firmware fault, 130 interrupted (Ctrl-C)",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    p.add_argument("--speed", type=ascii_float, default=1.0, help="simulated s per wall s (1.0)")
    p.add_argument("--seedlings", type=ascii_int, default=None, help="override scenario.seedlings")
    p.add_argument("--seed", type=ascii_int, default=None, help="override scenario.seed")
    _set_arg(p)
    p.set_defaults(func=cmd_view)

    p = sub.add_parser(
        "export",
        help="write the scene a trial builds (pots, seedlings, conveyor, drop tube) as MJCF",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    p.add_argument("out", type=Path, help="the .xml file to write (meshes go to assets/ beside)")
    p.add_argument("--seed", type=ascii_int, default=None, help="override scenario.seed")
    _set_arg(p)
    p.set_defaults(func=cmd_export)

    p = sub.add_parser(
        "hmi",
        help="teach the machine on an emulated 20x4 LCD and 4x4 keypad; write the EEPROM image",
        description="The paper's teach mode (docs/hmi.md): jog the arm (a real SGF, homed "
        "at power-on) with the keys, store the pickups' approach and grip points and the "
        "drop point, enter M_pp, the elbow angles, Z_up/Z_low and the speeds, and write the "
        "EEPROM image with its CRC to --out (menu 6). With --keys or --keys-file the keys "
        "are pressed in order and the final LCD is printed; without, on a terminal, the "
        "keypad is interactive (curses; q quits). Key map: menus A up, B down, # select, * "
        "back, a digit picks its item; values: digits, D point, C delete, # save; jog: 4/6 "
        "X, 8/2 Y, 9/3 Z, 5 step 10/1/0.1 mm, # store.",
        epilog="exit status: 0 the image was written (or an interactive session ended), "
        "1 the key sequence ended without writing it, 2 refused (options, scenario, a bad "
        "key in the script, --from image, --out path)",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    p.add_argument("--out", type=Path, required=True, help="the EEPROM image to write (.eeprom)")
    p.add_argument(
        "--keys",
        default=None,
        help="keys to press, e.g. '1 0 5#' (0-9 A-D * #; spaces ignored, ';' to the end of "
        "the line is a comment)",
    )
    p.add_argument("--keys-file", type=Path, default=None, help="a file of keys to press")
    p.add_argument(
        "--from",
        dest="start_from",
        type=Path,
        default=None,
        metavar="IMAGE",
        help="start from this EEPROM image's data (to change some of it) instead of a blank one",
    )
    p.add_argument("--show-screens", action="store_true", help="print the LCD after every key")
    _set_arg(p)
    p.set_defaults(func=cmd_hmi)

    p = sub.add_parser(
        "sweep",
        help="run a grid of settings x seeds in parallel; tables and plots in --out",
        description="One trial per (setting, seed), judged as `transplanter trial` judges it. "
        "Results in --out: runs.jsonl (a line per finished run), runs.csv, settings.csv "
        "(seeds pooled per setting), sweep.json (what was run) and PNG plots. Rerunning the "
        "same command resumes (finished runs are skipped); a different sweep into the same "
        "directory is refused.",
        epilog="exit status: 0 done (runs that failed are rows with their error), 2 refused "
        "before any run, 5 a result file could not be written, 130 interrupted (Ctrl-C: "
        "finished runs are kept; rerun to finish)",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    p.add_argument(
        "--vary",
        action="append",
        required=True,
        metavar="KEY=LO:HI:STEP|KEY=a,b,c",
        help="a key to vary, in its file unit: a range with HI included "
        "(taught.z_low_mm=26:46:2) or a list (motion.profile=trapezoid,scurve); repeatable "
        "(the grid is every combination)",
    )
    p.add_argument("--seeds", default="1", help="seeds of every setting ('1-5', '1,3'); 1")
    p.add_argument(
        "--seedlings", type=ascii_int, default=None, help="seedlings per trial (the scenario's)"
    )
    p.add_argument(
        "--workers",
        type=_workers,
        default=1,
        help="parallel trials: a number or auto (every CPU); default 1",
    )
    p.add_argument("--out", type=Path, required=True, help="directory for the results")
    p.add_argument(
        "--backend",
        choices=("process", "ray"),
        default="process",
        help="process: a pool of processes on this machine (default); ray: a Ray cluster "
        "(pip install 'transplanter[ray]')",
    )
    p.add_argument("--address", default=None, help="Ray cluster address (with --backend ray)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _set_arg(p)
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser(
        "tune",
        help="search scenario keys with Optuna for high success and short cycles",
        description="Optuna study with two objectives: maximise the lower end of the 95 %% "
        "interval of the success rate pooled over --seeds, minimise the mean cycle time. The "
        "study is kept in SQLite (--storage): the same command resumes it, and "
        "`optuna-dashboard sqlite:///results/tune.db` opens it in a browser. Writes "
        "trials.csv, pareto.csv, pareto.png and tuned.toml (the point with the highest lower "
        "bound, ties: the shortest cycle; `transplanter trial OUT/tuned.toml` runs it). Needs "
        "pip install 'transplanter[tune]'.",
        epilog="exit status: 0 done, 2 refused before any trial, 5 a result file could not be "
        "written, 130 interrupted (finished trials stay in the study)",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    p.add_argument(
        "--param",
        action="append",
        required=True,
        metavar="KEY=LO..HI",
        help="a key to tune within [LO, HI] in its file unit (whole numbers for integer "
        "keys), e.g. taught.z_low_mm=28..40; repeatable",
    )
    p.add_argument("--trials", type=ascii_int, default=20, help="trials in the study (20)")
    p.add_argument("--seeds", default="1-2", help="seeds each point is judged on ('1-2')")
    p.add_argument(
        "--seedlings", type=ascii_int, default=None, help="seedlings per trial (the scenario's)"
    )
    p.add_argument(
        "--storage", type=Path, default=Path("results/tune.db"), help="SQLite file of the study"
    )
    p.add_argument("--study", default="tune", help="study name in the storage (tune)")
    p.add_argument("--out", type=Path, default=Path("results/tune"), help="output directory")
    p.add_argument(
        "--workers", type=_workers, default=1, help="seeds run in parallel (a number or auto)"
    )
    p.add_argument("--sampler-seed", type=ascii_int, default=0, help="seed of the TPE sampler (0)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _set_arg(p)
    p.set_defaults(func=cmd_tune)

    p = sub.add_parser(
        "calibrate",
        help="fit uncertain scenario keys to your machine's observed success (and cycle)",
        description="Fits the --fit keys so that the twin's success rate, pooled over --seeds, "
        "matches the observed K/N (and, with --cycle-s, the mean cycle time): an Optuna "
        "study minimising the binomial deviance of twin against observation (plus the cycle "
        "mismatch beyond --cycle-tol-s). Reports the fitted point and, per key, the range of "
        "evaluated values whose twin rate lies inside the observation's Wilson 95 % interval. "
        "Writes calibration.csv, calibration.json and calibrated.toml (base = the scenario, "
        "only the fitted and --set keys) into --out. Needs pip install 'transplanter[tune]'.",
        epilog="exit status: 0 done, 2 refused before any trial, 5 a result file could not be "
        "written, 130 interrupted (the files hold the trials that finished)",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    p.add_argument(
        "--observed",
        required=True,
        metavar="K/N",
        help="successes K of N seedlings over your machine's trials, e.g. 112/120",
    )
    p.add_argument(
        "--fit",
        action="append",
        default=[],
        metavar="KEY=LO..HI",
        help="a key to fit within [LO, HI] in its file unit, e.g. taught.z_low_mm=18..40; "
        "repeatable",
    )
    p.add_argument(
        "--cycle-s", type=ascii_float, default=None, help="observed mean cycle time in s"
    )
    p.add_argument(
        "--cycle-tol-s",
        type=ascii_float,
        default=0.1,
        help="a twin cycle within this of --cycle-s matches (0.1 s)",
    )
    p.add_argument("--trials", type=ascii_int, default=20, help="points to evaluate (20)")
    p.add_argument("--seeds", default="1-3", help="seeds each point is run on ('1-3')")
    p.add_argument(
        "--seedlings", type=ascii_int, default=None, help="seedlings per trial (the scenario's)"
    )
    p.add_argument(
        "--storage",
        type=Path,
        default=None,
        help="SQLite file to keep the study in (the same command resumes it); default: memory",
    )
    p.add_argument("--study", default="calibrate", help="study name in the storage (calibrate)")
    p.add_argument("--out", type=Path, default=Path("results/calibrate"), help="output directory")
    p.add_argument(
        "--workers", type=_workers, default=1, help="seeds run in parallel (a number or auto)"
    )
    p.add_argument(
        "--backend",
        choices=("process", "ray", "inline"),
        default="process",
        help="process: a pool of processes (default); ray: a Ray cluster; inline: this process",
    )
    p.add_argument("--address", default=None, help="Ray cluster address (with --backend ray)")
    p.add_argument("--sampler-seed", type=ascii_int, default=0, help="seed of the TPE sampler (0)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _set_arg(p)
    p.set_defaults(func=cmd_calibrate)

    p = sub.add_parser(
        "serve",
        help="the SGF and the physics behind a pseudo-terminal or serial port (Marlin dialect)",
        epilog="one host session: it ends when the host closes the pty (or, with --until-done, "
        "when the taught program is done); exit status 0 done, 2 refused, 3 physics not "
        "valid, 4 the machine stopped on a fault (a stall, a homing failure), 5 a result "
        "file could not be written, 130 interrupted",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    _set_arg(p)
    p.add_argument("--seedlings", type=ascii_int, default=None, help="override scenario.seedlings")
    p.add_argument("--seed", type=ascii_int, default=None, help="override scenario.seed")
    p.add_argument("--port", default=None, help="a serial port (pyserial) instead of a new pty")
    p.add_argument("--baud", type=ascii_int, default=115200, help="baud rate of --port")
    p.add_argument(
        "--realtime",
        action="store_true",
        help="pace the physics to the wall clock (default: as fast as the handshake allows)",
    )
    p.add_argument(
        "--until-done",
        action="store_true",
        help="end once the scenario's taught program has been answered (default: when the "
        "host closes the port)",
    )
    p.add_argument(
        "--keepalive-s",
        type=ascii_float,
        default=2.0,
        help="'busy: processing' every this many s while a line runs (Marlin: 2; 0: none)",
    )
    p.add_argument(
        "--inject-errors",
        type=ascii_float,
        default=0.0,
        metavar="RATE",
        help="share of received lines given one byte error (a flipped bit or a dropped byte)",
    )
    p.add_argument("--inject-seed", type=ascii_int, default=0, help="seed of --inject-errors")
    p.add_argument("--json", type=Path, default=None, help="write results to this JSON file")
    p.add_argument("--record", type=Path, default=None, help="write a rerun .rrd recording")
    p.add_argument(
        "--record-rate", type=ascii_float, default=60.0, help="recording rate in Hz (> 0)"
    )
    p.set_defaults(func=cmd_serve)

    p = sub.add_parser(
        "pgf",
        help="stream the taught cycle (the PGF) to a serial SGF: `serve`, or a board",
        epilog="exit status 0 every line acknowledged, 2 refused, 4 the PGF stopped (a line "
        "refused, or no reply within the bus timeout)",
    )
    p.add_argument("scenario", help="scenario file, or a packaged scenario's name (paper)")
    _set_arg(p)
    p.add_argument("--seedlings", type=ascii_int, default=None, help="override scenario.seedlings")
    p.add_argument("--port", required=True, help="serial device of the SGF, e.g. /dev/ttyUSB0")
    p.add_argument("--baud", type=ascii_int, default=115200, help="baud rate (115200)")
    p.set_defaults(func=cmd_pgf)

    p = sub.add_parser("replay", help="open a recorded trial in the rerun viewer")
    p.add_argument("file", type=Path)
    p.set_defaults(func=cmd_replay)
    return parser


def main(argv: list[str] | None = None) -> int:
    # rerun's own log lines would repeat a failed recording's one-line report on stderr
    os.environ.setdefault("RUST_LOG", "off")
    args = build_parser().parse_args(argv)
    if args.command == "render" or getattr(args, "clips_of_failures", None) is not None:
        from transplanter.viewing.video import prepare_gl

        prepare_gl()  # MuJoCo reads MUJOCO_GL when it is first imported
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        _err("interrupted")
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
