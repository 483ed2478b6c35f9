"""Parameter sweeps: a grid of scenario settings x seeds, one trial per (setting, seed).

Each run is judged exactly as `transplanter trial` judges it: the scenario is loaded with the
`--set` overrides plus the setting's values, assembled with preflight, and `run_trial` gives
the result. The runs go to a backend (`inline` in this process, `process`: a spawn process
pool, `ray`: a Ray cluster) and come back in any order; every row carries its setting and
seed, and the tables are sorted by the grid, so the numbers never depend on the backend, the
worker count or the order the runs finished in (only `wall_time_s` does).

Files in the output directory:

- `sweep.json`: the manifest (scenario, its overrides and digest, the varied keys and values,
  seeds, seedlings). A rerun with a different manifest is refused; with the same one the runs
  already in `runs.jsonl` are skipped (resume).
- `runs.jsonl`: one JSON line per finished run, appended, flushed and fsynced as it finishes.
  A torn last line (killed mid-write) is dropped and that run is run again.
- `runs.csv`, `settings.csv`: rewritten atomically from the rows at the end and on Ctrl-C
  (or SIGTERM); `settings.csv` pools each setting's seeds with `stats.pooled_rate`.

One sweep at a time per directory: the directory itself is locked (`DirLock`) before any of
its files is read or written; a second sweep is refused and touches nothing. These names
are the program's own: a symbolic link at any of them is refused before anything runs, and
no file is ever opened or replaced through a link (O_NOFOLLOW; atomic writes replace the
name itself).
"""

from __future__ import annotations

import csv
import errno
import itertools
import json
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from transplanter import fileio, interrupts
from transplanter.studies.backends import (
    BACKENDS,
    RESULT_FIELDS,
    BackendMissing,
    InlineBackend,
    backend_of,
    check_backend,
    comparable,
    make_backend,
    run_one,
)
from transplanter.studies.grid import (
    MANIFEST_IDENTITY,
    Axis,
    SweepRefused,
    SweepSpec,
    format_value,
    parse_param_range,
    parse_vary,
    run_key,
)
from transplanter.studies.jobs import job_of
from transplanter.studies.stats import SETTING_FIELDS, aggregate, pool_runs

__all__ = [
    "Axis",
    "BACKENDS",
    "BackendMissing",
    "SweepRefused",
    "require_pictures",
    "SweepReport",
    "SweepSpec",
    "aggregate",
    "backend_of",
    "check_backend",
    "comparable",
    "format_value",
    "make_backend",
    "parse_param_range",
    "parse_vary",
    "pool_runs",
    "run_key",
    "run_one",
    "run_sweep",
    "DirLock",
    "check_out_files",
    "write_csv_atomic",
]

RUNS_JSONL, RUNS_CSV, SETTINGS_CSV = "runs.jsonl", "runs.csv", "settings.csv"
RANGE_TXT, RANGE_CSV = "range_analysis.txt", "range_analysis.csv"
MANIFEST = "sweep.json"


# Columns of settings.csv after the varied keys.
def _open_own(path: Path, flags: int) -> int:
    """A file descriptor of one of the sweep's own files, never through a symlink."""
    try:
        return os.open(path, flags | os.O_NOFOLLOW, 0o666)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise SweepRefused(_link_refused(path)) from None
        raise


def _link_refused(path: Path) -> str:
    return (
        f"{path} is a symbolic link; a sweep writes its own files and never through a link: "
        "remove the link or use another --out"
    )


def read_runs(path: Path) -> list[dict[str, Any]]:
    """The rows of a runs.jsonl. A torn last line (killed mid-write: no newline, or not
    JSON) is cut off the file so that new rows append cleanly and its run is run again; a
    damaged line before the last is refused."""
    if not os.path.lexists(path):
        return []
    with os.fdopen(_open_own(path, os.O_RDONLY), "rb") as f:
        data = f.read()
    rows: list[dict[str, Any]] = []
    pos = 0
    while pos < len(data):
        nl = data.find(b"\n", pos)
        if nl < 0:  # the last line lacks its newline: torn
            break
        line = data[pos:nl]
        if line.strip():
            try:
                row = json.loads(line)
                if not isinstance(row, dict) or "seed" not in row:
                    raise ValueError(line)
            except ValueError:
                if nl + 1 == len(data):
                    break  # the last line: torn
                line_no = data.count(b"\n", 0, pos) + 1
                raise SweepRefused(
                    f"{path}: line {line_no} is damaged; move the file away to start over"
                ) from None
            rows.append(row)
        pos = nl + 1
    if pos < len(data):
        with os.fdopen(_open_own(path, os.O_RDWR), "r+b") as f:
            f.truncate(pos)
            os.fsync(f.fileno())
    return rows


class DirLock:
    """A sweep's hold on its output directory (flock on the directory itself: no file is
    made for it); SweepRefused if another sweep holds it. Released by `release`, or when
    the process ends however it ends."""

    def __init__(self, out: Path, follow: bool = True) -> None:
        import fcntl

        try:  # `follow=False`: a directory the program named, never entered through a link
            self.fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY | (0 if follow else os.O_NOFOLLOW))
        except OSError:
            if not follow and os.path.islink(out):
                raise SweepRefused(_link_refused(out)) from None
            raise
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(self.fd)
            raise SweepRefused(
                f"another sweep is writing {out}; wait for it to end or use another --out "
                "(nothing was written)"
            ) from None

    def release(self) -> None:
        os.close(self.fd)  # closing the descriptor releases the lock


class RunLog:
    """runs.jsonl opened for appending (never through a link; the directory is locked)."""

    def __init__(self, path: Path) -> None:
        fd = _open_own(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT)
        self.f = os.fdopen(fd, "a", encoding="utf-8")

    def append(self, row: Mapping[str, Any]) -> None:
        self.f.write(json.dumps(row) + "\n")
        self.f.flush()
        os.fsync(self.f.fileno())

    def close(self) -> None:
        self.f.close()


def _cell(value: Any) -> Any:
    return "" if value is None else value


def write_csv_atomic(path: Path, fields: Sequence[str], rows: Iterable[Mapping[str, Any]]) -> None:
    """A CSV table replacing `path` atomically; its names are the program's own (runs.csv,
    trials.csv ...): a link at `path` is replaced itself, never written through."""
    tmp = fileio.temp_beside(path)
    try:
        with open(tmp, "w", encoding="utf-8", newline="") as f:
            w = csv.writer(f)
            w.writerow(fields)
            for row in rows:
                w.writerow([_cell(row.get(k)) for k in fields])
    except BaseException:
        fileio.discard(tmp)
        raise
    fileio.commit(tmp, path, follow=False)


def check_out_files(out: Path, names: Iterable[str], scenario: str | os.PathLike) -> None:
    """SweepRefused (before any trial runs) if one of a study's own files in `out` cannot be
    written there (a directory, a symbolic link, no permission) or is one of the files the
    scenario is read from."""
    from transplanter.scenario.schema import scenario_files

    inputs = scenario_files(scenario)
    for name in names:
        path = out / name
        try:
            fileio.check_output(path, derived=True)
        except fileio.FileRefused as exc:
            raise SweepRefused(str(exc)) from None
        for source in inputs:
            if fileio.same_file(path, source):
                raise SweepRefused(
                    f"{path} is the scenario file {source}: an output never replaces an "
                    "input; use another --out"
                )


def check_manifest(out: Path, manifest: Mapping[str, Any]) -> bool:
    """True if `out` already holds this sweep; SweepRefused if it holds another one (or
    results without a manifest). Creates `out` when missing."""
    if out.exists() and not out.is_dir():
        raise SweepRefused(f"--out {out} is a file; give a directory")
    path = out / MANIFEST
    if not path.exists():
        if (out / RUNS_JSONL).exists():
            raise SweepRefused(
                f"{out} holds {RUNS_JSONL} but no {MANIFEST}: results of unknown origin; "
                "use another --out"
            )
        return False
    try:
        old = json.loads(fileio.read_text_input(path, 1 << 24, "sweep manifest"))
    except (fileio.FileRefused, ValueError) as exc:
        raise SweepRefused(f"{path} cannot be read ({exc}); use another --out") from None
    if not isinstance(old, dict):  # valid JSON, but not what a sweep writes (null, [] ...)
        raise SweepRefused(
            f"{path} is not a sweep's manifest (a JSON object expected, it holds "
            f"{_json_kind(old)}); use another --out, or move the file away to start over"
        )
    differs = [k for k in MANIFEST_IDENTITY if old.get(k) != manifest.get(k)]
    if differs:
        raise SweepRefused(
            f"{out} holds the results of a different sweep (it differs in: "
            f"{', '.join(differs)}); results of two sweeps are never mixed: use another --out "
            "or delete that directory"
        )
    return True


def _json_kind(value: Any) -> str:
    """What a JSON document holds, for a refusal: 'null', 'a list', 'a number' ..."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int | float):
        return "a number"
    return "a string" if isinstance(value, str) else "a list"


# ---------------------------------------------------------------------------------------
# Aggregation
# ---------------------------------------------------------------------------------------


def sort_rows(rows: Iterable[Mapping[str, Any]], spec: SweepSpec) -> list[dict[str, Any]]:
    """Rows in grid order (settings as the grid lists them, seeds as given), one per run."""
    order = {
        run_key(s, seed, spec.keys): i
        for i, (s, seed) in enumerate(itertools.product(spec.settings(), spec.seeds))
    }
    unique: dict[str, dict[str, Any]] = {}
    for row in rows:
        if any(k not in row for k in spec.keys):
            continue
        k = run_key(row, row["seed"], spec.keys)
        if k in order and k not in unique:
            unique[k] = dict(row)
    return [unique[k] for k in sorted(unique, key=order.__getitem__)]


def best_setting(rows: Iterable[Mapping[str, Any]], keys: Sequence[str]) -> str:
    """The setting with the highest success rate so far (ties: shortest cycle), as text."""
    tally: dict[str, list[float]] = {}
    for r in rows:
        if r["successes"] is None:
            continue
        t = tally.setdefault(json.dumps([r[k] for k in keys]), [0, 0, 0.0, 0])
        t[0] += r["successes"]
        t[1] += r["seedlings"]
        if r["cycles"]:
            t[2] += r["cycle_time_s"] * r["cycles"]
            t[3] += r["cycles"]
    if not tally:
        return ""

    def score(item):
        k, n, c, m = item[1]
        return (k / n, -(c / m) if m else -math.inf)

    name, (k, n, _, _) = max(tally.items(), key=score)
    values = json.loads(name)
    text = " ".join(
        f"{key.split('.')[-1]}={format_value(v)}" for key, v in zip(keys, values, strict=True)
    )
    return f"best {text}: {100 * k / n:.0f} %"


# ---------------------------------------------------------------------------------------
# The runner
# ---------------------------------------------------------------------------------------


@dataclass
class SweepReport:
    """What a sweep left in its directory."""

    out: Path
    rows: list[dict[str, Any]]  # every finished run, grid order
    settings: list[dict[str, Any]]  # pooled per setting, grid order
    ran: int  # runs done by this call
    skipped: int  # runs found already done (resume)
    total: int
    interrupted: bool = False
    plots: list[Path] = field(default_factory=list)
    plot_error: str | None = None
    range_text: str | None = None  # the range analysis (--design L9, --range-analysis)
    range_note: str | None = None  # why it was not made

    @property
    def complete(self) -> bool:
        return len(self.rows) == self.total


def run_sweep(
    spec: SweepSpec,
    out: str | os.PathLike,
    backend: str = "process",
    workers: int = 1,
    address: str | None = None,
    progress: bool = False,
    plots: bool = True,
    on_row: Callable[[dict[str, Any]], None] | None = None,
    range_analysis: bool = False,
    own_dir: bool = False,
) -> SweepReport:
    """Run every (setting, seed) of the grid not yet in `out`, writing each row as it
    finishes; then the CSVs and the plots. Ctrl-C (or SIGTERM): the finished rows stay, the
    CSVs are rewritten and the report says `interrupted`. `out` is locked first: a second
    sweep into it is refused (SweepRefused) before it reads or writes anything there.
    `own_dir`: `out` is a name the caller derived (compare's runs/<scenario>): a symbolic
    link there is refused, never followed."""
    out = Path(out)
    manifest = spec.manifest()  # ScenarioError here: nothing runs
    if own_dir and out.is_symlink():
        raise SweepRefused(_link_refused(out))
    if out.exists() and not out.is_dir():
        raise SweepRefused(f"--out {out} is a file; give a directory")
    try:  # an --out that cannot be made is refused (exit 2) before anything runs
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SweepRefused(f"--out {out} cannot be made: {exc.strerror or exc}") from None
    lock = DirLock(out, follow=not own_dir)
    try:
        report = _run_locked(
            spec, out, manifest, backend, workers, address, progress, plots, on_row,
            range_analysis or spec.design == "L9",
        )  # fmt: skip
        if (range_analysis or spec.design == "L9") and not report.interrupted:
            _write_range_analysis(spec, report)
        return report
    finally:
        lock.release()


def _write_range_analysis(spec: SweepSpec, report: SweepReport) -> None:
    """range_analysis.txt and .csv in the sweep's directory (studies.orthogonal), once every
    setting has a pooled success; otherwise `report.range_note` says why not."""
    from transplanter.studies.orthogonal import sweep_range_analysis

    missing = [s for s in report.settings if s["success_rate"] is None]
    if not report.complete or missing:
        report.range_note = (
            f"no range analysis: {report.total - len(report.rows)} runs missing, "
            f"{len(missing)} settings without a counted run"
        )
        return
    axes = [(a.key, a.values) for a in spec.axes]
    text, rows = sweep_range_analysis(axes, report.settings, report.rows)
    fileio.write_text_atomic(report.out / RANGE_TXT, text + "\n", follow=False)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    write_csv_atomic(report.out / RANGE_CSV, fields, rows)
    report.range_text = text


def require_pictures(scenario, varied: Mapping[str, Sequence[Any]] | None = None) -> None:
    """SweepRefused, before any run, when the scenario's job photographs (the delta's trays
    graded by the pipeline, as set or among the `varied` values) and this process cannot
    render offscreen: the study's every run would fail alike, and a worker's second try
    would abort it (scene.offscreen)."""
    job = job_of(scenario)
    if job is None or job.pictures is None or not job.pictures(scenario, varied or {}):
        return
    from transplanter.scene.offscreen import offscreen_gl_error

    why = offscreen_gl_error()
    if why is not None:
        raise SweepRefused(
            f"{job.pictures_why}: {why}; headless, set MUJOCO_GL=egl (or osmesa) before the "
            f"command, {job.no_pictures}"
        )


def _run_locked(spec, out, manifest, backend, workers, address, progress, plots, on_row,
                ranged=False):  # fmt: skip
    """run_sweep once `out` is locked."""
    extra = (RANGE_TXT, RANGE_CSV) if ranged else ()
    check_out_files(out, (MANIFEST, RUNS_JSONL, RUNS_CSV, SETTINGS_CSV, *extra), spec.scenario)
    scenario = spec.check()
    job = job_of(scenario)  # the delta's jobs add their own columns; None: the five-bar
    fields, means = (job.fields, job.means) if job is not None else ((), ())
    resumed = check_manifest(out, manifest)
    if not resumed:
        fileio.write_json_atomic(out / MANIFEST, manifest, follow=False)
    log = RunLog(out / RUNS_JSONL)
    try:
        done = sort_rows(read_runs(out / RUNS_JSONL), spec)
        finished = {run_key(r, r["seed"], spec.keys) for r in done}
        tasks = [
            t for t in spec.tasks() if run_key(t["setting"], t["seed"], spec.keys) not in finished
        ]
        rows = list(done)
        interrupted = False
        if tasks:
            require_pictures(scenario, {a.key: a.values for a in spec.axes})
        runner = make_backend(backend, workers, address) if tasks else InlineBackend()
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=spec.runs_total, initial=len(done), unit="run", dynamic_ncols=True)
            bar.set_postfix_str(best_setting(rows, spec.keys))
        try:
            for row in runner.run(tasks):
                with interrupts.held():  # a row in runs.jsonl is a row of the tables
                    log.append(row)
                    rows.append(row)
                interrupts.raise_pending()
                if on_row is not None:
                    on_row(row)
                if bar is not None:
                    bar.set_postfix_str(best_setting(rows, spec.keys), refresh=False)
                    bar.update(1)
        except KeyboardInterrupt:  # Ctrl-C, or SIGTERM on the command line
            interrupted = True
        with interrupts.held():  # the workers stopped and the tables written, whatever comes
            if interrupted:
                getattr(runner, "terminate", runner.close)()
            else:
                runner.close()
            if bar is not None:
                bar.close()
            rows = sort_rows(rows, spec)
            settings = aggregate(rows, spec.keys, means)
            write_csv_atomic(out / RUNS_CSV, (*spec.keys, *RESULT_FIELDS, *fields), rows)
            write_csv_atomic(out / SETTINGS_CSV, (*spec.keys, *SETTING_FIELDS, *means), settings)
        if interrupts.take_pending() is not None:
            interrupted = True  # it came while the tables were written: they are whole
    finally:
        log.close()
    report = SweepReport(
        out=out,
        rows=rows,
        settings=settings,
        ran=len(tasks) if not interrupted else len(rows) - len(done),
        skipped=len(done),
        total=spec.runs_total,
        interrupted=interrupted,
    )
    if plots and not interrupted and settings:
        from transplanter.studies import plots as plotting

        try:
            report.plots = plotting.sweep_plots(out, spec.keys, rows)
        except (OSError, ValueError) as exc:
            report.plot_error = str(exc)
    return report
