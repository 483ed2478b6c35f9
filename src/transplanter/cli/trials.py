"""The commands of one scenario's trial: `trial` (headless; --seeds pools several),
`render` (an MP4 of it), `view` (MuJoCo's live viewer) and `export` (its scene as MJCF)."""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
from pathlib import Path
from typing import Any

from transplanter.cli.common import (
    EXIT_OK,
    EXIT_OUTPUT_FAILED,
    EXIT_REFUSED,
    Output,
    _clash,
    _err,
    _finish,
    _inputs,
    _output_targets,
    _progress,
    _run,
    _seeds,
    _show,
    _single_trial_config,
    _trial_overrides,
    add_options,
    ascii_float,
    ascii_int,
    video_written,
)


def register(sub) -> None:
    _trial_parser(sub)
    _render_parser(sub)
    _view_parser(sub)
    _export_parser(sub)


def _trial_parser(sub) -> None:
    p = sub.add_parser(
        "trial",
        help="run a headless pick-and-drop trial",
        epilog="exit status: 0 done, 2 scenario or output path refused, 3 the trial is not valid "
        "(a MuJoCo warning or divergence, or the program did not finish in its simulated "
        "time: 60 s + 30 s per seedling), 4 the firmware faulted (a line was refused), 5 a "
        "result file or the recording could not be written, 130 interrupted (Ctrl-C), 143 "
        "stopped by SIGTERM (as Ctrl-C: the JSON says interrupted, a partial recording goes "
        "to NAME.partial.rrd); a Ctrl-C or SIGTERM once the trial has finished waits until "
        "its results are written, then exits 130/143 with them complete",
    )
    add_options(p, "scenario", "--set", "--seedlings", "--seed", "--seeds")
    add_options(p, "--json", "--record", "--record-rate", "--quiet", "--report")
    p.add_argument(
        "--explain",
        action="store_true",
        help="print what each number of the job's summary means (its definitions: always in "
        "the JSON and docs/results.md)",
    )
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


def cmd_trial(args: argparse.Namespace) -> int:
    from transplanter import interrupts
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import definitions_block, estimate_line, format_summary
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
    # the trial's set-up, with stop signals held: one that comes here stops the trial as its
    # loop starts (nothing judged, "interrupted": true in --json, a partial recording)
    with interrupts.held():
        if not _read_eeprom(args):
            return EXIT_REFUSED
        try:
            overrides = _trial_overrides(args)
        except ScenarioError as exc:
            _err(f"scenario refused: {exc}")
            return EXIT_REFUSED
        job = _job_run(args, overrides)  # a job with its own run (transplanter.runs)
        if job is None and args.seeds is None:
            try:
                scenario = _trial_scenario(args, overrides)
                # MuJoCo is imported once the scenario has loaded: a refusal comes first
                from transplanter.scenario.assemble import assemble

                config = assemble(scenario, preflight=not args.no_preflight)
            except ScenarioError as exc:
                _err(f"scenario refused: {exc}")
                return EXIT_REFUSED
            if clips is not None and not _clip_dir_ready(Path(args.clips_of_failures)):
                return EXIT_REFUSED
            estimate = estimate_line(config.seedlings, config.scene.body_rows * config.scene.cols)
            if estimate is not None and not args.quiet:
                print(estimate, file=sys.stderr)
    if job is not None:
        interrupts.raise_pending()  # a stop while its scenario was read stops it at once
        return _job_trial(job, args, overrides, targets["--json"], targets["--record"])
    if args.seeds is not None:
        if args.seed is not None or args.record is not None:
            _err("--seeds runs one trial per seed: drop --seed and --record (record one seed)")
            return EXIT_REFUSED
        seeds = _seeds(args)
        if seeds is None:
            return EXIT_REFUSED
        interrupts.raise_pending()  # a stop while the scenario was read stops it at once
        return _pooled_trials(args, overrides, seeds, targets["--json"])
    try:
        result, interrupted = _run(
            config, _progress(args), record_path=targets["--record"],
            record_rate_hz=args.record_rate, observers=[clips] if clips is not None else (),
        )  # fmt: skip
    except (GLUnavailable, RenderRefused) as exc:
        _err(f"--clips-of-failures: {exc}")
        return EXIT_REFUSED
    summary, payload, outputs = format_summary(result), result.to_dict(), []
    if args.explain:
        summary += "\n" + definitions_block(payload["definitions"])
    if clips is not None:
        payload["clips"] = [dataclasses.asdict(c) for c in clips.clips]
        summary += "\n" + _clips_listing(clips, args.clips_of_failures)
        if clips.error is not None:
            outputs.append((None, f"--clips-of-failures: {clips.error}"))
    if args.record is not None:  # None, or why the recording could not be written
        payload["recording_error"] = result.recording_error
    if args.record is not None and result.recording_error is None:
        outputs.append(_recording_written(Path(args.record), interrupted))
    return _finish(
        args, [result], summary, payload, targets["--json"], interrupted=interrupted,
        note=f"interrupted after {result.judged} seedlings", outputs=outputs,
    )  # fmt: skip


def _job_run(args: argparse.Namespace, overrides: dict[str, Any]):
    """The run module of the scenario's job with its robot (`transplanter.runs`: JobRun), or
    None for the twin's own trial; None too for a scenario that does not load (the twin's
    path refuses it, saying why)."""
    from transplanter import runs
    from transplanter.scenario.schema import ScenarioError, load_scenario

    try:
        sc = load_scenario(args.scenario, overrides)
    except ScenarioError:
        return None
    return runs.of(sc)


def _refused_option(job, args: argparse.Namespace) -> str | None:
    """Why the job cannot honour an option the command was given (None: it can)."""
    for option, why in job.REFUSED_OPTIONS.items():
        value = getattr(args, option.lstrip("-").replace("-", "_"), None)
        if value is not None and value is not False:
            return why
    return None


def _job_scenario(job, args: argparse.Namespace, overrides: dict[str, Any], what: str):
    """The scenario, checked by the job (`JobRun.check`), or None after saying why not."""
    from transplanter.scenario.schema import ScenarioError, load_scenario

    try:
        scenario = load_scenario(args.scenario, overrides)
        job.check(scenario)
    except (ScenarioError, ValueError) as exc:
        _err(f"{what} refused: {exc}")
        return None
    return scenario


def _job_trial(job, args, overrides, json_path, record_path) -> int:
    """`transplanter trial` of a job with its own run (`transplanter.runs`): per seed a run
    with a progress bar over its units and its summary (a line per seed with --seeds, then
    the pooled rate); --record through the job's recorder; --explain its definitions."""
    from transplanter.scenario.schema import ScenarioError
    from transplanter.studies.stats import pooled_rate
    from transplanter.twin.report import definitions_block, progress_bar

    why = _refused_option(job, args)
    if why is not None:
        _err(why)
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
    scenario = _job_scenario(job, args, overrides, "scenario")
    if scenario is None:
        return EXIT_REFUSED
    results, outputs = [], []
    for seed in seeds:
        try:
            observers = [] if record_path is None else [
                job.recorder(scenario, record_path, args.record_rate)
            ]  # fmt: skip
        except ScenarioError as exc:
            _err(f"{exc}")
            return EXIT_REFUSED
        bar, update = progress_bar(job.total(scenario), _progress(args), job.UNIT)
        try:
            result = job.run(scenario, seed, progress=update, observers=observers)
        except ScenarioError as exc:
            _err(f"trial refused: {exc}")
            return EXIT_REFUSED
        finally:
            if bar is not None:
                bar.close()
        if record_path is not None and result.recording_error is None:
            shown = _show(record_path)
            outputs.append(
                (f"recording written to {shown} (view it with: transplanter replay {shown})",
                 None)
            )  # fmt: skip
        results.append(result)
        print(job.summary(result) if args.seeds is None else job.line(result))
    if args.seeds is None:
        payload: dict[str, Any] = results[0].to_dict()
    else:
        pooled = pooled_rate([r.successes for r in results], [r.seedlings for r in results])
        extra, lines = job.pool(results, pooled)
        payload = {"trials": [r.to_dict() for r in results], "pooled": pooled.to_dict(), **extra}
        print("\n".join(lines))
    # the definitions under --explain (else a hint to it: cli.common._finish)
    summary = definitions_block(dict(job.DEFINITIONS))
    return _finish(args, results, summary, payload, json_path, outputs=outputs)


def _job_render(job, args, overrides, target: Path, json_path: Path | None) -> int:
    """`transplanter render` of a job with its own run: one trial (`--seed`) as `trial` runs
    it, the same results, filmed by the job's filmer."""
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import progress_bar
    from transplanter.viewing import video

    why = _refused_option(job, args)
    if why is not None:
        _err(why)
        return EXIT_REFUSED
    scenario = _job_scenario(job, args, overrides, "render")
    if scenario is None:
        return EXIT_REFUSED
    subset = args.cells_of if args.cells_of is not None else args.seedlings_of
    try:
        observer = job.filmer(scenario, target, (args.width, args.height), args.fps,
                              args.camera, args.shadows, subset)  # fmt: skip
    except (ScenarioError, ValueError, video.RenderRefused, video.GLUnavailable) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    bar, update = progress_bar(job.total(scenario), _progress(args), job.UNIT)
    try:
        result = job.run(scenario, None, progress=update, observers=[observer])
    except (ScenarioError, video.GLUnavailable, video.RenderRefused) as exc:
        observer.abort()
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    finally:
        if bar is not None:
            bar.close()
    result.recording_error = None  # the video's error is reported below, not as --record's
    print(job.summary(result))
    written = video_written(observer, args, target, job.FILMED)
    return _finish(args, [result], None, result.to_dict(), json_path, outputs=[written])


def _job_view(job, args, overrides) -> int:
    """`transplanter view` of a job with its own run: one trial shown live by the job's
    viewer; closing the window stops it."""
    from transplanter.scenario.schema import ScenarioError
    from transplanter.viewing.live import ViewerUnavailable
    from transplanter.viewing.loop_live import ViewerClosed

    scenario = _job_scenario(job, args, overrides, "view")
    if scenario is None:
        return EXIT_REFUSED
    try:
        observer = job.viewer(scenario, args.speed)
    except ScenarioError as exc:
        _err(f"view refused: {exc}")
        return EXIT_REFUSED
    try:
        result = job.run(scenario, None, observers=[observer])
    except ViewerUnavailable as exc:
        _err(f"view: {exc}")
        return EXIT_REFUSED
    except ViewerClosed:
        print(f"viewer closed at t = {observer.closed_at:.1f} s simulated, after "
              f"{len(observer.verdicts)} verdicts ({observer.successes} successes); "
              "`transplanter trial` gives the whole run's results")  # fmt: skip
        return EXIT_OK
    print(job.summary(result))
    return _finish(args, [result], interrupted=getattr(result, "interrupted", False))


def _move_exported(staging: Path, target: Path) -> None:
    """Move an exported scene from `staging` to `target` and its mesh folders beside it:
    FileRefused (nothing moved) if a mesh folder there is a link or not a folder; each mesh
    replaces what is at its name, a planted link included, never writing through it."""
    from transplanter import fileio

    folders = sorted(p for p in staging.iterdir() if p.is_dir())
    for folder in folders:
        there = target.parent / folder.name
        if there.is_symlink() or (there.exists() and not there.is_dir()):
            kind = "a symbolic link" if there.is_symlink() else "not a directory"
            raise fileio.FileRefused(
                f"{there} is {kind}; export writes its meshes into {folder.name}/ itself: "
                "remove it or export elsewhere"
            )
    for folder in folders:
        there = target.parent / folder.name
        there.mkdir(exist_ok=True)
        for mesh in sorted(folder.iterdir()):
            os.replace(mesh, there / mesh.name)
    fileio.commit(staging / target.name, target)


def _recording_written(where: Path, interrupted: bool) -> Output:
    """Where the recording went (an interrupted trial's is .partial.rrd)."""
    if interrupted:
        where = where.with_name(where.stem + ".partial.rrd")
    shown = _show(where)
    return f"recording written to {shown} (view it with: transplanter replay {shown})", None


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
    from transplanter.scenario.schema import load_scenario

    scenario = load_scenario(args.scenario, overrides)
    image = getattr(args, "eeprom_image", None)
    if image is not None:
        from transplanter.scenario.assemble import with_eeprom

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


def _clips_listing(clips, directory) -> str:
    """The lines that list the failure clips written into `directory`."""
    if not clips.clips:
        return f"no failure clips: no seedling failed (or none was filmed) in {_show(directory)}"
    lines = [f"{len(clips.clips)} failure clip(s) written to {_show(directory)}:"]
    for c in clips.clips:
        cut = f", the first {c.dropped_frames} frames cut" if c.dropped_frames else ""
        lines.append(
            f"  {_show(Path(c.path).name)}  ({c.frames} frames, t {c.t_start_s:.2f}-"
            f"{c.t_end_s:.2f} s{cut})"
        )
    return "\n".join(lines)


def _pooled_trials(args, overrides: dict[str, Any], seeds: list[int], json_path) -> int:
    """`trial --seeds`: one trial per seed, each line printed as it finishes, then the pooled
    rate."""
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import ScenarioError
    from transplanter.studies.stats import pooled_rate
    from transplanter.twin.report import (
        estimate_line,
        format_failures_table,
        format_seed_row,
        seed_row_header,
        seeds_bar,
    )

    def config_of(seed: int):
        return assemble(
            _trial_scenario(args, {**overrides, "scenario.seed": seed}),
            preflight=not args.no_preflight,
        )

    try:  # the first seed's configuration now: a refused scenario is refused before any trial
        first = config_of(seeds[0])
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    pots = first.scene.body_rows * first.scene.cols  # the window of live rows
    estimate = estimate_line(first.seedlings * len(seeds), pots)
    if estimate is not None and not args.quiet:
        print(estimate, file=sys.stderr)
    print(seed_row_header())
    bar = seeds_bar(first.seedlings * len(seeds), _progress(args))
    results, interrupted = [], False
    for k, seed in enumerate(seeds):
        try:  # each seed's configuration when its turn comes (10,000 seeds start at once)
            config = first if k == 0 else config_of(seed)
        except ScenarioError as exc:
            _err(f"scenario refused at seed {seed}: {exc}")
            break
        update = None if bar is None else bar.for_trial(seed, k * first.seedlings)
        result, interrupted = _run(config, on_progress=update)
        if interrupted:
            break
        results.append(result)
        if bar is None:
            print(format_seed_row(seed, result))
        else:
            bar.write(format_seed_row(seed, result))
    if bar is not None:
        bar.close()
    table = format_failures_table(seeds, results)
    if table:
        print(table)
    payload: dict[str, Any] = {"trials": [r.to_dict() for r in results], "interrupted": interrupted}
    summary = None
    if results:
        pooled = pooled_rate([r.successes for r in results], [r.seedlings for r in results])
        payload["pooled"] = pooled.to_dict()
        lo, hi = pooled.ci95
        summary = (
            f"pooled over {pooled.trials} trial{'s' if pooled.trials != 1 else ''}: "
            f"{100 * pooled.success_rate:.1f} % "
            f"({pooled.successes}/{pooled.seedlings}), 95 % CI {100 * lo:.1f}-{100 * hi:.1f} % "
            f"({pooled.method})"
        )
        rates = [r.plants_per_hour for r in results if r.plants_per_hour is not None]
        if rates:
            payload["plants_per_hour"] = sum(rates) / len(rates)
            summary += f"; {payload['plants_per_hour']:.0f} plants per hour (the trials' mean)"
    return _finish(
        args, results, summary, payload, json_path, interrupted=interrupted,
        note=f"interrupted after {len(results)} trials",
    )  # fmt: skip


def _render_parser(sub) -> None:
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
        "not be written, 130 interrupted (no video is written), 143 SIGTERM (as Ctrl-C)",
    )
    add_options(p, "scenario")
    p.add_argument("--out", type=Path, required=True, help="the .mp4 file to write")
    add_options(p, "--json", help="write the trial's results to JSON")
    p.add_argument(
        "--seedlings-of",
        default=None,
        metavar="I,J-K",
        help="film only the cycles of these seedlings (0-based, as in the results: '23,24'), "
        "each from its first line to the release plus 0.5 s",
    )
    p.add_argument(
        "--cells-of",
        default=None,
        metavar="I,J-K",
        help="the delta's plug-tray job: film only the work on these planting cells (0-127, "
        "as the results' cells[].index), each from its first line to its last plus 0.5 s",
    )
    p.add_argument(
        "--camera",
        default="overview",
        help="named camera: overview, funnel, gripper_closeup; for the delta's job overview, "
        "trays, claws_closeup; for the serial arm's overview, gripper_closeup (overview)",
    )
    p.add_argument("--fps", type=ascii_float, default=30.0, help="frames per second (30)")
    p.add_argument("--width", type=ascii_int, default=640, help="frame width in px (640)")
    p.add_argument("--height", type=ascii_int, default=480, help="frame height in px (480)")
    p.add_argument("--shadows", action="store_true", help="draw shadows and reflections (slower)")
    add_options(p, "--seedlings", "--seed", "--quiet", "--set")
    p.set_defaults(func=cmd_render)


def cmd_render(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.scenario.schema import ScenarioError
    from transplanter.twin.report import format_summary
    from transplanter.viewing import video

    try:
        video.require_imageio()
        video.check_frames(args.width, args.height, args.fps)
        target = fileio.check_output(args.out, ".mp4")
        json_target = None if args.json is None else fileio.check_output(args.json)
    except (video.VideoUnavailable, video.RenderRefused, fileio.FileRefused) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    outputs = [("--out", args.out)] + ([] if args.json is None else [("--json", args.json)])
    clash = _clash(outputs, _inputs(args))
    if clash is not None:
        _err(f"render refused: {clash}")
        return EXIT_REFUSED
    try:
        overrides = _trial_overrides(args)
    except ScenarioError as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    job = _job_run(args, overrides)  # a job with its own run films it through its filmer
    if job is not None:
        return _job_render(job, args, overrides, target, json_target)
    if args.cells_of is not None:
        _err("render refused: --cells-of is for the delta's plug-tray job; give --seedlings-of")
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
    try:
        result, interrupted = _run(config, _progress(args), observers=[observer])
    except (video.GLUnavailable, video.RenderRefused) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    note = f"interrupted after {result.judged} seedlings; no video written"
    video_written = () if interrupted else [_video_written(args, observer)]
    return _finish(
        args, [result], format_summary(result), result.to_dict(), json_target,
        interrupted=interrupted, note=note, outputs=video_written,
    )  # fmt: skip


def _video_written(args: argparse.Namespace, observer) -> Output:
    """What the video came to: where it was written, or why it was not."""
    if observer.error is not None:
        return None, f"render: {observer.error}"
    n = observer.frames
    rate = f", {n / observer.render_s:.1f} frames/s" if observer.render_s > 0 else ""
    return (
        f"video written to {_show(args.out)}: {n} frames at {args.fps:g} fps "
        f"({n / args.fps:.1f} s), {args.width}x{args.height}, camera {_show(args.camera)}; "
        f"rendering and encoding took {observer.render_s:.1f} s{rate}"
    ), None


def _view_parser(sub) -> None:
    p = sub.add_parser(
        "view",
        help="watch a trial live in MuJoCo's viewer (needs a display)",
        description="Runs the trial with the firmware driving the physics and shows it in "
        "MuJoCo's passive viewer, paced to real time times --speed; the overlay shows the "
        "simulated time, the seedlings done and the last verdict. Closing the window stops "
        "the trial. Dragging bodies in the viewer pushes them: the results then differ "
        "from `transplanter trial`.",
        epilog="exit status: 0 done or window closed, 2 refused (no display, scenario), 3 "
        "invalid physics, 4 firmware fault, 130 interrupted (Ctrl-C), 143 SIGTERM",
    )
    add_options(p, "scenario")
    p.add_argument("--speed", type=ascii_float, default=1.0, help="simulated s per wall s (1.0)")
    add_options(p, "--seedlings", "--seed", "--set")
    p.set_defaults(func=cmd_view)


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

    try:
        overrides = _trial_overrides(args)
        job = _job_run(args, overrides)
        if job is not None:  # a job with its own run shows it through its viewer
            return _job_view(job, args, overrides)
        config = _single_trial_config(args)
    except ScenarioError as exc:
        _err(f"view refused: {exc}")
        return EXIT_REFUSED
    observer = live.LiveViewer(args.speed)
    try:
        result, _ = _run(config, observers=[observer])
    except live.ViewerUnavailable as exc:
        _err(f"view: {exc}")
        return EXIT_REFUSED
    print(format_summary(result))
    if observer.closed:
        print(f"viewer closed at t = {observer.closed_at:.1f} s simulated")
        return EXIT_OK
    return _finish(args, [result], interrupted=result.interrupted)


def _export_parser(sub) -> None:
    p = sub.add_parser(
        "export",
        help="write the scene a trial builds (pots, seedlings, conveyor, drop tube; for the "
        "delta's job its trays, plugs and bin) as MJCF",
    )
    add_options(p, "scenario")
    p.add_argument("out", type=Path, help="the .xml file to write (meshes go to assets/ beside)")
    add_options(p, "--seed", "--set")
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    import shutil
    import tempfile

    from transplanter import fileio
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.scene import export_scene

    try:
        path = fileio.check_output(args.out, ".xml")  # the user's name: a link is followed
        clash = _clash([("OUT", args.out)], _inputs(args))
        if clash is not None:
            raise fileio.FileRefused(clash)
        overrides = _trial_overrides(args)
        job = _job_run(args, overrides)  # a job with its own run writes its own scene
        if job is not None:
            config = load_scenario(args.scenario, overrides)
        else:
            config = assemble(load_scenario(args.scenario, overrides), preflight=False)
    except (ScenarioError, fileio.FileRefused) as exc:
        _err(f"export refused: {exc}")
        return EXIT_REFUSED
    # The scene is written into a fresh directory beside the target and moved into place, so
    # that no mesh is ever written through a link planted at assets/NAME.stl (a name the
    # program derives): os.replace puts the file in the link's place.
    staging = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    try:
        if job is not None:
            job.export(config, staging / path.name)
        else:
            export_scene(config.scene, config.seed, staging / path.name)
        _move_exported(staging, path)
    except (ScenarioError, fileio.FileRefused) as exc:
        _err(f"export refused: {exc}")
        return EXIT_REFUSED
    except OSError as exc:
        _err(f"export: the scene could not be written to {_show(path.parent)}: {exc}")
        return EXIT_OUTPUT_FAILED
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    print(f"scene of {_show(config.name)} (seed {config.seed}) written to {_show(path)}")
    print(f"view it with: python -m mujoco.viewer --mjcf {_show(path)}")
    return EXIT_OK
