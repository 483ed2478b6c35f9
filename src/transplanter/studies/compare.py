"""Machines compared on their jobs by the same judge (`transplanter compare`).

Each scenario (a robot, its effector and a job) runs over the same seeds through the sweep
machinery (`run_sweep` with the scenario as given: parallel, resumable, Ray when asked),
each in its own directory under ``OUT/runs/<label>``; its runs are then pooled into one row
of the comparison:

- ``successes`` / ``seedlings`` / ``success_rate`` with the 95 % interval from the spread
  between trials (`stats.pooled_rate`, as `transplanter trial --seeds` pools);
- ``cycle_time_s``: the job's cycle (on the pot line, whatever robot: a pot's approach to the
  end of its release, the row's index left out; the delta's trays: its time per operation),
  pooled over every timed cycle;
- ``plants_per_hour``: the mean over the seeds of each trial's own figure (the pot line:
  3600 / the pick pitch, one pick's start to the next over whole rows, indexes and recoveries
  included, as the trial's summary; the delta's trays: cells culled or refilled per hour of
  trays, tray changes included);
- ``damage_rate``: damaged / seedlings where the job judges damage (the pot line's bent or
  crushed shoots under every robot, the delta's torn leaves of a refill, the tomatoes'
  bruises), else None;
- failures by kind, summed;
- the drives (`transplanter.twin.motors`): the robot's peak motor torque (N m at the shaft,
  the largest over the seeds), the mechanical energy per seedling and the mean power;
- ``drives_usd`` (the scenario's `[costs] drives_usd`, not physics) and the drives' price per
  plant per hour of capacity.

Rows are ranked within their job (`rank_rows`): by plants per hour among those whose pooled
success interval lies at or above the floor (`--success-floor`), then the undecided (the
interval holds the floor; with the seedlings that would decide it), then those below; ranked
rows whose plants-per-hour intervals overlap tie. Files in OUT: ``compare.json`` (the
manifest and the rows), ``compare.csv``, ``compare.txt`` (a table per job, as printed),
``compare.png`` and, when the rows span several jobs, ``compare_JOB.png`` for each.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from transplanter import fileio
from transplanter.scenario.schema import (
    ScenarioError,
    load_scenario,
    read_overrides,
    units_key,
    units_of,
)
from transplanter.studies.grid import SweepRefused, SweepSpec
from transplanter.studies.jobs import POT_LINE_DAMAGE, job_of
from transplanter.studies.stats import (
    mean_interval,
    poisson_interval,
    pool_runs,
    seedlings_to_decide,
)

__all__ = [
    "CompareReport",
    "CompareSpec",
    "POT_LINE_DAMAGE",
    "compare_row",
    "format_table",
    "rank_rows",
    "run_compare",
]

COMPARE_JSON, COMPARE_CSV, COMPARE_TXT, COMPARE_PNG = (
    "compare.json",
    "compare.csv",
    "compare.txt",
    "compare.png",
)
RUNS_DIR = "runs"

CSV_FIELDS = (
    "rank",
    "scenario",
    "robot",
    "effector",
    "workcell",
    "trials",
    "errors",
    "successes",
    "seedlings",
    "unit",
    "success_rate",
    "ci95_low",
    "ci95_high",
    "meets_floor",
    "verdict",
    "decide_seedlings",
    "cycle_time_s",
    "cycle",
    "plants_per_hour",
    "plants_per_hour_ci95_low",
    "plants_per_hour_ci95_high",
    "tie",
    "damage_rate",
    "jams_per_1000",
    "jams_per_1000_ci95_low",
    "jams_per_1000_ci95_high",
    "peak_motor_torque_nm",
    "energy_per_seedling_j",
    "mean_power_w",
    "drives_usd",
    "usd_per_plant_per_hour",
    "failures",
)


JAM_FIELD = "fail_funnel_jam"
"""A run's count of jams (the pot line's judge: a pot stuck in the funnel, the jam itself, not
what followed it); a row gets its rate per 1,000 units with Poisson's exact interval."""


@dataclass(frozen=True)
class CompareSpec:
    """What a comparison runs: the scenarios (files or packaged names), the seeds every one
    runs on, the seedlings per trial (None: each scenario's own), the `--set` overrides
    applied to every scenario and the success floor of the ranking."""

    scenarios: tuple[str, ...]
    seeds: tuple[int, ...]
    seedlings: int | None = None
    overrides: Mapping[str, Any] = field(default_factory=dict)
    success_floor: float = 0.9

    def __post_init__(self) -> None:
        if not self.scenarios:
            raise SweepRefused("compare needs at least one scenario")
        if not self.seeds:
            raise SweepRefused("--seeds: give at least one seed")
        if not 0.0 <= self.success_floor <= 1.0:
            raise SweepRefused(
                f"--success-floor {self.success_floor:g} is not a share: give 0 to 1 (0.9 is 90 %)"
            )
        labels = self.labels()
        seen: dict[str, str] = {}
        for s, label in zip(self.scenarios, labels, strict=True):
            if label in seen:
                raise SweepRefused(
                    f"two scenarios compare as {label!r} ({seen[label]} and {s}): give each "
                    "once, or copy one to a file of another name"
                )
            seen[label] = s

    def labels(self) -> list[str]:
        """Each scenario's row name: its file's stem (a packaged scenario's name)."""
        return [_label(s) for s in self.scenarios]

    def sweeps(self) -> list[SweepSpec]:
        """One single-setting sweep per scenario (refused here if a scenario is bad)."""
        out, used = [], set()
        for s in self.scenarios:
            own = read_overrides(s, self.overrides)  # a --set reaches the scenarios that read it
            used |= set(own)
            seedlings = self.seedlings
            if units_key(s, own) in own:  # its own --set count is more particular
                seedlings = None
            elif seedlings is None:
                seedlings = units_of(load_scenario(s, own))
            out.append(SweepSpec(s, (), self.seeds, seedlings, own, design="one"))
        unread = sorted(set(self.overrides) - used)
        if unread:
            from transplanter import kinds

            who = [(*k.split(".", 1), ", ".join(kinds.readers(*k.split(".", 1))) or "no kind")
                   for k in unread]  # fmt: skip
            them = "them" if len(unread) > 1 else "it"
            raise ScenarioError(
                f"--set {', '.join(unread)}: no scenario of the comparison reads {them} (by "
                f"its robot, effector and job kinds): {kinds.describe_unread(who)}; remove "
                f"{them}, or add a scenario whose kinds read {them}"
            )
        return out

    def manifest(self, sweeps: Sequence[SweepSpec]) -> dict[str, Any]:
        return {
            "scenarios": [
                {"label": label, **{k: m[k] for k in ("scenario", "scenario_digest", "seedlings")}}
                for label, m in zip(self.labels(), (s.manifest() for s in sweeps), strict=True)
            ],
            "seeds": list(self.seeds),
            "overrides": dict(self.overrides),
        }


def _label(scenario: str | os.PathLike) -> str:
    stem = Path(str(scenario)).name
    stem = stem[:-5] if stem.endswith(".toml") else stem
    return re.sub(r"[^A-Za-z0-9_.-]", "_", stem) or "scenario"


def compare_row(
    label: str, scenario, rows: Sequence[Mapping[str, Any]], floor: float
) -> dict[str, Any]:
    """One scenario's runs pooled into its comparison row (module docstring)."""
    job = job_of(scenario)
    counted = [r for r in rows if r.get("successes") is not None and r.get("seedlings")]
    out: dict[str, Any] = {
        "scenario": label,
        "name": scenario.meta.name,
        "robot": scenario.robot.kind,
        "effector": scenario.effector.kind,
        "workcell": scenario.workcell.kind,
        "job": job.kind if job is not None else f"{scenario.robot.kind}:{scenario.workcell.kind}",
        "seeds": [r["seed"] for r in rows],
        "trials": len(counted),
        "errors": sum(1 for r in rows if r.get("error")),
        "error_messages": sorted({r["error"] for r in rows if r.get("error")}),
        "unit": job.unit if job is not None else "seedlings",
        "cycle": job.label if job is not None else "cycle",
        "successes": None,
        "seedlings": None,
        "success_rate": None,
        "ci95": None,
        "ci_method": None,
        "cycle_time_s": None,
        "plants_per_hour": None,
        "damage_rate": None,
        "failures": {},
        "peak_motor_torque_nm": None,
        "motor_energy_j": None,
        "energy_per_seedling_j": None,
        "mean_power_w": None,
        "drives_usd": scenario.costs.drives_usd or None,
        "usd_per_plant_per_hour": None,
        "meets_floor": False,
        "verdict": None,
        "decide_seedlings": None,
        "more": job.more if job is not None else "--seedlings x seeds",
        "plants_per_hour_ci95": None,
        "jams_per_1000": None,
        "jams_per_1000_ci95": None,
    }
    if not counted:
        return out
    pooled, cycle = pool_runs(counted)
    n = pooled.seedlings
    out.update(
        successes=pooled.successes,
        seedlings=n,
        success_rate=pooled.success_rate,
        ci95=list(pooled.ci95),
        ci_method=pooled.method,
        cycle_time_s=cycle,
        verdict=verdict(pooled.ci95, floor),
    )
    out["meets_floor"] = out["verdict"] == ABOVE
    if out["verdict"] == UNDECIDED:
        out["decide_seedlings"] = seedlings_to_decide(pooled.success_rate, floor)
    rates = [r["plants_per_hour"] for r in counted if r.get("plants_per_hour") is not None]
    if rates:
        out["plants_per_hour"] = sum(rates) / len(rates)
        band = mean_interval(rates)
        out["plants_per_hour_ci95"] = None if band is None else list(band)
    damage = POT_LINE_DAMAGE if job is None else job.damage
    if damage is not None:
        out["damage_rate"] = sum(r.get(f) or 0 for r in counted for f in damage) / n
    kinds = sorted({k for r in counted for k in r if k.startswith("fail_")})
    out["failures"] = {
        k.removeprefix("fail_"): total
        for k in kinds
        if (total := sum(r.get(k) or 0 for r in counted))
    }
    if any(r.get(JAM_FIELD) is not None for r in counted):  # a judge that names a jam
        jams = sum(r.get(JAM_FIELD) or 0 for r in counted)
        lo, hi = poisson_interval(jams, n)
        out["jams_per_1000"] = 1000.0 * jams / n
        out["jams_per_1000_ci95"] = [1000.0 * lo, 1000.0 * hi]
    peaks = [r["peak_motor_torque_nm"] for r in counted if r.get("peak_motor_torque_nm")]
    out["peak_motor_torque_nm"] = max(peaks) if peaks else None
    metered = [r for r in counted if r.get("motor_energy_j") is not None]
    if metered:
        energy = sum(r["motor_energy_j"] for r in metered)
        out["motor_energy_j"] = energy
        out["energy_per_seedling_j"] = energy / sum(r["seedlings"] for r in metered)
        sim = sum(r.get("sim_time_s") or 0.0 for r in metered)
        out["mean_power_w"] = energy / sim if sim > 0 else None
    if out["drives_usd"] is not None and out["plants_per_hour"]:
        out["usd_per_plant_per_hour"] = out["drives_usd"] / out["plants_per_hour"]
    return out


ABOVE, UNDECIDED, BELOW = "above", "undecided", "below"
"""A row's verdict against the success floor: its pooled 95 % interval lies at or above it
(ranked), holds it (undecided: the trials cannot tell) or lies below it."""


def verdict(ci95: Sequence[float], floor: float) -> str:
    """ABOVE, UNDECIDED or BELOW: where a pooled success interval lies against `floor`."""
    lo, hi = ci95
    return ABOVE if lo >= floor else (BELOW if hi < floor else UNDECIDED)


def _verdict_of(r: Mapping[str, Any]) -> str:
    return r.get("verdict") or (ABOVE if r.get("meets_floor") else BELOW)


PLANTS_PER_HOUR_RESOLUTION = 1.0
"""The finest difference of plants per hour a ranking tells apart: the table counts whole
plants, and two rows whose trials repeat the same pitch exactly (a zero-width interval, as
the five-bar's and the gantry's at the paper's setting: 995.38 and 995.41) are the same for a
grower. Each interval is widened by half of it before two are compared."""


def _overlap(a: Sequence[float] | None, b: Sequence[float] | None, slack: float = 0.0) -> bool:
    return a is not None and b is not None and a[0] - slack <= b[1] and b[0] - slack <= a[1]


def jobs_of(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The rows' jobs (their workcells), in the order they first appear."""
    return list(dict.fromkeys(r.get("workcell") or "" for r in rows))


def rank_rows(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Rows ranked within their job (the workcell: a pot-line row never ranks against a
    tray's): those whose success interval lies at or above the floor by plants per hour (most
    first), then the undecided, then those below, each the same way. Each gets its `rank`
    (1 first within its job) and `tie`: for a ranked row whose plants-per-hour interval over
    the trials overlaps the one ranked just above it (to PLANTS_PER_HOUR_RESOLUTION), the
    first rank of that run of ties
    (None otherwise); the rows come grouped by job."""
    order_of = {ABOVE: 0, UNDECIDED: 1, BELOW: 2}

    def order(r: Mapping[str, Any]):
        pph = r.get("plants_per_hour")
        return (order_of[_verdict_of(r)], -(pph if pph is not None else -math.inf), r["scenario"])

    out: list[dict[str, Any]] = []
    for job in jobs_of(rows):
        ranked = [dict(r) for r in sorted((r for r in rows if (r.get("workcell") or "") == job),
                                          key=order)]  # fmt: skip
        for i, r in enumerate(ranked, 1):
            r["rank"], r["tie"] = i, None
        for above, r in zip(ranked, ranked[1:], strict=False):
            if _verdict_of(above) == _verdict_of(r) == ABOVE and _overlap(
                above.get("plants_per_hour_ci95"),
                r.get("plants_per_hour_ci95"),
                PLANTS_PER_HOUR_RESOLUTION,
            ):
                r["tie"] = above["tie"] or above["rank"]
                above["tie"] = above["tie"] or above["rank"]
        out.extend(ranked)
    return out


def _pct(ci: Sequence[float]) -> str:
    return f"{100 * ci[0]:.1f}-{100 * ci[1]:.1f} %"


def job_notes(rows: Sequence[Mapping[str, Any]], floor: float) -> list[str]:
    """What the data cannot decide among one job's ranked rows: ties on plants per hour,
    undecided rows with the seedlings that would decide them, and leaders whose success
    intervals overlap."""
    notes = []
    ties: dict[int, list[str]] = {}
    for r in rows:
        if r.get("tie") is not None:
            ties.setdefault(r["tie"], []).append(r["scenario"])
    for names in ties.values():
        bands = ", ".join(
            f"{r['plants_per_hour_ci95'][0]:.0f}-{r['plants_per_hour_ci95'][1]:.0f}"
            for r in rows
            if r["scenario"] in names
        )
        notes.append(
            f"  tie: {' and '.join(names)} on plants per hour (their 95 % intervals over the "
            f"trials overlap, to a whole plant an hour: {bands})"
        )
    for r in rows:
        if _verdict_of(r) == UNDECIDED and r.get("ci95"):
            n = r.get("decide_seedlings")
            need = (
                f"at its rate about {n} {r.get('unit', 'seedlings')} would decide it "
                f"({r.get('more', '--seedlings x seeds')})"
                if n is not None
                else "its rate is the floor: no number of trials decides it"
            )
            notes.append(
                f"  undecided: {r['scenario']}: its 95 % interval ({_pct(r['ci95'])}) holds the "
                f"{100 * floor:g} % floor; {need}"
            )
    leaders = [r for r in rows if _verdict_of(r) == ABOVE]
    if len(leaders) >= 2 and _overlap(leaders[0].get("ci95"), leaders[1].get("ci95")):
        a, b = leaders[0], leaders[1]
        notes.append(
            f"  note: the success intervals of {a['scenario']} ({_pct(a['ci95'])}) and "
            f"{b['scenario']} ({_pct(b['ci95'])}) overlap: these {a['trials']} and "
            f"{b['trials']} trials cannot tell which succeeds more; they rank by plants per "
            "hour alone"
        )
    return notes


def _fmt(v: Any, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def format_table(rows: Sequence[Mapping[str, Any]], floor: float) -> str:
    """The comparison as text (what `compare` prints and writes to compare.txt): a table per
    job, its rows ranked within it (`rank_rows`), what its data cannot decide, its failures."""
    head = (
        f"{'#':>3}  {'scenario':<22} {'robot':<8} {'effector':<13} {'job':<13} "
        f"{'success':>13} {'95 % CI':>13} "
        f"{'cycle s':>7} {'plants/h':>8} {'damage':>7} {'jams/1k':>7} {'torque':>7} "
        f"{'J/seedl.':>8} "
        f"{'W':>6} {'drives $':>8} {'$/(pl/h)':>8}"
    )
    mark = {ABOVE: "", UNDECIDED: " ?", BELOW: " *"}
    lines: list[str] = []
    for job in jobs_of(rows):
        these = [r for r in rows if (r.get("workcell") or "") == job]
        unit = these[0].get("unit", "seedlings")
        if lines:
            lines.append("")
        lines.append(f"job {job} ({unit}), ranked within the job:")
        lines.append(head)
        for r in these:
            success = (
                "-"
                if r["success_rate"] is None
                else f"{100 * r['success_rate']:.1f} % {r['successes']}/{r['seedlings']}"
            )
            ci = "-" if r["ci95"] is None else _pct(r["ci95"])
            damage = "-" if r["damage_rate"] is None else f"{100 * r['damage_rate']:.1f} %"
            rank = f"{r['tie']}=" if r.get("tie") is not None else str(r["rank"])
            lines.append(
                f"{rank:>3}  {r['scenario'][:22]:<22} {r['robot']:<8} {r['effector'][:13]:<13} "
                f"{r['workcell'][:13]:<13} {success:>13} {ci:>13} "
                f"{_fmt(r['cycle_time_s'], '.3f'):>7} {_fmt(r['plants_per_hour'], '.0f'):>8} "
                f"{damage:>7} {_fmt(r.get('jams_per_1000'), '.1f'):>7} "
                f"{_fmt(r['peak_motor_torque_nm'], '.3f'):>7} "
                f"{_fmt(r['energy_per_seedling_j'], '.2f'):>8} "
                f"{_fmt(r['mean_power_w'], '.2f'):>6} {_fmt(r['drives_usd'], '.0f'):>8} "
                f"{_fmt(r['usd_per_plant_per_hour'], '.3f'):>8}{mark[_verdict_of(r)]}"
            )
        lines.extend(job_notes(these, floor))
        for r in these:
            if r["failures"] or r["errors"]:
                kinds = ", ".join(f"{k} {v}" for k, v in r["failures"].items()) or "none"
                errs = f"; {r['errors']} run(s) with an error: {'; '.join(r['error_messages'])}"
                lines.append(f"  {r['scenario']}: failures {kinds}{errs if r['errors'] else ''}")
    lines.append(
        f"ranked within each job by plants per hour among rows whose pooled success's 95 % "
        f"interval lies at or above the {100 * floor:g} % floor, then the undecided (?: the "
        "interval holds the floor), then those below it (*); N=: tied with rank N on plants "
        "per hour. jams/1k: pots stuck in the funnel per 1,000 seedlings (its 95 % interval in "
        "compare.json). torque: the robot's peak motor torque (N m at the shaft); J/seedl.: the "
        "drives' mechanical work per seedling; W: their mean power"
    )
    return "\n".join(lines) + "\n"


def job_png(job: str) -> str:
    """The picture of one job's rows when a comparison spans several jobs."""
    return f"compare_{job}.png"


@dataclass
class CompareReport:
    out: Path
    rows: list[dict[str, Any]]
    table: str
    ran: int
    skipped: int
    interrupted: bool = False
    plot: Path | None = None
    plot_error: str | None = None


def run_compare(
    spec: CompareSpec,
    out: str | os.PathLike,
    backend: str = "process",
    workers: int = 1,
    address: str | None = None,
    progress: bool = False,
    plots: bool = True,
    on_scenario: Callable[[str], None] | None = None,
) -> CompareReport:
    """Every scenario over the seeds (resuming what `out` already holds), then the rows,
    the table, compare.json / .csv / .txt and the plot. A different comparison in `out` is
    refused before anything runs."""
    from transplanter.studies.sweep import DirLock, check_out_files, run_sweep

    out = Path(out)
    sweeps = spec.sweeps()  # ScenarioError here: nothing runs
    manifest = spec.manifest(sweeps)
    if out.exists() and not out.is_dir():
        raise SweepRefused(f"--out {out} is a file; give a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SweepRefused(f"--out {out} cannot be made: {exc.strerror or exc}") from None
    lock = DirLock(out)
    try:
        jobs = list(dict.fromkeys(sweep.check().workcell.kind for sweep in sweeps))
        pictures = (COMPARE_PNG, *(job_png(j) for j in jobs)) if len(jobs) > 1 else (COMPARE_PNG,)
        for s in spec.scenarios:
            check_out_files(out, (COMPARE_JSON, COMPARE_CSV, COMPARE_TXT, *pictures), s)
        _check_same(out, manifest)
        runs = out / RUNS_DIR
        for path in (runs, *(runs / label for label in spec.labels())):
            _check_own_dir(path, make=False)  # a planted link refused before anything runs
        rows, ran, skipped, interrupted = [], 0, 0, False
        for label, sweep in zip(spec.labels(), sweeps, strict=True):
            if on_scenario is not None:
                on_scenario(label)
            _check_own_dir(runs, make=True)
            _check_own_dir(runs / label, make=True)
            report = run_sweep(
                sweep, runs / label, backend=backend, workers=workers,
                address=address, progress=progress, plots=False, own_dir=True,
            )  # fmt: skip
            ran += report.ran
            skipped += report.skipped
            scenario = sweep.check()
            rows.append(compare_row(label, scenario, report.rows, spec.success_floor))
            if report.interrupted:
                interrupted = True
                break
        rows = rank_rows(rows)
        table = format_table(rows, spec.success_floor)
        result = CompareReport(out, rows, table, ran, skipped, interrupted)
        payload = {**manifest, "success_floor": spec.success_floor, "complete": not interrupted}
        fileio.write_json_atomic(out / COMPARE_JSON, {**payload, "rows": rows}, follow=False)
        _write_csv(out / COMPARE_CSV, rows)
        fileio.write_text_atomic(out / COMPARE_TXT, table, follow=False)
        if plots and rows and not interrupted:
            try:
                result.plot = plot_compare(rows, spec.success_floor, out / COMPARE_PNG)
                if len(jobs_of(rows)) > 1:  # and a picture per job
                    for job in jobs_of(rows):
                        these = [r for r in rows if r["workcell"] == job]
                        plot_compare(these, spec.success_floor, out / job_png(job))
            except (OSError, ValueError) as exc:
                result.plot_error = str(exc)
        return result
    finally:
        lock.release()


def _check_own_dir(path: Path, make: bool) -> None:
    """SweepRefused if `path` (OUT/runs or a scenario's directory in it: names compare
    derives) is a symbolic link, which would take the scenario's runs elsewhere, or is not a
    directory; made when missing with `make`."""
    if make:
        try:
            path.mkdir()
        except FileExistsError:
            pass
        except OSError as exc:
            raise SweepRefused(f"{path} cannot be made: {exc.strerror or exc}") from None
    if path.is_symlink():
        raise SweepRefused(
            f"{path} is a symbolic link; compare keeps each scenario's runs under "
            f"{RUNS_DIR}/ itself and never writes through a link: remove the link or use "
            "another --out"
        )
    if os.path.lexists(path) and not path.is_dir():
        raise SweepRefused(
            f"{path} is not a directory; compare keeps a scenario's runs there: move it away "
            "or use another --out"
        )


def _check_same(out: Path, manifest: Mapping[str, Any]) -> None:
    path = out / COMPARE_JSON
    if not path.exists():
        return
    try:
        old = json.loads(fileio.read_text_input(path, 1 << 26, "comparison"))
    except (fileio.FileRefused, ValueError) as exc:
        raise SweepRefused(f"{path} cannot be read ({exc}); use another --out") from None
    if not isinstance(old, dict):  # valid JSON, but not what compare writes (null, [] ...)
        from transplanter.studies.sweep import _json_kind

        raise SweepRefused(
            f"{path} is not a comparison's manifest (a JSON object expected, it holds "
            f"{_json_kind(old)}); use another --out, or move the file away to start over"
        )
    differs = [k for k in ("scenarios", "seeds", "overrides") if old.get(k) != manifest.get(k)]
    if differs:
        raise SweepRefused(
            f"{out} holds another comparison (it differs in: {', '.join(differs)}); results "
            "of two comparisons are never mixed: use another --out or delete that directory"
        )


def _write_csv(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    from transplanter.studies.sweep import write_csv_atomic

    flat = []
    for r in rows:
        f = dict(r)
        f["ci95_low"], f["ci95_high"] = r["ci95"] if r["ci95"] else (None, None)
        band = r.get("plants_per_hour_ci95")
        f["plants_per_hour_ci95_low"], f["plants_per_hour_ci95_high"] = band or (None, None)
        jams = r.get("jams_per_1000_ci95")
        f["jams_per_1000_ci95_low"], f["jams_per_1000_ci95_high"] = jams or (None, None)
        f["failures"] = " ".join(f"{k}={v}" for k, v in r["failures"].items())
        flat.append(f)
    write_csv_atomic(path, CSV_FIELDS, flat)


def plot_compare(rows: Sequence[Mapping[str, Any]], floor: float, path: Path) -> Path:
    """compare.png (and compare_JOB.png, one job's rows): plants per hour, pooled success
    with its interval and the floor, cycle, and the drives' energy per seedling, one bar per
    scenario in rank order within each job (hatched: its interval below the floor; dotted:
    it holds the floor). Written atomically."""
    from transplanter.studies.plots import _pyplot, _save

    plt = _pyplot()

    several = len(jobs_of(rows)) > 1
    names = [
        (f"{r['workcell']}: " if several else "")
        + (f"{r['tie']}= " if r.get("tie") is not None else f"{r['rank']}. ")
        + r["scenario"]
        for r in rows
    ]
    hatch = [{ABOVE: "", UNDECIDED: ".."}.get(_verdict_of(r), "//") for r in rows]
    colors = [f"C{i % 10}" for i in range(len(rows))]

    def values(key: str, scale: float = 1.0) -> list[float]:
        return [math.nan if r[key] is None else scale * r[key] for r in rows]

    fig, axes = plt.subplots(2, 3, figsize=(15, 7.5), layout="constrained")
    panels = (
        (axes[0, 0], values("plants_per_hour"), "plants per hour"),
        (axes[0, 1], values("success_rate", 100), "pooled success (%), 95 % interval"),
        (axes[0, 2], values("cycle_time_s"), "cycle / time per operation (s)"),
        (axes[1, 0], values("energy_per_seedling_j"), "drives' work per seedling (J)"),
        (axes[1, 1], values("peak_motor_torque_nm"), "robot's peak motor torque (N m, shaft)"),
        (axes[1, 2], values("usd_per_plant_per_hour"), "drives' cost per plant/h (US$)"),
    )
    y = list(range(len(rows)))
    for ax, v, title in panels:
        bars = ax.barh(y, [0 if math.isnan(x) else x for x in v], color=colors)
        for b, h in zip(bars, hatch, strict=True):
            b.set_hatch(h)
        ax.set_yticks(y, names)
        ax.invert_yaxis()
        ax.set_title(title)
        ax.grid(axis="x", alpha=0.3)
    ax = axes[0, 1]
    # never below 0: Wilson's upper end at 60/60 is 0.9999999999999998, under the rate's 1.0
    lo = [max(100 * (r["success_rate"] - r["ci95"][0]), 0.0) if r["ci95"] else 0 for r in rows]
    hi = [max(100 * (r["ci95"][1] - r["success_rate"]), 0.0) if r["ci95"] else 0 for r in rows]
    ax.errorbar(
        [0 if math.isnan(x) else x for x in values("success_rate", 100)], y,
        xerr=[lo, hi], fmt="none", ecolor="black", capsize=4,
    )  # fmt: skip
    ax.axvline(100 * floor, color="red", linestyle="--", label=f"floor {100 * floor:g} %")
    ax.set_xlim(0, 100)
    ax.legend(loc="lower left")
    seeds = sorted({s for r in rows for s in r["seeds"]})
    which = (
        f"seed {seeds[0]}" if len(seeds) == 1 else f"{len(seeds)} seeds ({seeds[0]}-{seeds[-1]})"
    )
    jobs = jobs_of(rows)
    fig.suptitle(
        f"{len(rows)} machine(s) on {'their jobs' if several else 'the job ' + jobs[0]}, "
        f"{which} each, ranked within each job; hatched //: pooled success interval below the "
        f"{100 * floor:g} % floor, dotted: it holds the floor (undecided)"
    )
    return _save(fig, path)
