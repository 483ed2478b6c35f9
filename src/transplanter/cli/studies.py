"""The commands of many trials: `sweep` (a grid of settings x seeds), `tune` (an Optuna
search) and `calibrate` (fit keys to a machine's observed success)."""

from __future__ import annotations

import argparse
import functools
import os
import sys
from pathlib import Path
from typing import Any

from transplanter.cli.common import (
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_OUTPUT_FAILED,
    EXIT_REFUSED,
    OPTIONS,
    _err,
    _overrides,
    _progress,
    _seeds,
    _show,
    add_options,
    ascii_float,
    ascii_int,
)


def _workers(text: str) -> int:
    """--workers N or auto (every CPU of this machine)."""
    if text == "auto":
        return os.cpu_count() or 1
    n = ascii_int(text)
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: give at least 1 worker, or auto")
    return n


# The options of the studies, with the shared ones: each study runs its trials on seedlings of
# the scenario's number unless told, in parallel.
STUDY_OPTIONS: dict[str, dict[str, Any]] = {
    **OPTIONS,
    "--seedlings": {
        "type": ascii_int,
        "default": None,
        "help": "seedlings per trial (the scenario's)",
    },
    "--workers": {
        "type": _workers,
        "default": 1,
        "help": "seeds run in parallel (a number or auto)",
    },
    "--out": {"type": Path, "help": "output directory"},
    "--address": {"default": None, "help": "Ray cluster address (with --backend ray)"},
    "--sampler-seed": {"type": ascii_int, "default": 0, "help": "seed of the TPE sampler (0)"},
}
_add = functools.partial(add_options, table=STUDY_OPTIONS)
TUNE_OUT, CALIBRATE_OUT = Path("results/tune"), Path("results/calibrate")  # made when missing


def _check_out_parent(out: Path, made: Path | None = None) -> None:
    """SweepRefused when the folder --out would be made in does not exist, as --json refuses
    a file in a missing folder (sweep made the whole of `--out /missing/x/y`); checked before
    anything runs or is created. `made`: the command's default --out, made as before."""
    from transplanter.studies.sweep import SweepRefused

    out = Path(out)
    try:
        if out == made or out.exists() or out.is_symlink() or os.path.lexists(out.parent):
            return  # what is there is judged when the study opens or makes --out
    except OSError:
        return  # a parent that cannot be searched: refused when --out is made
    raise SweepRefused(f"--out {_show(out)}: {_show(out.parent)} does not exist; create it first")


def register(sub) -> None:
    _sweep_parser(sub)
    _compare_parser(sub)
    _tune_parser(sub)
    _calibrate_parser(sub)


def _seedlings(args: argparse.Namespace, overrides: dict[str, Any]) -> int:
    """--seedlings, or the scenario's (with the --set overrides) when not given: the job's
    unit count (schema.units_of: the trays' max_cells, the pool's tomatoes)."""
    if args.seedlings is not None:
        return args.seedlings
    from transplanter.scenario.schema import load_scenario, units_of

    return units_of(load_scenario(args.scenario, overrides))


def _sweep_parser(sub) -> None:
    p = sub.add_parser(
        "sweep",
        help="run a grid of settings x seeds in parallel; tables and plots in --out",
        description="One trial per (setting, seed), judged as `transplanter trial` judges it. "
        "Results in --out: runs.jsonl (a line per finished run), runs.csv, settings.csv "
        "(seeds pooled per setting), sweep.json (what was run) and PNG plots. Rerunning the "
        "same command resumes (finished runs are skipped); a different sweep into the same "
        "directory is refused.",
        epilog="exit status: 0 done (runs that failed are rows with their error), 2 refused "
        "before any run (another sweep writing --out included: nothing is touched), 5 a "
        "result file could not be written, 130 interrupted (Ctrl-C: finished runs are kept, "
        "runs.csv and settings.csv hold them; rerun to finish), 143 the same for SIGTERM "
        "(the pool's workers are stopped)",
    )
    _add(p, "scenario")
    p.add_argument(
        "--vary",
        action="append",
        required=True,
        metavar="KEY=LO:HI:STEP|KEY=a,b,c",
        help="a key to vary, in its file unit: a range with HI included "
        "(taught.z_low_mm=26:46:2) or a list (motion.profile=trapezoid,scurve); repeatable "
        "(the grid is every combination)",
    )
    _add(p, "--seeds", default="1", help="seeds of every setting ('1-5', '1,3'); 1")
    _add(p, "--seedlings")
    _add(p, "--workers", help="parallel trials: a number or auto (every CPU); default 1")
    _add(p, "--out", required=True, help="directory for the results")
    p.add_argument(
        "--backend",
        choices=("process", "ray"),
        default="process",
        help="process: a pool of processes on this machine (default); ray: a Ray cluster "
        "(pip install 'transplanter[ray]')",
    )
    p.add_argument(
        "--design",
        choices=("full", "L9"),
        default="full",
        help="full: every combination (default); L9: the nine runs of the L9(3^4) orthogonal "
        "array over 2-4 keys of three values each, with the range analysis (k1-k3, R per "
        "key) printed and in range_analysis.txt / .csv",
    )
    p.add_argument(
        "--range-analysis",
        action="store_true",
        help="the range analysis of a full grid too (each key's values are its levels)",
    )
    _add(p, "--address", "--quiet", "--set", "--report")
    p.set_defaults(func=cmd_sweep)


def cmd_sweep(args: argparse.Namespace) -> int:
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.studies.jobs import job_of
    from transplanter.studies.sweep import (
        SweepRefused,
        SweepSpec,
        check_backend,
        format_value,
        parse_vary,
        run_sweep,
    )
    from transplanter.twin.report import estimate_line

    seeds = _seeds(args)
    if seeds is None:
        return EXIT_REFUSED
    try:
        overrides = _overrides(args)
        axes = tuple(parse_vary(v) for v in args.vary)
        seedlings = _seedlings(args, overrides)
        spec = SweepSpec(args.scenario, axes, tuple(seeds), seedlings, overrides, args.design)
        job = job_of(spec.check())  # a job with its own run (transplanter.runs); None: the twin's
        check_backend(args.backend, args.workers, args.address)
        _check_out_parent(args.out)
    except (ScenarioError, SweepRefused) as exc:
        _err(f"sweep refused: {exc}")
        return EXIT_REFUSED
    unit = "seedlings" if job is None else job.unit
    each = f"{seedlings} {unit}" if seedlings else f"all the {unit} of one run"
    print(
        f"{spec.runs_total} runs: {len(spec.settings())} settings x {len(seeds)} seeds, "
        f"{each} each, {args.workers} {args.backend} worker(s)"
    )
    base = load_scenario(args.scenario, spec.base_overrides())
    # the pots that are bodies: the window of live rows, not the belt's length
    pots = min(base.conveyor.rows, base.conveyor.live_rows) * base.conveyor.cols
    estimate = estimate_line(spec.runs_total * seedlings, pots, args.workers)
    if estimate is not None and not args.quiet and job is None:  # the five-bar's estimate
        print(f"{estimate}; a rerun resumes", file=sys.stderr)
    try:
        report = run_sweep(
            spec, args.out, backend=args.backend, workers=args.workers, address=args.address,
            progress=_progress(args), range_analysis=args.range_analysis,
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
    # failures by kind as columns: the kinds that occurred in any run, summed per setting
    kinds = [
        f for f in (report.rows[0] if report.rows else {})
        if f.startswith("fail_") and any(r.get(f) for r in report.rows)
    ]  # fmt: skip
    per_setting: dict[tuple, dict[str, int]] = {}
    for r in report.rows:
        sums = per_setting.setdefault(tuple(r[k] for k in spec.keys), dict.fromkeys(kinds, 0))
        for f in kinds:
            sums[f] += r.get(f) or 0
    names = [f.removeprefix("fail_") for f in kinds]
    head = "  ".join(f"{k:>{width}}" for k in spec.keys)
    means = job.means if job is not None else ()  # the job's own columns, seeds averaged
    print(
        f"{head}  {'success':>16}  {'95 % CI':>13}  {'cycle s':>7}  errors"
        + "".join(f"  {n}" for n in names)
        + "".join(f"  {m}" for m in means)
    )
    for a in report.settings:
        values = "  ".join(f"{format_value(a[k]):>{width}}" for k in spec.keys)
        sums = per_setting.get(tuple(a[k] for k in spec.keys), {})
        failures = "".join(
            f"  {sums.get(f, 0):>{len(n)}}" for f, n in zip(kinds, names, strict=True)
        )
        if a["success_rate"] is None:
            print(f"{values}  {'-':>16}  {'-':>13}  {'-':>7}  {a['errors']:>6}{failures}")
            continue
        rate = f"{100 * a['success_rate']:.1f} % ({a['successes']}/{a['seedlings']})"
        ci = f"{100 * a['ci95_low']:.1f}-{100 * a['ci95_high']:.1f} %"
        cycle = "-" if a["cycle_time_s"] is None else f"{a['cycle_time_s']:.3f}"
        own = "".join(
            f"  {'-' if a.get(m) is None else format(a[m], '.4g'):>{len(m)}}" for m in means
        )
        print(f"{values}  {rate:>16}  {ci:>13}  {cycle:>7}  {a['errors']:>6}{failures}{own}")
    failed = [r for r in report.rows if r["error"] is not None]
    for r in failed[:5]:
        where = " ".join(f"{k}={format_value(r[k])}" for k in spec.keys)
        _err(f"run {where} seed {r['seed']}: {r['error']}")
    if len(failed) > 5:
        _err(f"... and {len(failed) - 5} more runs with an error (see runs.csv)")
    if report.range_text is not None:
        print()
        print(report.range_text)
    elif report.range_note is not None:
        _err(report.range_note)
    _report_sweep(args, spec, report)
    ranged = ", range_analysis.txt, range_analysis.csv" if report.range_text else ""
    print(f"results in {_show(args.out)}: runs.jsonl, runs.csv, settings.csv, sweep.json{ranged}")
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


def _report_sweep(args: argparse.Namespace, spec, report) -> None:
    """Fill the sweep's --report: the settings and the runs (settings.csv, runs.csv) as
    tables, its plots embedded."""
    data = getattr(args, "report_data", None)
    if data is None:
        return
    from transplanter.studies.plots import seed_ranges
    from transplanter.viewing import html_report

    data.seeds = seed_ranges(sorted(spec.seeds))
    data.tables = [
        html_report.records_table("settings (seeds pooled)", "settings.csv", report.settings),
        html_report.records_table("runs", "runs.csv", report.rows),
    ]
    data.pictures = [html_report.Picture.of_file(p) for p in report.plots if p.exists()]
    if report.range_text is not None:
        data.notes.append("range analysis: range_analysis.txt in --out (also printed above)")
    data.ready = True


def _report_compare(args: argparse.Namespace, seeds, report) -> None:
    """Fill the comparison's --report: a table of its rows per job (compare.json's rows),
    its pictures embedded."""
    data = getattr(args, "report_data", None)
    if data is None:
        return
    from transplanter.studies.compare import COMPARE_PNG, job_png, jobs_of
    from transplanter.studies.plots import seed_ranges
    from transplanter.viewing import html_report

    data.seeds = seed_ranges(sorted(seeds))
    jobs = jobs_of(report.rows)
    data.tables = [
        html_report.records_table(
            f"{job}: ranked",
            f"compare.json#rows?workcell={job}",
            [r for r in report.rows if r["workcell"] == job],
        )  # fmt: skip
        for job in jobs
    ]
    names = [COMPARE_PNG, *(job_png(j) for j in jobs)] if len(jobs) > 1 else [COMPARE_PNG]
    data.pictures = [
        html_report.Picture.of_file(report.out / n) for n in names if (report.out / n).exists()
    ] if report.plot is not None else []  # fmt: skip
    data.ready = True


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


def _share(text: str) -> float:
    """--success-floor: a share 0-1 (0.9) or a percentage (90%)."""
    pct = text.endswith("%")
    value = ascii_float(text[:-1] if pct else text)
    return value / 100.0 if pct else value


def _compare_parser(sub) -> None:
    p = sub.add_parser(
        "compare",
        help="machines on their jobs side by side: success, cycle, plants/h, damage, drives",
        description="Each scenario (a robot, its effector and a job) runs over the same seeds "
        "as `transplanter trial` judges it (through the sweep machinery: parallel, resumable, "
        "Ray when asked); its runs are pooled into one row: pooled success with its 95 % "
        "interval, the cycle or time per operation, plants per hour, damage, failures by "
        "kind, the robot's peak motor torque, the drives' energy per seedling and mean "
        "power, and what the drives cost ([costs] drives_usd). Rows are ranked within their "
        "job by plants per hour among those whose success interval lies at or above "
        "--success-floor, then the undecided (with the seedlings that would decide them), "
        "then those below; overlapping plants-per-hour intervals tie. In --out: "
        "compare.json (the rows), compare.csv, compare.txt (a table per job), compare.png "
        "(and compare_JOB.png per job) and runs/<scenario>/ (each scenario's sweep); "
        "rerunning the same command resumes.",
        epilog="exit status: 0 done, 2 refused before any run, 5 a result file could not be "
        "written, 130 interrupted (Ctrl-C: finished runs are kept; rerun to finish), 143 the "
        "same for SIGTERM (the pool's workers are stopped)",
    )
    p.add_argument(
        "scenarios",
        nargs="+",
        metavar="SCENARIO",
        help="scenario files or packaged names (paper serial_arm_pots delta_refill)",
    )
    _add(p, "--seeds", default="1-5", help="seeds every scenario runs on ('1-5', '1,3'); 1-5")
    _add(p, "--seedlings", help="units per trial, each job's own: seedlings on the pot line, "
         "cells of the delta's tray (delta_refill.max_cells), tomatoes (pool_to_belt.count); "
         "default each scenario's own")  # fmt: skip
    p.add_argument(
        "--success-floor",
        type=_share,
        default=0.9,
        metavar="SHARE",
        help="rows whose pooled success's 95 %% interval lies at or above this (0.9 or 90%%) "
        "rank first within their job, those it holds next (undecided), those below it last; 0.9",
    )
    _add(p, "--workers", help="parallel trials: a number or auto (every CPU); default 1")
    _add(p, "--out", required=True, help="directory for the results")
    p.add_argument("--backend", choices=("process", "ray"), default="process",
                   help="process (default) or ray (pip install 'transplanter[ray]')")  # fmt: skip
    _add(p, "--address", "--quiet", "--set", "--report")
    p.set_defaults(func=cmd_compare)


def cmd_compare(args: argparse.Namespace) -> int:
    from transplanter.scenario.schema import ScenarioError
    from transplanter.studies.compare import CompareSpec, run_compare
    from transplanter.studies.sweep import SweepRefused, check_backend

    seeds = _seeds(args)
    if seeds is None:
        return EXIT_REFUSED
    try:
        overrides = _overrides(args)
        spec = CompareSpec(
            tuple(args.scenarios), tuple(seeds), args.seedlings, overrides, args.success_floor
        )
        check_backend(args.backend, args.workers, args.address)
        _check_out_parent(args.out)
    except (ScenarioError, SweepRefused) as exc:
        _err(f"compare refused: {exc}")
        return EXIT_REFUSED
    quiet = args.quiet

    def started(label: str) -> None:
        if not quiet:
            print(f"{label}: {len(seeds)} trial(s)", file=sys.stderr, flush=True)

    try:
        report = run_compare(
            spec, args.out, backend=args.backend, workers=args.workers, address=args.address,
            progress=_progress(args), on_scenario=started,
        )  # fmt: skip
    except (ScenarioError, SweepRefused) as exc:
        _err(f"compare refused: {exc}")
        return EXIT_REFUSED
    except OSError as exc:
        _err(f"--out: the results could not be written to {_show(args.out)}: {exc}")
        return EXIT_OUTPUT_FAILED
    print(report.table, end="")
    _report_compare(args, seeds, report)
    if report.skipped:
        print(f"{report.skipped} runs were already in {_show(args.out)} (skipped)")
    if report.plot_error:
        print(f"the plot could not be drawn: {report.plot_error}", file=sys.stderr)
    from transplanter.studies.compare import job_png, jobs_of

    jobs = jobs_of(report.rows)
    pictures = ["compare.png", *(job_png(j) for j in jobs)] if len(jobs) > 1 else ["compare.png"]
    print(f"results in {_show(args.out)}: compare.json, compare.csv, compare.txt"
          + ("".join(f", {p}" for p in pictures) if report.plot else ""))  # fmt: skip
    if report.interrupted:
        print("interrupted: rerun the same command to finish", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_OK


def _tune_parser(sub) -> None:
    p = sub.add_parser(
        "tune",
        help="search scenario keys with Optuna for high success and short cycles",
        description="Optuna study with two objectives: maximise the lower end of the 95 % "
        "interval of the success rate pooled over --seeds, minimise the mean cycle time. The "
        "study is kept in SQLite (--storage): the same command resumes it, and "
        "`optuna-dashboard sqlite:///results/tune.db` opens it in a browser. Writes "
        "trials.csv, pareto.csv, pareto.png and tuned.toml (the point with the highest lower "
        "bound, ties: the shortest cycle; `transplanter trial OUT/tuned.toml` runs it). Needs "
        "pip install 'transplanter[tune]'.",
        epilog="exit status: 0 done, 2 refused before any trial (--out's files are checked "
        "first), 5 a result file could not be written, 130 interrupted (finished trials stay "
        "in the study), 143 the same for SIGTERM",
    )
    _add(p, "scenario")
    p.add_argument(
        "--param",
        action="append",
        required=True,
        metavar="KEY=LO..HI",
        help="a key to tune within [LO, HI] in its file unit (whole numbers for integer "
        "keys), e.g. taught.z_low_mm=28..40; repeatable",
    )
    p.add_argument("--trials", type=ascii_int, default=20, help="trials in the study (20)")
    _add(p, "--seeds", default="1-2", help="seeds each point is judged on ('1-2')")
    _add(p, "--seedlings")
    p.add_argument(
        "--storage", type=Path, default=Path("results/tune.db"), help="SQLite file of the study"
    )
    p.add_argument("--study", default="tune", help="study name in the storage (tune)")
    _add(p, "--out", default=TUNE_OUT)
    _add(p, "--workers", "--sampler-seed", "--quiet", "--set")
    p.set_defaults(func=cmd_tune)


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
        _check_out_parent(args.out, made=TUNE_OUT)
        report = run_tune(
            spec, args.trials, args.storage, args.study, args.out, workers=args.workers,
            progress=_progress(args),
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
    if report.note is not None:
        print(report.note)
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


def _calibrate_parser(sub) -> None:
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
        epilog="exit status: 0 done, 2 refused before any trial (--out's files are checked "
        "first), 5 a result file could not be written, 130 interrupted (the files hold the "
        "trials that finished), 143 the same for SIGTERM",
    )
    _add(p, "scenario")
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
    _add(p, "--seeds", default="1-3", help="seeds each point is run on ('1-3')")
    _add(p, "--seedlings")
    p.add_argument(
        "--storage",
        type=Path,
        default=None,
        help="SQLite file to keep the study in (the same command resumes it); default: memory",
    )
    p.add_argument("--study", default="calibrate", help="study name in the storage (calibrate)")
    _add(p, "--out", default=CALIBRATE_OUT)
    _add(p, "--workers")
    p.add_argument(
        "--backend",
        choices=("process", "ray", "inline"),
        default="process",
        help="process: a pool of processes (default); ray: a Ray cluster; inline: this process",
    )
    _add(p, "--address", "--sampler-seed", "--quiet", "--set")
    p.set_defaults(func=cmd_calibrate)


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
        _check_out_parent(args.out, made=CALIBRATE_OUT)
        report = run_calibrate(
            spec, args.trials, args.out, storage=args.storage, study_name=args.study,
            workers=args.workers, backend=args.backend, address=args.address,
            progress=_progress(args),
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
