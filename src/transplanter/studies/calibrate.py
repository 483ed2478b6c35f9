"""Calibration: fit uncertain scenario keys so that the twin matches observed trials.

The user counts K successes in N seedlings on their own machine (`--observed K/N`) and may
time the mean cycle (`--cycle-s`). An Optuna study (the machinery of `tune`: TPESampler
seeded by the trials that count before each, the study optionally in SQLite so the same
command resumes it) searches the `--fit KEY=LO..HI` keys; every point is run on every seed with
`sweep_backends.run_one` (on the sweep's backends) and the seeds pooled (`sweep.pool_runs`).

The loss of a point is the binomial deviance (likelihood-ratio G^2) of the 2x2 table
twin successes/failures against observed successes/failures: 0 when the pooled twin rate
equals the observed one, growing with the gap and with the evidence on both sides; under
"the same success probability" it is about chi-square with one degree of freedom, so a loss
under 3.84 means the two cannot be told apart at the 5 % level (picks treated as
independent). With `--cycle-s`, ((|twin cycle - observed| - tol) / tol)^2 is added for a
mismatch beyond the tolerance `--cycle-tol-s`.

A point is consistent with the observation when its pooled twin rate lies inside the
observation's Wilson 95 % interval (and, with `--cycle-s`, its mean cycle within the
tolerance). For each fitted key the consistent range is the span of the consistent points'
values (a projection when several keys are fitted), with a note when it is a single point
or reaches the search bounds (no evaluated point beyond it disagrees: widen the range).

Files in `--out`: `calibration.csv` (every evaluated point), `calibration.json` (the
observation, the search, the best point and the ranges) and `calibrated.toml` (`base =` the
original scenario, the fitted keys at the best point and any `--set` keys, the observation,
seeds, command and ranges in its header comment).
"""

from __future__ import annotations

import math
import os
import re
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from transplanter import fileio, interrupts
from transplanter.scenario.schema import ScenarioError, load_scenario
from transplanter.studies.sweep import (
    SweepRefused,
    check_backend,
    check_out_files,
    format_value,
    write_csv_atomic,
)
from transplanter.studies.tune import (
    MAX_TRIALS,
    TuneSpec,
    _import_optuna,
    _toml_value,
    drive_study,
    open_study,
    scenario_digest,
    scenario_toml,
)
from transplanter.twin.results import wilson_interval

__all__ = [
    "CSV_NAME",
    "CalibrationReport",
    "CalibrationSpec",
    "JSON_NAME",
    "Observation",
    "TOML_NAME",
    "binomial_deviance",
    "consistent_ranges",
    "cycle_penalty",
    "format_summary",
    "loss",
    "parse_observed",
    "run_calibrate",
]

CSV_NAME, JSON_NAME, TOML_NAME = "calibration.csv", "calibration.json", "calibrated.toml"
MAX_OBSERVED = 10**9  # seedlings of an observation; more is a typo
EDGE_SHARE = 0.05  # a consistent range this close to a search bound (share of the span) touches it
_OBSERVED_RE = re.compile(r"\s*(\d+)\s*/\s*(\d+)\s*")

JUDGED_FIELDS = (
    "successes",
    "seedlings",
    "success_rate",
    "ci95_low",
    "ci95_high",
    "cycle_time_s",
)
"""What a point's runs measured, pooled over the seeds (kept in the trial's user attrs)."""
RESULT_FIELDS = (*JUDGED_FIELDS, "loss", "consistent", "error")


def parse_observed(text: str) -> tuple[int, int]:
    """'112/120' -> (112, 120): successes K of N seedlings; SweepRefused saying why not."""
    where = f"--observed {text!r}"
    m = _OBSERVED_RE.fullmatch(text) if text.isascii() else None
    if m is None:
        raise SweepRefused(f"{where}: write SUCCESSES/SEEDLINGS in whole numbers, e.g. 112/120")
    k, n = int(m.group(1)), int(m.group(2))
    if n < 1:
        raise SweepRefused(f"{where}: at least one seedling must have been observed")
    if n > MAX_OBSERVED:
        raise SweepRefused(f"{where}: more than {MAX_OBSERVED} seedlings")
    if k > n:
        raise SweepRefused(f"{where}: {k} successes out of {n} seedlings is more than all")
    return k, n


@dataclass(frozen=True)
class Observation:
    """What the user's machine did: `successes` of `seedlings`, optionally the mean cycle
    time (s) with the tolerance within which the twin's counts as a match."""

    successes: int
    seedlings: int
    cycle_s: float | None = None
    cycle_tol_s: float = 0.1

    def __post_init__(self) -> None:
        if not 1 <= self.seedlings <= MAX_OBSERVED or not 0 <= self.successes <= self.seedlings:
            raise SweepRefused(
                f"--observed {self.successes}/{self.seedlings}: need 0 <= K <= N, N >= 1"
            )
        if self.cycle_s is not None and not (math.isfinite(self.cycle_s) and self.cycle_s > 0):
            raise SweepRefused(f"--cycle-s must be a time above 0 s, got {self.cycle_s}")
        if not (math.isfinite(self.cycle_tol_s) and self.cycle_tol_s > 0):
            raise SweepRefused(f"--cycle-tol-s must be above 0 s, got {self.cycle_tol_s}")

    @property
    def rate(self) -> float:
        return self.successes / self.seedlings

    @property
    def ci95(self) -> tuple[float, float]:
        """The Wilson 95 % interval of the observed rate."""
        return wilson_interval(self.successes, self.seedlings)

    def to_dict(self) -> dict[str, Any]:
        return {
            "successes": self.successes,
            "seedlings": self.seedlings,
            "success_rate": self.rate,
            "ci95": list(self.ci95),
            "ci_method": "Wilson",
            "cycle_s": self.cycle_s,
            "cycle_tol_s": self.cycle_tol_s if self.cycle_s is not None else None,
        }

    def text(self) -> str:
        lo, hi = self.ci95
        out = (
            f"{self.successes}/{self.seedlings} ({100 * self.rate:.1f} %, Wilson 95 % "
            f"{100 * lo:.1f}-{100 * hi:.1f} %)"
        )
        if self.cycle_s is not None:
            out += f", mean cycle {self.cycle_s:.3f} s +- {self.cycle_tol_s:.3f} s"
        return out


@dataclass(frozen=True)
class CalibrationSpec:
    """The search (`TuneSpec` with option '--fit': scenario, --set, fitted keys, seeds,
    seedlings, sampler seed) and the observation it is fitted to."""

    search: TuneSpec
    observed: Observation

    def identity(self, scenario_digest: str) -> dict[str, Any]:
        """What a resumed study must share with this command."""
        o = self.observed
        return {
            **self.search.identity(scenario_digest),
            "observed": [o.successes, o.seedlings, o.cycle_s, o.cycle_tol_s],
        }


# ---------------------------------------------------------------------------------------
# The loss
# ---------------------------------------------------------------------------------------


def _xlogy(o: float, e: float) -> float:
    return 0.0 if o == 0 else o * math.log(o / e)


def binomial_deviance(k: int, n: int, K: int, N: int) -> float:
    """G^2 of the 2x2 table (k of n) against (K of N): twice the log-likelihood ratio of
    two success probabilities against one. 0 when k/n == K/N; about chi-square(1) when
    both come from the same probability."""
    if not (0 <= k <= n and 0 <= K <= N and n >= 1 and N >= 1):
        raise ValueError(f"binomial_deviance needs 0 <= k <= n >= 1 twice, got {k}/{n}, {K}/{N}")
    p = (k + K) / (n + N)
    g = 0.0
    for o_s, total in ((k, n), (K, N)):
        g += _xlogy(o_s, total * p) + _xlogy(total - o_s, total * (1 - p))
    return max(0.0, 2.0 * g)


def cycle_penalty(cycle_s: float | None, observed: Observation) -> float:
    """((|twin - observed| - tol) / tol)^2 beyond the tolerance, else 0 (also without
    --cycle-s); inf when a cycle was observed but the twin timed none."""
    if observed.cycle_s is None:
        return 0.0
    if cycle_s is None:
        return math.inf
    excess = max(0.0, abs(cycle_s - observed.cycle_s) - observed.cycle_tol_s)
    return (excess / observed.cycle_tol_s) ** 2


def loss(successes: int, seedlings: int, cycle_s: float | None, observed: Observation) -> float:
    """The distance of the twin's pooled result from the observation (0: a match)."""
    return binomial_deviance(
        successes, seedlings, observed.successes, observed.seedlings
    ) + cycle_penalty(cycle_s, observed)


def is_consistent(row: Mapping[str, Any], observed: Observation) -> bool:
    """The pooled twin rate inside the observation's Wilson 95 % interval (and the mean
    cycle within the tolerance when a cycle was observed)."""
    if row.get("success_rate") is None:
        return False
    lo, hi = observed.ci95
    if not lo - 1e-12 <= row["success_rate"] <= hi + 1e-12:
        return False
    if observed.cycle_s is not None:
        c = row.get("cycle_time_s")
        return c is not None and abs(c - observed.cycle_s) <= observed.cycle_tol_s + 1e-12
    return True


def consistent_ranges(
    rows: Sequence[Mapping[str, Any]], params: Sequence[Any]
) -> dict[str, dict[str, Any]]:
    """Per fitted key: the span of the consistent rows' values, how many points, and notes
    (a single point; open below or above: no evaluated inconsistent point beyond it, and
    'touches' when it is also within EDGE_SHARE of the search bound)."""
    scored = [r for r in rows if r.get("loss") is not None]
    good = [r for r in scored if r.get("consistent")]
    bad = [r for r in scored if not r.get("consistent")]
    out: dict[str, dict[str, Any]] = {}
    for p in params:
        entry: dict[str, Any] = {"search": [p.lo, p.hi], "points": len(good)}
        if not good:
            entry.update(low=None, high=None, notes=["no evaluated point is consistent"])
            out[p.key] = entry
            continue
        vals = [r[p.key] for r in good]
        lo, hi = min(vals), max(vals)
        span = float(p.hi - p.lo)
        notes = []
        if len(set(vals)) == 1:
            notes.append("a single point: add trials to see how far it extends")
        if not any(r[p.key] < lo for r in bad):
            if lo - p.lo <= EDGE_SHARE * span:
                notes.append(
                    f"touches the search bound {format_value(p.lo)}: widen the range below it"
                )
            else:
                notes.append(f"open below: no evaluated point under {format_value(lo)} disagrees")
        if not any(r[p.key] > hi for r in bad):
            if p.hi - hi <= EDGE_SHARE * span:
                notes.append(
                    f"touches the search bound {format_value(p.hi)}: widen the range above it"
                )
            else:
                notes.append(f"open above: no evaluated point over {format_value(hi)} disagrees")
        entry.update(low=lo, high=hi, notes=notes)
        out[p.key] = entry
    return out


def _range_text(key: str, r: Mapping[str, Any]) -> str:
    if r["low"] is None:
        return f"{key}: none ({'; '.join(r['notes'])})"
    span = (
        format_value(r["low"])
        if r["low"] == r["high"]
        else f"{format_value(r['low'])}..{format_value(r['high'])}"
    )
    notes = f" ({'; '.join(r['notes'])})" if r["notes"] else ""
    return f"{key} {span}{notes}"


# ---------------------------------------------------------------------------------------
# The study
# ---------------------------------------------------------------------------------------


@dataclass
class CalibrationReport:
    out: Path
    storage: str
    study_name: str
    observed: Observation
    keys: list[str]
    finished: int  # trials that count toward --trials
    ran: int  # trials run by this call
    rows: list[dict[str, Any]]  # every evaluated point, in trial order
    best: dict[str, Any] | None
    ranges: dict[str, dict[str, Any]]
    command: str
    files: list[Path] = field(default_factory=list)
    interrupted: bool = False


def _seeds_text(seeds: Sequence[int]) -> str:
    parts: list[str] = []
    i = 0
    while i < len(seeds):
        j = i
        while j + 1 < len(seeds) and seeds[j + 1] == seeds[j] + 1:
            j += 1
        parts.append(str(seeds[i]) if i == j else f"{seeds[i]}-{seeds[j]}")
        i = j + 1
    return ",".join(parts)


def command_text(
    spec: CalibrationSpec,
    trials: int,
    out: str | os.PathLike,
    storage: str | os.PathLike | None,
    study_name: str,
) -> str:
    """The command that reproduces this calibration (every option that changes the result
    spelled out, defaults included)."""
    s, o = spec.search, spec.observed
    words = [
        "transplanter",
        "calibrate",
        str(s.scenario),
        "--observed",
        f"{o.successes}/{o.seedlings}",
    ]
    if o.cycle_s is not None:
        words += ["--cycle-s", repr(o.cycle_s), "--cycle-tol-s", repr(o.cycle_tol_s)]
    for p in s.params:
        words += ["--fit", f"{p.key}={format_value(p.lo)}..{format_value(p.hi)}"]
    words += [
        "--seeds",
        _seeds_text(s.seeds),
        "--seedlings",
        str(s.seedlings),
        "--trials",
        str(trials),
        "--sampler-seed",
        str(s.sampler_seed),
    ]
    for k, v in s.overrides.items():
        words += ["--set", f"{k}={_toml_value(v)}"]
    if storage is not None:
        words += ["--storage", str(storage), "--study", study_name]
    words += ["--out", str(out)]
    return shlex.join(words)


def run_calibrate(
    spec: CalibrationSpec,
    trials: int,
    out: str | os.PathLike,
    storage: str | os.PathLike | None = None,
    study_name: str = "calibrate",
    workers: int = 1,
    backend: str = "process",
    address: str | None = None,
    progress: bool = False,
) -> CalibrationReport:
    """Run the study until `trials` trials count (with `storage`, a rerun resumes), then
    write calibration.csv, calibration.json and calibrated.toml into `out` (also after
    Ctrl-C, from the trials that finished)."""
    optuna = _import_optuna("calibrate")
    if not 1 <= trials <= MAX_TRIALS:
        raise SweepRefused(f"--trials must be 1..{MAX_TRIALS}, got {trials}")
    check_backend(backend, workers, address)
    search = spec.search
    digest = scenario_digest(search.check())
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise SweepRefused(f"--out {out} is a file; give a directory")
    if storage is not None and Path(storage).exists() and not Path(storage).is_file():
        raise SweepRefused(f"--storage {storage} is not a file; give a .db file's path")
    out.mkdir(parents=True, exist_ok=True)
    check_out_files(out, (CSV_NAME, JSON_NAME, TOML_NAME), search.scenario)  # before any trial
    study, url = open_study(
        optuna, storage, study_name, ["minimize"], "calibrate", spec.identity(digest),
        ["deviance_g2"],  # optuna-dashboard's and the plots' axis
    )  # fmt: skip
    observed = spec.observed

    def objective(scored: Mapping[str, Any]) -> float | None:
        if scored["successes"] is None:
            return None
        value = loss(scored["successes"], scored["seedlings"], scored["cycle_time_s"], observed)
        return value if math.isfinite(value) else None

    def describe(study) -> str:
        done = [t for t in study.get_trials(deepcopy=False) if t.values]
        if not done:
            return ""
        best = min(done, key=lambda t: (t.values[0], t.number))
        return f"best loss {best.values[0]:.3g} (trial {best.number})"

    finished, ran, interrupted = drive_study(
        optuna,
        study,
        search,
        trials,
        objective,
        workers=workers,
        backend=backend,
        address=address,
        progress=progress,
        describe=describe,
    )
    command = command_text(spec, trials, out, storage, study_name)
    with interrupts.held():  # a stop signal now waits until the files are written
        report = _write_outputs(
            spec, study, out, url, study_name, finished, ran, interrupted, command
        )
    if interrupts.take_pending() is not None:
        report.interrupted = True
    return report


def _on_grid(key: str, value: Any) -> Any:
    """A sampled value as the decimal on its key's grid (30.073999999999998 -> 30.074)."""
    from transplanter.scenario.assemble import key_quantum

    step = key_quantum(key)
    if step is None or not isinstance(value, float):
        return value
    return round(value, max(0, -math.floor(math.log10(step) + 1e-9)))


def _rows(spec: CalibrationSpec, study) -> list[dict[str, Any]]:
    import optuna

    keys = [p.key for p in spec.search.params]
    rows = []
    for t in study.get_trials(deepcopy=False):
        if t.state not in (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL):
            continue
        attrs = t.user_attrs
        if "errors" not in attrs:  # stopped by Ctrl-C, not judged
            continue
        row: dict[str, Any] = {"trial": t.number, "state": t.state.name}
        row.update({k: _on_grid(k, t.params.get(k)) for k in keys})
        for k in JUDGED_FIELDS:
            row[k] = attrs.get(k)
        errors = list(attrs.get("errors") or [])
        if t.state == optuna.trial.TrialState.COMPLETE:
            row["loss"] = t.values[0]
            row["consistent"] = is_consistent(row, spec.observed)
        else:
            row["loss"] = None
            row["consistent"] = False
            if row["successes"] is not None and spec.observed.cycle_s is not None:
                errors.append("no timed cycle to compare with --cycle-s")
        row["error"] = "; ".join(errors) or None
        rows.append(row)
    return rows


def _write_outputs(spec, study, out, url, study_name, finished, ran, interrupted, command):
    search, observed = spec.search, spec.observed
    keys = [p.key for p in search.params]
    rows = _rows(spec, study)
    scored = [r for r in rows if r["loss"] is not None]
    best = min(scored, key=lambda r: (r["loss"], r["trial"])) if scored else None
    ranges = consistent_ranges(rows, search.params)
    report = CalibrationReport(
        out,
        url,
        study_name,
        observed,
        keys,
        finished,
        ran,
        rows,
        best,
        ranges,
        command,
        interrupted=interrupted,
    )
    write_csv_atomic(out / CSV_NAME, ["trial", "state", *keys, *RESULT_FIELDS], rows)
    report.files.append(out / CSV_NAME)
    payload = {
        "scenario": str(search.scenario),
        "overrides": dict(search.overrides),
        "fit": [{"key": p.key, "kind": p.kind, "low": p.lo, "high": p.hi} for p in search.params],
        "seeds": list(search.seeds),
        "seedlings": search.seedlings,
        "sampler_seed": search.sampler_seed,
        "observed": observed.to_dict(),
        "loss": "binomial deviance G^2 of twin k/n against observed K/N"
        + (
            " + ((|cycle - observed| - tol) / tol)^2 beyond the tolerance"
            if observed.cycle_s is not None
            else ""
        ),
        "consistent_if": "pooled twin rate inside the observation's Wilson 95 % interval"
        + (" and mean cycle within the tolerance" if observed.cycle_s is not None else ""),
        "study": study_name,
        "storage": url,
        "trials": finished,
        "interrupted": interrupted,
        "best": best,
        "consistent_points": sum(bool(r["consistent"]) for r in rows),
        "consistent_ranges": ranges,
        "command": command,
    }
    fileio.write_json_atomic(out / JSON_NAME, payload, follow=False)
    report.files.append(out / JSON_NAME)
    if best is not None:
        path = out / TOML_NAME
        fileio.write_text_atomic(
            path, calibrated_toml(spec, best, ranges, command, out), follow=False
        )
        try:
            load_scenario(path)
        except ScenarioError as exc:  # pragma: no cover - a bug here, never the user's input
            raise AssertionError(f"{TOML_NAME} does not load: {exc}") from None
        report.files.append(path)
    return report


def calibrated_toml(
    spec: CalibrationSpec,
    best: Mapping[str, Any],
    ranges: Mapping[str, Mapping[str, Any]],
    command: str,
    out: Path,
) -> str:
    """The calibrated scenario: `base =` the original, the fitted keys at the best point and
    the --set keys; the observation, seeds, command and consistent ranges as comments."""
    search = spec.search
    lo, hi = best["ci95_low"], best["ci95_high"]
    cycle = best["cycle_time_s"]
    lines = [
        "written by `transplanter calibrate`",
        f"observed: {spec.observed.text()}",
        f"twin at the fitted point (trial {best['trial']}): {best['successes']}/"
        f"{best['seedlings']} ({100 * best['success_rate']:.1f} %, 95 % {100 * lo:.1f}-"
        f"{100 * hi:.1f} %), mean cycle {'-' if cycle is None else f'{cycle:.3f} s'}, loss "
        f"{best['loss']:.3g}",
        f"seed{'s' if len(search.seeds) > 1 else ''} {', '.join(map(str, search.seeds))}; "
        f"{search.seedlings} seedlings per trial",
        "consistent with the observation's 95 % interval:",
        *(f"  {_range_text(k, r)}" for k, r in ranges.items()),
        f"command: {command}",
    ]
    if search.overrides:
        lines.append("held fixed with --set: " + ", ".join(search.overrides))
    keys = [p.key for p in search.params]
    return scenario_toml(search, {k: best[k] for k in keys}, out, lines)


def format_summary(report: CalibrationReport, top: int = 10) -> str:
    """The printed summary: the observation, the best points (lowest loss first), the best
    point and the consistent ranges."""
    keys = report.keys
    width = max(8, *(len(k) for k in keys))
    lines = [f"observed: {report.observed.text()}"]
    scored = sorted(
        (r for r in report.rows if r["loss"] is not None), key=lambda r: (r["loss"], r["trial"])
    )
    head = "  ".join(f"{k:>{width}}" for k in keys)
    lines.append(
        f"trial  {head}  {'twin success':>18}  {'95 % CI':>13}  {'cycle s':>7}  "
        f"{'loss':>8}  consistent"
    )
    for r in scored[:top]:
        values = "  ".join(f"{format_value(r[k]):>{width}}" for k in keys)
        rate = f"{100 * r['success_rate']:.1f} % ({r['successes']}/{r['seedlings']})"
        ci = f"{100 * r['ci95_low']:.1f}-{100 * r['ci95_high']:.1f} %"
        cycle = "-" if r["cycle_time_s"] is None else f"{r['cycle_time_s']:.3f}"
        lines.append(
            f"{r['trial']:>5}  {values}  {rate:>18}  {ci:>13}  {cycle:>7}  "
            f"{r['loss']:>8.3g}  {'yes' if r['consistent'] else 'no'}"
        )
    if len(scored) > top:
        lines.append(f"... and {len(scored) - top} more points (see {CSV_NAME})")
    failed = len(report.rows) - len(scored)
    if failed:
        lines.append(f"{failed} points could not be scored (see the error column of {CSV_NAME})")
    if report.best is None:
        lines.append("no point could be scored: nothing is calibrated")
        return "\n".join(lines)
    b = report.best
    values = ", ".join(f"{k} = {format_value(b[k])}" for k in keys)
    lines.append(f"fitted (lowest loss, trial {b['trial']}): {values}")
    lines.append(
        f"  twin there: {100 * b['success_rate']:.1f} % ({b['successes']}/{b['seedlings']}), "
        f"95 % {100 * b['ci95_low']:.1f}-{100 * b['ci95_high']:.1f} %"
        + ("" if b["cycle_time_s"] is None else f", mean cycle {b['cycle_time_s']:.3f} s")
    )
    good = sum(bool(r["consistent"]) for r in report.rows)
    lines.append(f"consistent with the observation: {good} of {len(report.rows)} points")
    lines += [f"  {_range_text(k, r)}" for k, r in report.ranges.items()]
    return "\n".join(lines)
