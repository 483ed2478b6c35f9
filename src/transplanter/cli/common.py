"""What the commands share: the exit statuses, ASCII number types, the options declared once
(`OPTIONS`, `add_options`), reading --set/--seeds and the scenario, checking the output
paths, printing, and the one end of every command that runs trials (`_finish`).

Names with a leading underscore belong to the `transplanter.cli` package: its command
modules use them, nothing outside it should.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

DEFAULT_SCENARIO = "paper"  # the packaged paper scenario

EXIT_OK, EXIT_REFUSED, EXIT_INVALID_PHYSICS, EXIT_FIRMWARE_FAULT = 0, 2, 3, 4
EXIT_OUTPUT_FAILED = 5  # a result file or the recording could not be written
EXIT_INTERRUPTED = 130  # Ctrl-C, as shells report SIGINT
EXIT_TERMINATED = 143  # SIGTERM (a scheduler, `timeout`, a container stop), as shells report it


_FLOAT_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:inf|nan)", re.I)
_INT_RE = re.compile(r"[+-]?\d+")


def ascii_float(text: str) -> float:
    """A number written in ASCII (Python's float() also takes Unicode digits such as '١٠')."""
    if not (text.isascii() and _FLOAT_RE.fullmatch(text.strip())):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (ASCII digits 0-9)")
    return float(text)


def ascii_finite_float(text: str) -> float:
    """A finite number written in ASCII: `ascii_float` without inf and nan, and without what
    rounds to them ('1e309'), refused as written."""
    value = ascii_float(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def ascii_int(text: str) -> int:
    """A whole number written in ASCII digits."""
    if not (text.isascii() and _INT_RE.fullmatch(text.strip())):
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number (ASCII digits 0-9)")
    return int(text)


# The options several commands take, each declared once: add_options(parser, name, ...) adds
# them in the order named; keyword arguments change what one command says differently.
OPTIONS: dict[str, dict[str, Any]] = {
    "scenario": {"help": "scenario file, or a packaged scenario's name (paper)"},
    "--scenario": {
        "default": DEFAULT_SCENARIO,
        "help": "scenario file, or the name of a packaged scenario (default: paper)",
    },
    "--set": {
        "action": "append",
        "default": [],
        "metavar": "SECTION.KEY=VALUE",
        "help": "override a scenario key in its file unit, e.g. --set taught.z_low_mm=30 "
        '(a TOML value: 30, true, [0, 140], "scurve"); repeatable',
    },
    "--seedlings": {
        "type": ascii_int,
        "default": None,
        "help": "how many units the job does: seedlings on the pot line and the claws' bench "
        "(scenario.seedlings), cells of the tray (delta_refill.max_cells), tomatoes "
        "(pool_to_belt.count)",
    },
    "--seed": {"type": ascii_int, "default": None, "help": "override scenario.seed"},
    "--seeds": {
        "default": None,
        "help": "one trial per seed ('41-44', '1,3,5-7') and the pooled success rate with an "
        "interval from the spread between trials",
    },
    "--json": {"type": Path, "default": None, "help": "write results to this JSON file"},
    "--record": {"type": Path, "default": None, "help": "write a rerun .rrd recording"},
    "--record-rate": {"type": ascii_float, "default": 60.0, "help": "recording rate in Hz (> 0)"},
    "--quiet": {"action": "store_true", "help": "no progress bar"},
    "--report": {
        "type": Path,
        "default": None,
        "metavar": "FILE.html",
        "help": "also write one self-contained HTML file: what was printed, the results as "
        "tables, the pictures embedded, the scenario files as read, the command, the version "
        "and the seeds",
    },
}


def add_options(
    parser: argparse.ArgumentParser,
    *names: str,
    table: dict[str, dict[str, Any]] = OPTIONS,
    **changes: Any,
) -> None:
    """Add the named options of `table` (default: OPTIONS) to `parser`, in order, with
    `changes` (e.g. help=..., default=...) made to each."""
    for name in names:
        parser.add_argument(name, **{**table[name], **changes})


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


def _trial_overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The --set overrides with --seedlings and --seed, where the command has them and they
    are given: --seedlings as the job's unit count (schema.units_key: scenario.seedlings,
    delta_refill.max_cells, pool_to_belt.count), --seed as scenario.seed; ScenarioError for a
    malformed --set or a scenario that does not load."""
    from transplanter.scenario.schema import with_units

    overrides = _overrides(args)
    if getattr(args, "seed", None) is not None:
        overrides["scenario.seed"] = args.seed
    units = getattr(args, "seedlings", None)
    if units is not None:
        overrides = with_units(args.scenario, overrides, units)
    return overrides


def _seeds(args: argparse.Namespace) -> list[int] | None:
    """The --seeds list, or None after saying why it was refused."""
    from transplanter.studies.stats import parse_seeds

    try:
        return parse_seeds(args.seeds)
    except ValueError as exc:
        _err(f"--seeds: {exc}")
        return None


def _machine(args: argparse.Namespace):
    """The machine of a scenario (with --set, and --seedlings where the command has it), or
    None after saying why it was refused."""
    from transplanter.scenario.assemble import machine_config
    from transplanter.scenario.schema import ScenarioError, load_scenario

    try:
        return machine_config(load_scenario(args.scenario, _trial_overrides(args)))
    except ScenarioError as exc:
        _err(f"scenario refused: {exc}")
        return None


def _single_trial_config(args: argparse.Namespace):
    """The assembled config of one trial from SCENARIO, --set, --seedlings and --seed;
    ScenarioError when refused."""
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import load_scenario

    return assemble(load_scenario(args.scenario, _trial_overrides(args)), preflight=True)


def _output_targets(args: argparse.Namespace) -> dict[str, Path | None] | None:
    """The checked --json and --record paths (None where not given), or None after saying
    why one is refused (trial and serve): a path that cannot be written, or one that names
    an input or the other output (_clash)."""
    from transplanter import fileio

    targets: dict[str, Path | None] = {"--json": None, "--record": None}
    for option, path, suffix in (("--json", args.json, None), ("--record", args.record, ".rrd")):
        if path is not None:
            try:
                targets[option] = fileio.check_output(path, suffix)
            except fileio.FileRefused as exc:
                _err(f"{option}: {exc}")
                return None
    outputs = [(o, getattr(args, o[2:])) for o in targets if targets[o] is not None]
    clash = _clash(outputs, _inputs(args))
    if clash is not None:
        _err(clash)
        return None
    return targets


def _inputs(args: argparse.Namespace) -> list[tuple[str, Path]]:
    """The files a command reads, named for a message: the scenario and its base chain,
    and --eeprom and --keys-file where given."""
    from transplanter.scenario.schema import scenario_files

    found: list[tuple[str, Path]] = []
    scenario = getattr(args, "scenario", None)
    if scenario is not None:
        found += [("the scenario file", path) for path in scenario_files(scenario)]
    for option, what in (("eeprom", "the --eeprom image"), ("keys_file", "the --keys-file")):
        path = getattr(args, option, None)
        if path is not None:
            found.append((what, Path(path)))
    return found


def _clash(
    outputs: Sequence[tuple[str, Path]], inputs: Sequence[tuple[str, Path]] = ()
) -> str | None:
    """The one line that refuses an output naming an input (the scenario, --eeprom; through
    a link or a hard link too) or the same file as another output; None when all differ."""
    from transplanter import fileio

    for i, (option, path) in enumerate(outputs):
        for what, source in inputs:
            if fileio.same_file(path, source):
                return (
                    f"{option} {_show(path)} is {what} {_show(source)}: an output never "
                    "replaces an input; give the output another name"
                )
        for other, other_path in outputs[i + 1 :]:
            if fileio.same_file(path, other_path):
                return (
                    f"{option} {_show(path)} and {other} {_show(other_path)} name the same "
                    "file: give each output its own name"
                )
    return None


def _progress(args: argparse.Namespace) -> bool:
    """Whether to draw a progress bar: not with --quiet, and only on a terminal."""
    return not args.quiet and sys.stderr.isatty()


def _run(config, progress: bool = False, on_progress=None, **kwargs: Any):
    """run_trial(config, **kwargs) with a progress bar when `progress` (or the caller's own
    `on_progress(done, sim_t)`): (result, interrupted), an interrupted trial's result being the
    part that ran (a stop signal that came once the trial had finished is left pending: the
    result is whole, `interrupted` False)."""
    from transplanter.twin.report import progress_bar
    from transplanter.twin.trial import TrialInterrupted, run_trial

    bar, update = progress_bar(config.seedlings, progress and on_progress is None)
    update = on_progress if on_progress is not None else update
    try:
        return run_trial(config, progress=update, **kwargs), False
    except TrialInterrupted as stop:
        return stop.result, stop.result.interrupted
    finally:
        if bar is not None:
            bar.close()


# An output of a command besides --json: the line to print when it was written, or the error to
# report when it was not (exit status 5); (None, None) says nothing.
Output = tuple[str | None, str | None]


DEFINITIONS_HEAD = "definitions:"
"""How a job's block of definitions starts (what each number of its summary means)."""
EXPLAIN_HINT = "what each number means: --explain (and the JSON's definitions)"


def _finish(
    args: argparse.Namespace,
    results: Sequence[Any],
    summary: str | None = None,
    payload: Any = None,
    json_target: Path | None = None,
    *,
    interrupted: bool = False,
    note: str | None = None,
    outputs: Sequence[Output] = (),
) -> int:
    """How every command that runs trials ends (trial and its --seeds, render, view, serve):
    print the summary, write `payload` to --json, report a --record error of any result and
    the command's other `outputs` in order, then the exit status: 130 interrupted (after
    `note` on stderr, where given), 5 an output could not be written, 3 a trial not valid,
    4 a firmware fault, else 0. A stop signal while the results are written is held until
    they are (interrupts.held): the command line's exit status then says it came."""
    from transplanter import interrupts

    with interrupts.held():
        return _finish_held(
            args, results, summary, payload, json_target, interrupted=interrupted, note=note,
            outputs=outputs,
        )  # fmt: skip


def _finish_held(
    args: argparse.Namespace,
    results: Sequence[Any],
    summary: str | None,
    payload: Any,
    json_target: Path | None,
    *,
    interrupted: bool,
    note: str | None,
    outputs: Sequence[Output],
) -> int:
    from transplanter import fileio

    _report_trial(args, results, payload)
    if summary is not None:
        if summary.startswith(DEFINITIONS_HEAD) and not getattr(args, "explain", True):
            print(EXPLAIN_HINT)  # `trial` leads with the answer; --explain for the meanings
        else:
            print(summary)
    failed = False
    if json_target is not None:
        try:
            fileio.write_json_atomic(json_target, payload)
            print(f"results written to {_show(args.json)}")
        except OSError as exc:
            _err(f"--json: the results could not be written to {_show(args.json)}: {exc}")
            failed = True
    recording = [
        (None, f"--record: {r.recording_error}") for r in results if r.recording_error is not None
    ]
    for line, error in [*recording, *outputs]:
        if error is not None:
            _err(error)
            failed = True
        elif line is not None:
            print(line)
    if interrupted:
        if note is not None:
            _err(note)
        return EXIT_INTERRUPTED
    if failed:
        return EXIT_OUTPUT_FAILED
    if not all(r.valid for r in results):
        return EXIT_INVALID_PHYSICS
    return EXIT_FIRMWARE_FAULT if any(r.fault for r in results) else EXIT_OK


def _report_trial(args: argparse.Namespace, results: Sequence[Any], payload: Any) -> None:
    """Fill the --report of a trial (where the command has one) from the JSON it writes:
    its tables, a picture of the units of each records table with outcomes, the seeds."""
    report = getattr(args, "report_data", None)
    if report is None or not isinstance(payload, dict):
        return
    from transplanter.viewing import html_report

    report.tables = html_report.tables_of(payload, "result")
    report.pictures = [
        p for p in (html_report.units_picture(t) for t in report.tables) if p is not None
    ][:MAX_REPORT_PICTURES]
    seeds = [getattr(r, "seed", None) for r in results]
    report.seeds = ", ".join(str(s) for s in seeds if s is not None)
    report.ready = True


MAX_REPORT_PICTURES = 12
"""A trial's report draws the units of at most this many of its records tables."""


def report_target(args: argparse.Namespace) -> Path | None | bool:
    """The checked --report path (None without one), or False after saying why it is
    refused: a file that cannot be written, or one that names an input or another output."""
    from transplanter import fileio

    path = getattr(args, "report", None)
    if path is None:
        return None
    try:
        target = fileio.check_output(path, ".html")
    except fileio.FileRefused as exc:
        _err(f"--report: {exc}")
        return False
    outputs = [("--report", path)] + [
        (option, getattr(args, option[2:]))
        for option in ("--json", "--record")
        if getattr(args, option[2:], None) is not None
    ]
    inputs = _inputs(args) + [
        ("a scenario file", p)
        for name in getattr(args, "scenarios", None) or ()
        for p in _scenario_files(name)
    ]
    clash = _clash(outputs, inputs)
    if clash is not None:
        _err(clash)
        return False
    return target


def _scenario_files(name) -> list[Path]:
    from transplanter.scenario.schema import ScenarioError, scenario_files

    try:
        return scenario_files(name)
    except ScenarioError:
        return []  # refused by the command itself, saying why


def new_report(args: argparse.Namespace, argv: Sequence[str]):
    """The report a command fills (`args.report_data`): its title, the command line, the
    version, the --set overrides and the scenario files as read."""
    import shlex

    import transplanter
    from transplanter.viewing import html_report

    names = getattr(args, "scenarios", None) or [getattr(args, "scenario", None)]
    names = [n for n in names if n is not None]
    report = html_report.Report(
        title=f"transplanter {args.command} {' '.join(str(n) for n in names)}".strip(),
        command=shlex.join(["transplanter", *argv]),
        version=transplanter.__version__,
        overrides=[f"--set {item}" for item in getattr(args, "set", None) or ()],
        scenarios=html_report.scenario_texts(p for n in names for p in _scenario_files(n)),
    )
    return report


class StdoutCopy:
    """sys.stdout that keeps a copy of what is written (the report's summary: what the
    command printed), passing everything on."""

    def __init__(self, stream) -> None:
        self._stream = stream
        self._parts: list[str] = []

    def write(self, text: str) -> int:
        self._parts.append(text)
        return self._stream.write(text)

    @property
    def text(self) -> str:
        return "".join(self._parts)

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def write_report(args: argparse.Namespace, target: Path, summary: str) -> str | None:
    """Write the filled report (with `summary`, what the command printed) atomically; the
    error's message when it could not be written, None when written (or nothing to write)."""
    from transplanter import fileio
    from transplanter.viewing import html_report

    report = args.report_data
    if not report.ready:
        return None
    report.summary = summary
    try:
        fileio.write_text_atomic(target, html_report.render(report))
    except OSError as exc:
        return f"--report: the report could not be written to {_show(args.report)}: {exc}"
    print(f"report written to {_show(args.report)}")
    return None


def video_written(observer, args: argparse.Namespace, target: Path, what: str = ""):
    """A render's output line (`_finish`'s (written, error) pair): the video (of `what`), its
    frames, size, camera and the time rendering took; or the observer's error."""
    if observer.error is not None:
        return None, f"render: {observer.error}"
    n = observer.frames
    rate = f", {n / observer.render_s:.1f} frames/s" if observer.render_s > 0 else ""
    of = f" of {what}" if what else ""
    return (
        f"video{of} written to {_show(target)}: {n} frames at {args.fps:g} fps "
        f"({n / args.fps:.1f} s), {args.width}x{args.height}, camera {_show(args.camera)}; "
        f"rendering and encoding took {observer.render_s:.1f} s{rate}",
        None,
    )


def _show(path) -> str:
    from transplanter.twin.report import printable

    return printable(str(path))


def _err(message: str) -> None:
    from transplanter.twin.report import printable

    print(printable(message), file=sys.stderr)
