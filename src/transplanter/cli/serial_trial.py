"""`transplanter trial` for the serial arm's jobs (`[robot] kind = "serial4"` in the
`pool_to_belt` workcell, seed 004): the paper's ten targets (Tables 3-5), its 18 gripper
trials (Table 6) and the pick-and-place of the pool's tomatoes (transplanter.twin.serial_arm),
printed as tables beside the paper's numbers; with --seeds, the pick-and-place pooled.
`render serial_arm` runs the same trial and films its pick and place
(viewing.serial_arm.SerialVideo)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from transplanter.cli.common import (
    EXIT_OK,
    EXIT_REFUSED,
    _err,
    _finish,
    _progress,
    _seeds,
    _show,
    video_written,
)

__all__ = ["format_tables", "render", "run_trial"]


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
    from transplanter.twin.serial_arm import PAPER_MEAN_ERRORS_CM, PAPER_MEAN_JOINT_ERRORS_PCT

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


def run_trial(
    args: argparse.Namespace,
    overrides: dict[str, Any],
    json_path: Path | None,
    record_path: Path | None = None,
) -> int:
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.studies.stats import pooled_rate
    from transplanter.twin.serial_arm import DEFINITIONS, run_serial_arm

    for option, value in (
        ("--clips-of-failures", args.clips_of_failures),
        ("--eeprom", args.eeprom),
    ):
        if value is not None:
            _err(f"{option}: not available for the serial arm's trial (docs/serial_arm.md)")
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
    from transplanter.machine.servo_drives import frame_steps
    from transplanter.scenario.assemble import require_awake
    from transplanter.twin.serial_arm import require_own_motion

    try:
        frame_steps(scenario.physics.timestep_s)
        if scenario.workcell.kind != "conveyor_tube":  # the pot line sleeps its pots
            require_awake(scenario, "the serial arm's trial")
        require_own_motion(scenario, "the serial arm's trial")
    except ValueError as exc:
        _err(f"scenario refused: {exc}")
        return EXIT_REFUSED
    if scenario.workcell.kind == "conveyor_tube":
        from transplanter.twin.serial_pots import check_placement

        try:
            check_placement(scenario)
        except ScenarioError as exc:
            _err(f"scenario refused: {exc}")
            return EXIT_REFUSED
        return _run_pots(args, scenario, seeds, json_path, record_path)
    from transplanter.twin.report import progress_bar

    results, outputs = [], []
    for seed in seeds:
        recording = None
        if record_path is not None:
            from transplanter.viewing.serial_arm import SerialRecording

            recording = SerialRecording(record_path, args.record_rate)
        bar, update = progress_bar(scenario.pool_to_belt.count, _progress(args), "tomato")
        try:
            result = run_serial_arm(scenario, seed, recording=recording, progress=update)
        finally:
            if bar is not None:
                bar.close()
        results.append(result)
        print(format_tables(result))
        if recording is not None and result.recording_error is None:
            shown = _show(record_path)
            outputs.append(
                (f"recording of the pick and place written to {shown} (view it with: "
                 f"transplanter replay {shown})", None)
            )  # fmt: skip
    if args.seeds is None:
        payload: dict[str, Any] = results[0].to_dict()
    else:
        picked = [r.pick_totals.get("picked", 0) for r in results]
        done = [r.pick_totals.get("successes", 0) for r in results]
        pooled = pooled_rate(done, picked)
        payload = {"trials": [r.to_dict() for r in results], "pooled": pooled.to_dict()}
        cycles = [r.pick_totals.get("cycle_time_s", math.nan) for r in results]
        cycles = [c for c in cycles if math.isfinite(c)]
        payload["mean_cycle_time_s"] = sum(cycles) / len(cycles) if cycles else None
        lo, hi = pooled.ci95
        print(
            f"pooled over {pooled.trials} runs: {100 * pooled.success_rate:.1f} % of tomatoes "
            f"onto the belt ({pooled.successes}/{pooled.seedlings}), 95 % CI "
            f"{100 * lo:.1f}-{100 * hi:.1f} % ({pooled.method})"
        )
    summary = "definitions:\n" + "\n".join(f"  {k}: {v}" for k, v in DEFINITIONS.items())
    return _finish(args, results, summary, payload, json_path, outputs=outputs)


def _preflight(scenario, args: argparse.Namespace) -> None:
    """Refuse before the trial runs: the camera is not in the pick-and-place scene, or no
    OpenGL context can be made (video.RenderRefused, video.GLUnavailable)."""
    from transplanter.machine.servo_drives import frame_steps
    from transplanter.scenario.assemble import require_awake
    from transplanter.twin.serial_arm import _compile, _scene, require_own_motion
    from transplanter.viewing import video

    try:
        frame_steps(scenario.physics.timestep_s)
        require_awake(scenario, "the serial arm's trial")
        require_own_motion(scenario, "the serial arm's trial")
    except ValueError as exc:
        raise video.RenderRefused(str(exc)) from None
    spec, cfg = _scene(scenario, "pool_to_belt", tomatoes=0)
    model, _ = _compile(spec, cfg)
    video.check_frames(args.width, args.height, args.fps, model.opt.timestep)
    video.FrameGrabber(model, args.width, args.height, args.camera).close()


def render(
    args: argparse.Namespace, overrides: dict[str, Any], target: Path, json_path: Path | None
) -> int:
    """`transplanter render` of the serial arm: the trial as `trial` runs it (all three jobs,
    the same results) with its pick and place filmed by viewing.serial_arm.SerialVideo (on
    the pot line: `cli.serial_pots_trial.render`)."""
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.twin.serial_arm import DEFINITIONS, run_serial_arm
    from transplanter.viewing import video
    from transplanter.viewing.serial_arm import SerialVideo

    for option, value in (("--seedlings-of", args.seedlings_of), ("--cells-of", args.cells_of)):
        if value is not None:
            _err(f"render refused: {option}: the serial arm's job has tomatoes, not seedlings or "
                 "cells; it is filmed whole")  # fmt: skip
            return EXIT_REFUSED
    try:
        scenario = load_scenario(args.scenario, overrides)
        observer = SerialVideo(target, args.width, args.height, args.fps, args.camera, args.shadows)
        _preflight(scenario, args)
    except (ScenarioError, video.RenderRefused, video.GLUnavailable) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    try:
        result = run_serial_arm(scenario, None, recording=observer)
    except (video.GLUnavailable, video.RenderRefused) as exc:
        observer.abort()
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    result.recording_error = None  # the video's error is reported below, not as --record's
    print(format_tables(result))
    written = video_written(observer, args, target, "the pick and place")
    summary = "definitions:\n" + "\n".join(f"  {k}: {v}" for k, v in DEFINITIONS.items())
    return _finish(args, [result], summary, result.to_dict(), json_path, outputs=[written])


def pots_line(r) -> str:
    """One pot job's result in a line (`twin.pot_job.PotJobResult`, any robot's)."""
    d = r.to_dict()
    kinds = ", ".join(f"{k} {v}" for k, v in d["outcomes"].items())
    cycle = "-" if not math.isfinite(r.cycle_time_s) else f"{r.cycle_time_s:.3f} s"
    planner = f", {d['planner']}" if "planner" in d else ""
    rate = "-" if d["plants_per_hour"] is None else f"{d['plants_per_hour']:.0f}"
    line = (
        f"{r.trial} (seed {r.seed}{planner}): {r.successes}/{r.seedlings} seedlings into the "
        f"tube ({100 * d['success_rate']:.1f} %; {kinds}); cycle {cycle}, "
        f"{rate} plants/h; largest shoot bend "
        f"{d['max_stem_bend_deg']:.1f} deg; peak squeeze {d['peak_squeeze_n']:.2f} N; "
        f"{r.sim_time_s:.1f} s simulated in {r.wall_s:.1f} s"
    )
    if r.fault:
        line += f"\n  fault: {r.fault}"
    return line


def _run_pots(
    args: argparse.Namespace, scenario, seeds, json_path: Path | None, record_path=None
) -> int:
    from transplanter.twin.serial_pots import DEFINITIONS, run_serial_pots

    return run_pot_seeds(
        args, scenario, seeds, json_path, run_serial_pots, pots_line, DEFINITIONS, record_path
    )


def render_pots(
    args: argparse.Namespace,
    overrides: dict[str, Any],
    target: Path,
    json_path: Path | None,
    run,
    definitions,
    check,
) -> int:
    """`transplanter render` of a pot job on `twin.loop.StepLoop` (the serial arm's, the
    delta's): one trial (`--seed`) as `trial` runs it, the same results, filmed by
    `viewing.loop_video.LoopVideo`; `check(scenario)` refuses what the job cannot run."""
    from transplanter.machine.servo_drives import frame_steps
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.twin.report import format_summary, progress_bar
    from transplanter.viewing import video
    from transplanter.viewing.loop_video import LoopVideo

    for option, value in (("--seedlings-of", args.seedlings_of), ("--cells-of", args.cells_of)):
        if value is not None:
            _err(f"render refused: {option}: a pot job on the pot line is filmed whole; give "
                 "--seedlings to film fewer")  # fmt: skip
            return EXIT_REFUSED
    try:
        scenario = load_scenario(args.scenario, overrides)
        frame_steps(scenario.physics.timestep_s)
        check(scenario)
        observer = LoopVideo(target, args.width, args.height, args.fps, args.camera, args.shadows)
    except (ScenarioError, ValueError, video.RenderRefused, video.GLUnavailable) as exc:
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    bar, update = progress_bar(scenario.meta.seedlings, _progress(args), "seedling")
    try:
        result = run(scenario, None, progress=update, observers=[observer])
    except (video.GLUnavailable, video.RenderRefused) as exc:
        observer.abort()
        _err(f"render refused: {exc}")
        return EXIT_REFUSED
    finally:
        if bar is not None:
            bar.close()
    result.recording_error = None  # the video's error is reported below, not as --record's
    print(format_summary(result))
    print(pots_line(result))
    written = video_written(observer, args, target, "the pot job")
    summary = "definitions:\n" + "\n".join(f"  {k}: {v}" for k, v in definitions.items())
    return _finish(args, [result], summary, result.to_dict(), json_path, outputs=[written])


def view_pots(args: argparse.Namespace, overrides: dict[str, Any], run, check) -> int:
    """`transplanter view` of a pot job on `twin.loop.StepLoop` (the serial arm's, the
    delta's): one trial as `trial` runs it, shown live (`viewing.loop_live.LoopLiveViewer`);
    `check(scenario)` refuses what the job cannot run. Closing the window stops it."""
    from transplanter.machine.servo_drives import frame_steps
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.twin.report import format_summary
    from transplanter.viewing.live import ViewerUnavailable
    from transplanter.viewing.loop_live import LoopLiveViewer, ViewerClosed

    try:
        scenario = load_scenario(args.scenario, overrides)
        frame_steps(scenario.physics.timestep_s)
        check(scenario)
    except (ScenarioError, ValueError) as exc:
        _err(f"view refused: {exc}")
        return EXIT_REFUSED
    observer = LoopLiveViewer(args.speed)
    try:
        result = run(scenario, None, observers=[observer])
    except ViewerUnavailable as exc:
        _err(f"view: {exc}")
        return EXIT_REFUSED
    except ViewerClosed:
        print(f"viewer closed at t = {observer.closed_at:.1f} s simulated, after "
              f"{len(observer.verdicts)} verdicts ({observer.successes} successes); "
              "`transplanter trial` gives the whole run's results")  # fmt: skip
        return EXIT_OK
    print(format_summary(result))
    print(pots_line(result))
    return _finish(args, [result], interrupted=result.interrupted)


def run_pot_seeds(
    args: argparse.Namespace,
    scenario,
    seeds,
    json_path: Path | None,
    run,
    line,
    definitions,
    record_path: Path | None = None,
) -> int:
    """A pot job's trials (the serial arm's or the delta's on the five-bar's line): `run`
    per seed, a `line` each, the pooled rate and mean cycle over --seeds, the JSON and the
    definitions; with `record_path` (one seed) a rerun recording of the loop
    (`viewing.loop_recording.LoopRecording`)."""
    from transplanter.studies.stats import pooled_rate
    from transplanter.twin.report import progress_bar

    results, outputs = [], []
    for seed in seeds:
        bar, update = progress_bar(scenario.meta.seedlings, _progress(args), "seedling")
        observers = []
        if record_path is not None:
            from transplanter.viewing.loop_recording import LoopRecording

            observers.append(LoopRecording(record_path, args.record_rate))
        try:
            result = run(scenario, seed, progress=update, observers=observers)
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
        if args.seeds is None:  # the pot line's summary, as the five-bar's
            from transplanter.twin.report import format_summary

            print(format_summary(result))
        print(line(result))
    if args.seeds is None:
        payload: dict[str, Any] = results[0].to_dict()
    else:
        pooled = pooled_rate([r.successes for r in results], [r.seedlings for r in results])
        payload = {"trials": [r.to_dict() for r in results], "pooled": pooled.to_dict()}
        cycles = [r.cycle_time_s for r in results if math.isfinite(r.cycle_time_s)]
        payload["mean_cycle_time_s"] = sum(cycles) / len(cycles) if cycles else None
        lo, hi = pooled.ci95
        print(
            f"pooled over {pooled.trials} runs: {100 * pooled.success_rate:.1f} % of seedlings "
            f"into the tube ({pooled.successes}/{pooled.seedlings}), 95 % CI "
            f"{100 * lo:.1f}-{100 * hi:.1f} % ({pooled.method})"
        )
    summary = "definitions:\n" + "\n".join(f"  {k}: {v}" for k, v in definitions.items())
    return _finish(args, results, summary, payload, json_path, outputs=outputs)
