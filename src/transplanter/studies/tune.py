"""Tuning with Optuna: search scenario keys for fast and reliable settings.

Two objectives: maximise the lower end of the 95 % interval of the success rate pooled over
the seeds (`stats.pooled_rate`, so a lucky seed does not win) and minimise the mean cycle
time. Each Optuna trial runs one `sweep_backends.run_one` per seed (the same judging as
`transplanter trial`), on the sweep's backends. The study lives in SQLite, so rerunning the
same command resumes it: finished trials count toward `--trials`. The sampler is seeded per
trial that counts (`sampler_seed + trials counted before it`; a trial stopped by Ctrl-C takes
an Optuna number but does not count), so the same command gives the same points, resumed or
not, however often it was stopped.

Files in the output directory: `trials.csv` (every finished trial), `pareto.csv` (the Pareto
front), `pareto.png` (Optuna's Pareto-front plot) and `tuned.toml`: the chosen point (highest
lower bound; ties: the shortest cycle) as a scenario with `base = ...` and only the tuned keys
(plus any `--set` keys the study held fixed), which `transplanter trial DIR/tuned.toml` runs.

At the sample sizes users run (20 seedlings x 2 seeds) most good points succeed on every
seedling and tie on the lower bound (as on any function of the pooled count: a prior's
posterior mean, a floor's test; docs/tuning.md has the study), so only the cycle time ranks
them. `saturation_note` then says so in one line, with the seedlings the rule of three asks
for; `TuneReport.note` carries it.
"""

from __future__ import annotations

import importlib.resources
import json
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from transplanter import fileio, interrupts
from transplanter.scenario.schema import (
    ScenarioError,
    load_scenario,
    resolve_scenario_path,
    scenario_digest,
    with_units,
)
from transplanter.studies.grid import task
from transplanter.studies.sweep import (
    SweepRefused,
    backend_of,
    check_out_files,
    pool_runs,
    require_pictures,
    write_csv_atomic,
)

# The files tune writes into --out (checked writable before the first trial).
OUT_FILES = ("trials.csv", "pareto.csv", "pareto.png", "tuned.toml")

__all__ = [
    "Param",
    "TuneReport",
    "TuneSpec",
    "drive_study",
    "open_study",
    "run_tune",
    "scenario_toml",
    "tuned_toml",
]

MAX_TRIALS = 100000


@dataclass(frozen=True)
class Param:
    """A tuned key ('section.key', file unit), its kind ('float' or 'int') and range."""

    key: str
    kind: str
    lo: float | int
    hi: float | int

    def distribution(self):
        import optuna

        from transplanter.scenario.assemble import key_quantum

        if self.kind == "int":
            return optuna.distributions.IntDistribution(int(self.lo), int(self.hi))
        # a taught key on the EEPROM's grid (a finer value would be refused, not rounded)
        step = key_quantum(self.key)
        return optuna.distributions.FloatDistribution(float(self.lo), float(self.hi), step=step)


@dataclass(frozen=True)
class TuneSpec:
    """What a study tunes: the scenario with `overrides` (--set), the params, the seeds and
    seedlings each point is judged on, and the sampler's seed."""

    scenario: str
    params: tuple[Param, ...]
    seeds: tuple[int, ...]
    seedlings: int
    overrides: Mapping[str, Any] = field(default_factory=dict)
    sampler_seed: int = 0
    option: str = "--param"  # the command-line option of the params, for messages

    def __post_init__(self) -> None:
        keys = [p.key for p in self.params]
        opt = self.option
        verb = "tuned" if opt == "--param" else "fitted"
        if not keys:
            raise SweepRefused(f"give at least one {opt} KEY=LO..HI (the keys to search)")
        if len(set(keys)) != len(keys):
            raise SweepRefused(f"{opt}: a key is given twice")
        for k in keys:
            if k in self.overrides:
                raise SweepRefused(f"{k} is both set (--set) and {verb} ({opt}); drop one")
        if not self.seeds:
            raise SweepRefused("--seeds: give at least one seed")

    def check(self):
        """The scenario with --set and the seedlings (ScenarioError before any run)."""
        overrides = with_units(self.scenario, self.overrides, self.seedlings)
        return load_scenario(self.scenario, overrides)

    def identity(self, scenario_digest: str) -> dict[str, Any]:
        """What a resumed study must share with this command."""
        return {
            "scenario_digest": scenario_digest,
            "overrides": dict(self.overrides),
            "params": [[p.key, p.kind, p.lo, p.hi] for p in self.params],
            "seeds": list(self.seeds),
            "seedlings": self.seedlings,
            "sampler_seed": self.sampler_seed,
        }


@dataclass
class TuneReport:
    out: Path
    storage: str
    study_name: str
    finished: int  # trials that count toward --trials
    ran: int  # trials run by this call
    front: list[dict[str, Any]]
    chosen: dict[str, Any] | None
    files: list[Path]
    interrupted: bool = False
    note: str | None = None  # one line when the sample is too small to rank the points


def _import_optuna(command: str = "tune"):
    try:
        import optuna
    except ImportError:
        raise SweepRefused(
            f"transplanter {command} needs Optuna: pip install 'transplanter[tune]'"
        ) from None
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


def evaluate(runner, spec: TuneSpec, values: Mapping[str, Any]) -> dict[str, Any]:
    """One point judged on every seed: pooled success, its interval, the mean cycle time
    and the runs' errors; `lower` and `cycle_time_s` are None when it cannot be scored."""
    tasks = [
        task(spec.scenario, spec.overrides, values, seed, spec.seedlings) for seed in spec.seeds
    ]
    order = {s: i for i, s in enumerate(spec.seeds)}
    rows = sorted(runner.run(tasks), key=lambda r: order[r["seed"]])
    out: dict[str, Any] = {
        "errors": [r["error"] for r in rows if r["error"] is not None],
        "successes": None,
        "seedlings": None,
        "success_rate": None,
        "ci95_low": None,
        "ci95_high": None,
        "cycle_time_s": None,
    }
    counted = [r for r in rows if r["successes"] is not None]
    if len(counted) != len(rows):
        return out
    pooled, cycle = pool_runs(rows)
    out.update(
        successes=pooled.successes,
        seedlings=pooled.seedlings,
        success_rate=pooled.success_rate,
        ci95_low=pooled.ci95[0],
        ci95_high=pooled.ci95[1],
        cycle_time_s=cycle,
    )
    return out


def _counts(trial, optuna) -> bool:
    """A trial that counts toward --trials: scored, or failed for its setting (not stopped)."""
    state = trial.state
    return state == optuna.trial.TrialState.COMPLETE or (
        state == optuna.trial.TrialState.FAIL and "errors" in trial.user_attrs
    )


TUNE_METRICS = ("success_ci95_low", "cycle_time_s")
"""The tune study's objectives by name: the lower end of the pooled success's 95 % interval
(maximised) and the mean cycle time in s (minimised)."""
SQLITE_HEADER = b"SQLite format 3\x00"
"""The first 16 bytes of every SQLite database file."""


def open_study(
    optuna,
    storage: str | os.PathLike | None,
    study_name: str,
    directions: Sequence[str],
    attr: str,
    identity: Mapping[str, Any],
    metric_names: Sequence[str] | None = None,
):
    """The study in SQLite `storage` (created, or loaded to resume; in memory when None),
    holding `identity` under the user attribute `attr` (and `metric_names`, the objectives'
    names); SweepRefused if it was made by a different command, or if the file is not a
    sound SQLite database (SQLite's integrity check, before anything is written to it: a
    damaged page anywhere is refused, not found out by a read or a write of the study).
    Returns (study, storage URL)."""
    if storage is None:
        study = optuna.create_study(study_name=study_name, directions=list(directions))
        _hold(optuna, study, study_name, storage, attr, identity, metric_names)
        return study, "in memory"
    storage = Path(storage)
    if storage.exists() and not storage.is_file():
        raise SweepRefused(f"--storage {storage} is not a file; give a .db file's path")
    if storage.is_file() and storage.stat().st_size > 0:
        try:
            with storage.open("rb") as handle:
                header = handle.read(len(SQLITE_HEADER))
        except OSError as exc:
            raise SweepRefused(
                f"--storage {storage} cannot be read ({exc.strerror or exc}); give a .db path "
                "this user can read and write"
            ) from None
        if header != SQLITE_HEADER:
            raise SweepRefused(
                f"--storage {storage} is not a SQLite database (an Optuna study's "
                "file); give a new .db path or the study's own file"
            )
        _check_intact(storage)
    try:
        storage.parent.mkdir(parents=True, exist_ok=True)
        url = f"sqlite:///{storage.resolve()}"
        study = optuna.create_study(
            study_name=study_name,
            storage=url,
            directions=list(directions),
            load_if_exists=True,
        )
        # the study's own rows are read and written here too, inside the refusal below
        _hold(optuna, study, study_name, storage, attr, identity, metric_names)
    except Exception as exc:  # SQLAlchemy's and OSError's: the file cannot hold a study
        if isinstance(exc, SweepRefused):
            raise
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SweepRefused(
            f"--storage {storage} cannot hold the study ({reason}); give a writable .db path"
        ) from None
    return study, url


def _check_intact(storage: Path) -> None:
    """SweepRefused naming `storage` unless SQLite's integrity check finds every page of it
    sound (a page damaged by a disk or a copy cut short)."""
    import sqlite3

    try:
        con = sqlite3.connect(storage)
        try:
            found = [row[0] for row in con.execute("PRAGMA integrity_check")]
        finally:
            con.close()
    except sqlite3.OperationalError as exc:  # locked, unreadable: not known to be damaged
        raise SweepRefused(
            f"--storage {storage} cannot be read ({exc}); give a .db path this user can read "
            "and write, or wait for the command using it to end"
        ) from None
    except sqlite3.DatabaseError as exc:  # "database disk image is malformed"
        found = [str(exc)]
    if found != ["ok"]:
        more = f" and {len(found) - 1} more" if len(found) > 1 else ""
        first = " ".join(found[0].split())
        raise SweepRefused(
            f"--storage {storage} is damaged (SQLite: {first}{more}); restore it from a copy "
            "or give a new .db path"
        )


def _hold(optuna, study, study_name, storage, attr, identity, metric_names) -> None:
    """The study's identity under `attr` (set when new, compared when resumed) and its
    objectives' names."""
    held = study.user_attrs.get(attr)
    plain = json.loads(json.dumps(identity))
    if held is None:
        study.set_user_attr(attr, plain)
    elif held != plain:
        differs = [k for k in plain if not isinstance(held, dict) or held.get(k) != plain[k]]
        raise SweepRefused(
            f"study {study_name!r} in {storage} was made by a different command (it differs "
            f"in: {', '.join(differs)}); use another --study or --storage"
        )
    if metric_names is not None:
        with warnings.catch_warnings():  # "experimental" since Optuna 3.2, and stable in use
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            study.set_metric_names(list(metric_names))  # optuna-dashboard's and plots' axes


def drive_study(
    optuna,
    study,
    spec: TuneSpec,
    trials: int,
    objective,
    workers: int = 1,
    backend: str = "process",
    address: str | None = None,
    progress: bool = False,
    describe=None,
) -> tuple[int, int, bool]:
    """Ask, evaluate and tell until `trials` trials count (finished ones included): each
    point is judged with `evaluate` on every seed on the backend, its results kept as the
    trial's user attributes, and `objective(scored)` told (None: the trial FAILs). The
    sampler is a TPESampler seeded `spec.sampler_seed + the trials counted so far` (a
    stopped trial does not shift the points of a resumed study). Returns (finished,
    ran now, interrupted by Ctrl-C). No trial is left RUNNING in the study: asking (the
    sampler's work) and telling run with stop signals held, and a trial stopped while its
    runs ran is told FAIL (without results: it does not count, a rerun asks again)."""
    dists = {p.key: p.distribution() for p in spec.params}
    finished = sum(_counts(t, optuna) for t in study.get_trials(deepcopy=False))
    ran, interrupted = 0, False
    if finished < trials:
        require_pictures(spec.check())
    bar = None
    if progress and finished < trials:
        from tqdm import tqdm

        bar = tqdm(total=trials, initial=finished, unit="trial", dynamic_ncols=True)
    try:
        with backend_of(backend, workers, address) as runner:
            while finished < trials:
                # seeded by the trials that count, not by Optuna's trial number: a trial
                # stopped (told FAIL, not counted) takes a number, and a resumed study must
                # go on with the points the uninterrupted one takes
                study.sampler = optuna.samplers.TPESampler(seed=spec.sampler_seed + finished)
                with interrupts.held():  # a trial asked is a trial told
                    trial = study.ask(dists)
                try:
                    interrupts.raise_pending()  # a stop held while asking: told FAIL below
                    scored = evaluate(runner, spec, trial.params)
                except BaseException:  # Ctrl-C, SIGTERM, a broken pool: never left RUNNING
                    with interrupts.held():
                        study.tell(trial, state=optuna.trial.TrialState.FAIL)
                    raise
                with interrupts.held():  # its results and its state, whole
                    for k, v in scored.items():
                        trial.set_user_attr(k, v)
                    values = objective(scored)
                    if values is None:
                        study.tell(trial, state=optuna.trial.TrialState.FAIL)
                    else:
                        study.tell(trial, values)
                finished += 1
                ran += 1
                if bar is not None:
                    if describe is not None:
                        bar.set_postfix_str(describe(study), refresh=False)
                    bar.update(1)
                interrupts.raise_pending()  # a stop held while telling: this trial is kept
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if bar is not None:
            bar.close()
    return finished, ran, interrupted


def run_tune(
    spec: TuneSpec,
    trials: int,
    storage: str | os.PathLike,
    study_name: str,
    out: str | os.PathLike,
    workers: int = 1,
    backend: str = "process",
    progress: bool = False,
) -> TuneReport:
    """Run the study until `trials` trials count (a rerun resumes), then write the files."""
    optuna = _import_optuna()
    if not 1 <= trials <= MAX_TRIALS:
        raise SweepRefused(f"--trials must be 1..{MAX_TRIALS}, got {trials}")
    scenario = spec.check()
    digest = scenario_digest(scenario)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise SweepRefused(f"--out {out} is a file; give a directory")
    storage = Path(storage)
    if storage.exists() and not storage.is_file():
        raise SweepRefused(f"--storage {storage} is not a file; give a .db file's path")
    out.mkdir(parents=True, exist_ok=True)
    check_out_files(out, OUT_FILES, spec.scenario)  # not found out after every trial ran
    study, url = open_study(
        optuna, storage, study_name, ["maximize", "minimize"], "tune", spec.identity(digest),
        TUNE_METRICS,
    )  # fmt: skip

    def objective(scored):
        if scored["ci95_low"] is None or scored["cycle_time_s"] is None:
            return None
        return [scored["ci95_low"], scored["cycle_time_s"]]

    finished, ran, interrupted = drive_study(
        optuna, study, spec, trials, objective, workers=workers, backend=backend,
        progress=progress, describe=_best_text,
    )  # fmt: skip
    with interrupts.held():  # a stop signal now waits until the files are written
        report = _write_outputs(spec, study, out, url, study_name, finished, ran, interrupted)
    if interrupts.take_pending() is not None:
        report.interrupted = True
    return report


def _best_text(study) -> str:
    front = study.best_trials
    if not front:
        return ""
    best = max(front, key=lambda t: (t.values[0], -t.values[1]))
    return f"best lower bound {100 * best.values[0]:.0f} %, cycle {best.values[1]:.3f} s"


def _row(trial, keys: Sequence[str]) -> dict[str, Any]:
    attrs = trial.user_attrs
    row = {"trial": trial.number, "state": trial.state.name}
    row.update({k: trial.params.get(k) for k in keys})
    for k in ("successes", "seedlings", "success_rate", "ci95_low", "ci95_high", "cycle_time_s"):
        row[k] = attrs.get(k)
    row["error"] = "; ".join(attrs.get("errors") or []) or None
    return row


def _write_outputs(spec, study, out, url, study_name, finished, ran, interrupted) -> TuneReport:
    import optuna

    from transplanter.studies import plots

    keys = [p.key for p in spec.params]
    done = [
        t
        for t in study.get_trials(deepcopy=False)
        if t.state in (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL)
        and "errors" in t.user_attrs
    ]
    fields = ["trial", "state", *keys, "successes", "seedlings", "success_rate", "ci95_low",
              "ci95_high", "cycle_time_s", "error"]  # fmt: skip
    files = []
    write_csv_atomic(out / "trials.csv", fields, [_row(t, keys) for t in done])
    files.append(out / "trials.csv")
    front_trials = sorted(study.best_trials, key=lambda t: (-t.values[0], t.values[1], t.number))
    front = [_row(t, keys) for t in front_trials]
    write_csv_atomic(out / "pareto.csv", fields, front)
    files.append(out / "pareto.csv")
    chosen = front[0] if front else None
    complete = [_row(t, keys) for t in done if t.state == optuna.trial.TrialState.COMPLETE]
    seeds = ", ".join(map(str, spec.seeds))
    files.append(
        plots.pareto_plot(
            out / "pareto.png",
            study,
            (chosen["cycle_time_s"], chosen["ci95_low"]) if chosen else None,
            title=f"speed vs success: n = {spec.seedlings} seedlings x {len(spec.seeds)} "
            f"seed{'s' if len(spec.seeds) > 1 else ''} ({seeds}) per point",
        )
    )
    if chosen is not None:
        path = out / "tuned.toml"
        text = tuned_toml(spec, {k: chosen[k] for k in keys}, out, chosen, study_name)
        fileio.write_text_atomic(path, text, follow=False)
        try:
            load_scenario(path)
        except ScenarioError as exc:  # pragma: no cover - a bug here, never the user's input
            raise AssertionError(f"tuned.toml does not load: {exc}") from None
        files.append(path)
    from transplanter.studies.jobs import job_of

    job = job_of(spec.check())
    note = saturation_note(complete, chosen, *((job.unit, job.more) if job else ()))
    return TuneReport(
        out, url, study_name, finished, ran, front, chosen, files, interrupted, note=note
    )


FAILURE_TO_SEPARATE = 0.01
"""The failure rate per pick the saturation note sizes its sample for (1 %)."""


def rule_of_three_seedlings(failure_rate: float) -> int:
    """Seedlings per point (all succeeding) that rule out `failure_rate` at 95 %: the rule
    of three (0 failures in n picks bounds the rate below about 3/n; exactly, below
    1 - 0.05**(1/n))."""
    return math.ceil(3 / failure_rate)


def saturation_note(
    complete: Sequence[Mapping[str, Any]],
    chosen: Mapping[str, Any] | None,
    unit: str = "seedlings",
    more: str = "--seedlings x seeds",
):
    """One line when the success objective cannot rank the points: the chosen point and at
    least one other succeeded on every seedling (`unit`: what the job counts; `more`: how a
    user gives a point more of them), so they tie on the lower bound and only the cycle time
    told them apart. None otherwise."""
    if chosen is None or chosen["successes"] != chosen["seedlings"]:
        return None
    full = [r for r in complete if r["successes"] is not None and r["successes"] == r["seedlings"]]
    if len(full) < 2:
        return None
    n = chosen["seedlings"]
    each = "picks" if unit == "seedlings" else unit
    bound = 100 * (1 - 0.05 ** (1 / n))
    need = rule_of_three_seedlings(FAILURE_TO_SEPARATE)
    return (
        f"note: {len(full)} of {len(complete)} points succeeded on all {n} {unit}, too few "
        f"to rank their success (0 failures in {n} {each} rules out only failure rates above "
        f"{bound:.1f} %: the rule of three, about 3/n), so the front keeps the fastest of "
        f"them; to tell a setting failing {100 * FAILURE_TO_SEPARATE:g} % of {each} from a "
        f"perfect one, give about {need} {unit} per point ({more})"
    )


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"{v!r} cannot be written to a scenario")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise ValueError(f"{v!r} cannot be written to a scenario")


def base_reference(scenario: str, out: Path) -> str:
    """How a file in `out` names the scenario as its base: a packaged scenario by name
    ('paper'), a file inside `out` by its relative path, any other file by its absolute
    path."""
    path = resolve_scenario_path(scenario).resolve()
    packaged = Path(str(importlib.resources.files("transplanter.scenarios"))).resolve()
    if path.parent == packaged:
        return path.stem
    try:
        return str(path.relative_to(out.resolve()))
    except ValueError:
        return str(path)


def tuned_toml(
    spec: TuneSpec,
    values: Mapping[str, Any],
    out: Path,
    chosen: Mapping[str, Any] | None = None,
    study_name: str = "",
) -> str:
    """A scenario file: `base = ` the original, the tuned keys (and the --set keys the study
    held fixed) in their sections."""
    lines = ["written by `transplanter tune`"]
    if chosen is not None:
        lines.append(
            f"study {study_name!r}, trial {chosen['trial']}: pooled success "
            f"{100 * chosen['success_rate']:.1f} % ({chosen['successes']}/{chosen['seedlings']}"
            f"), lower 95 % bound {100 * chosen['ci95_low']:.1f} %, mean cycle "
            f"{chosen['cycle_time_s']:.3f} s over seeds {', '.join(map(str, spec.seeds))}"
        )
    if spec.overrides:
        lines.append("held fixed with --set: " + ", ".join(spec.overrides))
    return scenario_toml(spec, values, out, lines)


def scenario_toml(
    spec: TuneSpec, values: Mapping[str, Any], out: Path, comments: Sequence[str] = ()
) -> str:
    """A scenario file for `out`: the `comments` (one '# ' line each), `base = ` the original,
    then the --set keys and `values` in their sections."""
    tables: dict[str, dict[str, Any]] = {"scenario": {"base": base_reference(spec.scenario, out)}}
    for dotted, v in {**spec.overrides, **values}.items():
        section, _, key = dotted.partition(".")
        tables.setdefault(section, {})[key] = v
    lines = [f"# {c}".rstrip() for text in comments for c in text.splitlines() or [""]]
    for section, table in tables.items():
        lines.append(f"\n[{section}]")
        lines += [f"{k} = {_toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"
