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
- `runs.csv`, `settings.csv`: rewritten atomically from the rows at the end and on Ctrl-C;
  `settings.csv` pools each setting's seeds with `stats.pooled_rate`.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import hashlib
import itertools
import json
import math
import os
import re
import signal
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from pathlib import Path
from typing import Any

from transplanter import fileio
from transplanter.results import FAILURE_KINDS
from transplanter.scenario import ScenarioError, check_value, key_spec, load_scenario, parse_value
from transplanter.stats import pooled_rate

__all__ = [
    "Axis",
    "BACKENDS",
    "BackendMissing",
    "SweepRefused",
    "SweepReport",
    "SweepSpec",
    "aggregate",
    "make_backend",
    "parse_param_range",
    "parse_vary",
    "run_key",
    "run_one",
    "run_sweep",
]

BACKENDS = ("process", "ray", "inline")
MAX_GRID_VALUES = 10000  # values of one --vary key; more is a typo, not a sweep
MAX_RUNS = 1_000_000
# Keys a sweep sets itself (one trial per seed, --seedlings), never varied.
RESERVED_KEYS = ("scenario.seed", "scenario.seedlings")

RUNS_JSONL, RUNS_CSV, SETTINGS_CSV = "runs.jsonl", "runs.csv", "settings.csv"
MANIFEST = "sweep.json"

_DECIMAL_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")

# Columns of a run's row after the varied keys.
RESULT_FIELDS = (
    "seed",
    "successes",
    "seedlings",
    "success_rate",
    "cycle_time_s",
    "cycle_time_sd_s",
    "cycles",
    *(f"fail_{k}" for k in FAILURE_KINDS),
    "lost_step_events",
    "valid",
    "fault",
    "sim_time_s",
    "wall_time_s",
    "error",
)
# Columns of settings.csv after the varied keys.
SETTING_FIELDS = (
    "runs",
    "errors",
    "successes",
    "seedlings",
    "success_rate",
    "ci95_low",
    "ci95_high",
    "ci_method",
    "cycle_time_s",
)


class SweepRefused(ValueError):
    """A sweep that cannot start (bad grid, output directory of another sweep); the message
    says why and what to do."""


class BackendMissing(SweepRefused):
    """The backend's package is not installed."""


# ---------------------------------------------------------------------------------------
# The grid
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Axis:
    """One varied key ('section.key' in its file unit) and its values, in order."""

    key: str
    values: tuple[Any, ...]


def _decimal(text: str, where: str) -> Decimal:
    text = text.strip()
    if not (text.isascii() and _DECIMAL_RE.fullmatch(text)):
        raise SweepRefused(f"{where}: {text!r} is not a number (ASCII digits 0-9)")
    try:
        return Decimal(text)
    except InvalidOperation:  # pragma: no cover - the regex admits only valid decimals
        raise SweepRefused(f"{where}: {text!r} is not a number") from None


def _typed(key: str, kind: str, value: Any) -> Any:
    """A float key's value as a float (26 and 26.0 are one setting); others as given."""
    if kind == "float" and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value


def parse_vary(text: str) -> Axis:
    """`KEY=LO:HI:STEP` (HI included, exact decimal steps) or `KEY=a,b,c` -> Axis. Every
    value is checked with the schema (kind, range); SweepRefused naming the key otherwise."""
    key, eq, spec = text.partition("=")
    key = key.strip()
    where = f"--vary {text!r}"
    if not eq or not spec.strip():
        raise SweepRefused(f"{where}: write KEY=LO:HI:STEP or KEY=a,b,c")
    try:
        kind = key_spec(key).kind
    except ScenarioError as exc:
        raise SweepRefused(f"{where}: {exc}") from None
    if key in RESERVED_KEYS:
        raise SweepRefused(f"{where}: a sweep sets {key} itself; use --seeds / --seedlings")
    if kind in ("list", "xy"):
        raise SweepRefused(f"{where}: {key} holds a {kind}; only single values can be varied")
    if ":" in spec and not spec.strip().startswith(('"', "'", "[")):
        values = _grid_range(key, kind, spec, where)
    else:
        values = [_typed(key, kind, parse_value(item)) for item in _split_list(spec)]
    if not values:
        raise SweepRefused(f"{where}: no values")
    if len(values) > MAX_GRID_VALUES:
        raise SweepRefused(f"{where}: {len(values)} values; at most {MAX_GRID_VALUES}")
    seen: list[Any] = []
    for v in values:
        if any(v == s and type(v) is type(s) for s in seen):
            raise SweepRefused(f"{where}: the value {v!r} is given twice")
        seen.append(v)
        try:
            check_value(key, v)
        except ScenarioError as exc:
            raise SweepRefused(f"--vary {key}: {exc}") from None
    return Axis(key, tuple(values))


def _split_list(spec: str) -> list[str]:
    items = [s.strip() for s in spec.split(",")]
    if any(not s for s in items):
        raise SweepRefused(f"--vary: {spec!r} has an empty value between commas")
    return items


def _grid_range(key: str, kind: str, spec: str, where: str) -> list[Any]:
    parts = spec.split(":")
    if len(parts) != 3:
        raise SweepRefused(f"{where}: a range is LO:HI:STEP (three numbers), got {spec!r}")
    if kind not in ("float", "int"):
        raise SweepRefused(f"{where}: {key} is a {kind}; list its values: KEY=a,b,c")
    lo, hi, step = (_decimal(p, where) for p in parts)
    if step <= 0:
        raise SweepRefused(f"{where}: the step must be above 0, got {step}")
    if hi < lo:
        raise SweepRefused(f"{where}: HI {hi} is below LO {lo}; write LO:HI:STEP with LO <= HI")
    count, rest = divmod(hi - lo, step)
    if rest != 0:
        raise SweepRefused(
            f"{where}: the step {step} does not divide the span {lo}..{hi} ({hi - lo}); "
            "choose a step that lands on HI"
        )
    if count + 1 > MAX_GRID_VALUES:
        raise SweepRefused(f"{where}: {count + 1} values; at most {MAX_GRID_VALUES}")
    exact = [lo + i * step for i in range(int(count) + 1)]
    if kind == "int":
        if any(v != v.to_integral_value() for v in (lo, hi, step)):
            raise SweepRefused(f"{where}: {key} takes whole numbers; LO, HI and STEP must be too")
        return [int(v) for v in exact]
    return [float(v) for v in exact]


def parse_param_range(text: str) -> tuple[str, str, Any, Any]:
    """`KEY=LO..HI` for tuning -> (key, kind 'float' or 'int', lo, hi), both ends checked
    with the schema; SweepRefused naming the problem."""
    key, eq, spec = text.partition("=")
    key = key.strip()
    where = f"--param {text!r}"
    lo_text, dots, hi_text = spec.partition("..")
    if not eq or not dots:
        raise SweepRefused(f"{where}: write KEY=LO..HI (e.g. taught.z_low_mm=28..40)")
    try:
        kind = key_spec(key).kind
    except ScenarioError as exc:
        raise SweepRefused(f"{where}: {exc}") from None
    if key in RESERVED_KEYS or kind not in ("float", "int"):
        raise SweepRefused(f"{where}: only number keys can be tuned ({key} is a {kind})")
    lo, hi = _decimal(lo_text, where), _decimal(hi_text, where)
    if not lo < hi:
        raise SweepRefused(f"{where}: LO must be below HI")
    if kind == "int":
        if lo != lo.to_integral_value() or hi != hi.to_integral_value():
            raise SweepRefused(f"{where}: {key} takes whole numbers; LO and HI must be too")
        ends: tuple[Any, Any] = (int(lo), int(hi))
    else:
        ends = (float(lo), float(hi))
    for v in ends:
        try:
            check_value(key, v)
        except ScenarioError as exc:
            raise SweepRefused(f"--param {key}: {exc}") from None
    return key, kind, ends[0], ends[1]


@dataclass(frozen=True)
class SweepSpec:
    """What a sweep runs: a scenario (file or packaged name) with `overrides` (--set), the
    varied axes, the seeds and the seedlings per trial."""

    scenario: str
    axes: tuple[Axis, ...]
    seeds: tuple[int, ...]
    seedlings: int
    overrides: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        keys = [a.key for a in self.axes]
        if not keys:
            raise SweepRefused("a sweep needs at least one --vary KEY=...")
        if len(set(keys)) != len(keys):
            raise SweepRefused("--vary: a key is varied twice; give each key once")
        for k in keys:
            if k in self.overrides:
                raise SweepRefused(f"{k} is both set (--set) and varied (--vary); drop one")
        if not self.seeds:
            raise SweepRefused("--seeds: give at least one seed")
        if self.runs_total > MAX_RUNS:
            raise SweepRefused(f"{self.runs_total} runs; at most {MAX_RUNS}")

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(a.key for a in self.axes)

    def settings(self) -> list[dict[str, Any]]:
        """Every combination of the axes' values, the first key outermost."""
        return [
            dict(zip(self.keys, combo, strict=True))
            for combo in itertools.product(*(a.values for a in self.axes))
        ]

    @property
    def runs_total(self) -> int:
        return math.prod(len(a.values) for a in self.axes) * len(self.seeds)

    def base_overrides(self) -> dict[str, Any]:
        return {**self.overrides, "scenario.seedlings": self.seedlings}

    def check(self):
        """The scenario with the --set overrides and seedlings, or ScenarioError (before any
        run: a bad --set key, too many seedlings for the conveyor)."""
        return load_scenario(self.scenario, self.base_overrides())

    def tasks(self) -> list[dict[str, Any]]:
        """One task per (setting, seed), in grid order: what `run_one` takes."""
        return [
            {
                "scenario": self.scenario,
                "overrides": dict(self.overrides),
                "setting": setting,
                "seed": seed,
                "seedlings": self.seedlings,
            }
            for setting in self.settings()
            for seed in self.seeds
        ]

    def manifest(self) -> dict[str, Any]:
        """What identifies the sweep's results (not how it is run: backend, workers)."""
        scenario = self.check()
        # each run sets its own seed; the seedlings are a field of their own
        meta = dataclasses.replace(scenario.meta, seed=0, seedlings=0)
        sections = [meta] + [
            getattr(scenario, f.name)
            for f in dataclasses.fields(scenario)
            if f.name not in ("path", "meta", "overrides")
        ]
        digest = hashlib.sha256(repr(sections).encode()).hexdigest()
        return {
            "scenario": str(self.scenario),
            "scenario_name": scenario.name,
            "scenario_digest": digest,
            "overrides": dict(self.overrides),
            "vary": [{"key": a.key, "values": list(a.values)} for a in self.axes],
            "seeds": list(self.seeds),
            "seedlings": self.seedlings,
        }


# Manifest fields that must match for a rerun to add to the results ("scenario" is the
# text given on the command line: the digest says whether it is the same scenario).
_MANIFEST_IDENTITY = (
    "scenario_name",
    "scenario_digest",
    "overrides",
    "vary",
    "seeds",
    "seedlings",
)


def run_key(setting: Mapping[str, Any], seed: int, keys: Sequence[str]) -> str:
    """The identity of a run: its varied values (in the keys' order) and seed, as JSON."""
    return json.dumps([[k, setting[k]] for k in keys] + [["seed", seed]])


# ---------------------------------------------------------------------------------------
# One run
# ---------------------------------------------------------------------------------------


def _empty_result() -> dict[str, Any]:
    return {f: None for f in RESULT_FIELDS if f != "seed"}


def run_one(task: Mapping[str, Any]) -> dict[str, Any]:
    """One trial as `transplanter trial` runs it, as a row: the varied values, the seed, the
    counts and times; a setting the scenario refuses or a trial that raised is a row with
    its `error` (never an exception)."""
    from transplanter.config import assemble
    from transplanter.trial import run_trial

    row: dict[str, Any] = {**task["setting"], "seed": task["seed"], **_empty_result()}
    t0 = time.perf_counter()
    overrides = {
        **task["overrides"],
        **task["setting"],
        "scenario.seed": task["seed"],
        "scenario.seedlings": task["seedlings"],
    }
    try:
        config = assemble(load_scenario(task["scenario"], overrides), preflight=True)
    except ScenarioError as exc:
        row["error"] = f"setting refused: {exc}"
        row["wall_time_s"] = time.perf_counter() - t0
        return row
    try:
        result = run_trial(config)
    except Exception as exc:  # the physics or the firmware raised: a row, not a crash
        row["error"] = f"{type(exc).__name__}: {exc}"
        row["wall_time_s"] = time.perf_counter() - t0
        return row
    d = result.to_dict()
    row.update(
        successes=d["successes"],
        seedlings=d["seedlings"],
        success_rate=d["success_rate"],
        cycle_time_s=d["cycle_time_s"],
        cycle_time_sd_s=d["cycle_time_sd_s"],
        cycles=int(result.cycle_times.size),
        lost_step_events=len(d["lost_step_events"]),
        valid=d["valid"],
        fault=d["fault"],
        sim_time_s=d["sim_time_s"],
        wall_time_s=d["wall_time_s"],
    )
    for kind, count in d["failures"].items():
        row[f"fail_{kind}"] = count
    if not d["valid"]:
        row["error"] = f"invalid physics: {d['invalid_reason']}"
    elif d["fault"]:
        row["error"] = f"firmware fault: {d['fault']}"
    return row


# ---------------------------------------------------------------------------------------
# Backends: run tasks, yield rows as they finish (any order)
# ---------------------------------------------------------------------------------------


class InlineBackend:
    """Runs the tasks one after another in this process (notebooks, tests)."""

    workers = 1

    def run(self, tasks: Iterable[Mapping[str, Any]]) -> Iterator[dict[str, Any]]:
        for task in tasks:
            yield run_one(task)

    def close(self) -> None:
        pass


def _ignore_sigint() -> None:
    # Ctrl-C goes to the whole process group: the parent decides, workers are terminated.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class ProcessBackend:
    """A `ProcessPoolExecutor` of spawned processes (MuJoCo and fork do not mix)."""

    def __init__(self, workers: int) -> None:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        self.workers = workers
        self.pool = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_ignore_sigint,
        )

    def run(self, tasks: Iterable[Mapping[str, Any]]) -> Iterator[dict[str, Any]]:
        from concurrent.futures import FIRST_COMPLETED, wait

        pending = {self.pool.submit(run_one, dict(t)) for t in tasks}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield future.result()
        finally:
            for future in pending:
                future.cancel()

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)

    def terminate(self) -> None:
        """Stop at once (Ctrl-C): running trials are lost, finished rows are kept."""
        processes = list(getattr(self.pool, "_processes", {}).values())
        self.pool.shutdown(wait=False, cancel_futures=True)
        for p in processes:
            p.terminate()
        for p in processes:
            p.join(5)


class RayBackend:
    """Tasks on a Ray cluster (`address`) or a local one of `workers` CPUs."""

    def __init__(self, workers: int, address: str | None = None) -> None:
        try:
            import ray
        except ImportError:
            raise BackendMissing(
                "the ray backend needs Ray: pip install 'transplanter[ray]' (or use "
                "--backend process)"
            ) from None
        self.ray = ray
        self.workers = workers
        self.owns = not ray.is_initialized()
        if self.owns:
            if address is not None:
                ray.init(address=address, log_to_driver=False)
            else:
                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        self.remote = ray.remote(num_cpus=1, max_retries=0)(run_one)

    def run(self, tasks: Iterable[Mapping[str, Any]]) -> Iterator[dict[str, Any]]:
        ray = self.ray
        pending = [self.remote.remote(dict(t)) for t in tasks]
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    yield ray.get(ref)
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)

    def close(self) -> None:
        if self.owns:
            self.ray.shutdown()

    def terminate(self) -> None:
        self.close()


def make_backend(name: str, workers: int, address: str | None = None):
    """A backend by name: 'process' (default), 'ray' or 'inline'."""
    if name not in BACKENDS:
        raise SweepRefused(f"--backend {name!r}: choose one of {', '.join(BACKENDS)}")
    if workers < 1:
        raise SweepRefused(f"--workers must be at least 1, got {workers}")
    if address is not None and name != "ray":
        raise SweepRefused("--address names a Ray cluster: use it with --backend ray")
    if name == "inline":
        return InlineBackend()
    if name == "ray":
        return RayBackend(workers, address)
    return ProcessBackend(workers)


# ---------------------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------------------


def read_runs(path: Path) -> list[dict[str, Any]]:
    """The rows of a runs.jsonl. A torn last line (killed mid-write: no newline, or not
    JSON) is cut off the file so that new rows append cleanly and its run is run again; a
    damaged line before the last is refused."""
    if not path.exists():
        return []
    data = path.read_bytes()
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
        with open(path, "r+b") as f:
            f.truncate(pos)
            os.fsync(f.fileno())
    return rows


class RunLog:
    """runs.jsonl opened for appending, locked against a second sweep writing it."""

    def __init__(self, path: Path) -> None:
        import fcntl

        self.f = open(path, "a", encoding="utf-8")
        try:
            fcntl.flock(self.f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.f.close()
            raise SweepRefused(
                f"{path} is being written by another sweep; wait for it or use another --out"
            ) from None

    def append(self, row: Mapping[str, Any]) -> None:
        self.f.write(json.dumps(row) + "\n")
        self.f.flush()
        os.fsync(self.f.fileno())

    def close(self) -> None:
        self.f.close()


def _cell(value: Any) -> Any:
    return "" if value is None else value


def write_csv_atomic(path: Path, fields: Sequence[str], rows: Iterable[Mapping[str, Any]]) -> None:
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
    fileio.commit(tmp, path)


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
    differs = [k for k in _MANIFEST_IDENTITY if old.get(k) != manifest.get(k)]
    if differs:
        raise SweepRefused(
            f"{out} holds the results of a different sweep (it differs in: "
            f"{', '.join(differs)}); results of two sweeps are never mixed: use another --out "
            "or delete that directory"
        )
    return True


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


def aggregate(rows: Iterable[Mapping[str, Any]], keys: Sequence[str]) -> list[dict[str, Any]]:
    """One row per distinct value of `keys` (in first-seen order): the runs pooled with
    `stats.pooled_rate` (runs that raised or were refused are counted in `errors` only) and
    the mean cycle time over all their timed cycles."""
    groups: dict[str, list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault(json.dumps([row[k] for k in keys]), []).append(row)
    out = []
    for members in groups.values():
        agg: dict[str, Any] = {k: members[0][k] for k in keys}
        counted = [r for r in members if r["successes"] is not None]
        agg.update(runs=len(members), errors=sum(r["error"] is not None for r in members))
        agg.update({f: None for f in SETTING_FIELDS[2:]})
        if counted:
            pooled = pooled_rate(
                [r["successes"] for r in counted], [r["seedlings"] for r in counted]
            )
            agg.update(
                successes=pooled.successes,
                seedlings=pooled.seedlings,
                success_rate=pooled.success_rate,
                ci95_low=pooled.ci95[0],
                ci95_high=pooled.ci95[1],
                ci_method=pooled.method,
            )
            timed = [r for r in counted if r["cycles"]]
            n = sum(r["cycles"] for r in timed)
            if n:
                agg["cycle_time_s"] = sum(r["cycle_time_s"] * r["cycles"] for r in timed) / n
        out.append(agg)
    return out


def format_value(v: Any) -> str:
    """A grid value as text: 26.0 -> '26', 26.5 -> '26.5', 'scurve' -> 'scurve'."""
    return f"{v:g}" if isinstance(v, float) else str(v)


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
) -> SweepReport:
    """Run every (setting, seed) of the grid not yet in `out`, writing each row as it
    finishes; then the CSVs and the plots. Ctrl-C: the finished rows stay, the CSVs are
    rewritten and the report says `interrupted`."""
    out = Path(out)
    manifest = spec.manifest()  # ScenarioError here: nothing runs
    resumed = check_manifest(out, manifest)
    out.mkdir(parents=True, exist_ok=True)
    if not resumed:
        fileio.write_json_atomic(out / MANIFEST, manifest)
    log = RunLog(out / RUNS_JSONL)
    try:
        done = sort_rows(read_runs(out / RUNS_JSONL), spec)
        finished = {run_key(r, r["seed"], spec.keys) for r in done}
        tasks = [
            t for t in spec.tasks() if run_key(t["setting"], t["seed"], spec.keys) not in finished
        ]
        rows = list(done)
        interrupted = False
        runner = make_backend(backend, workers, address) if tasks else InlineBackend()
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=spec.runs_total, initial=len(done), unit="run", dynamic_ncols=True)
            bar.set_postfix_str(best_setting(rows, spec.keys))
        try:
            for row in runner.run(tasks):
                log.append(row)
                rows.append(row)
                if on_row is not None:
                    on_row(row)
                if bar is not None:
                    bar.set_postfix_str(best_setting(rows, spec.keys), refresh=False)
                    bar.update(1)
        except KeyboardInterrupt:
            interrupted = True
            getattr(runner, "terminate", runner.close)()
        else:
            runner.close()
        finally:
            if bar is not None:
                bar.close()
        rows = sort_rows(rows, spec)
        settings = aggregate(rows, spec.keys)
        write_csv_atomic(out / RUNS_CSV, (*spec.keys, *RESULT_FIELDS), rows)
        write_csv_atomic(out / SETTINGS_CSV, (*spec.keys, *SETTING_FIELDS), settings)
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
        from transplanter import plots as plotting

        try:
            report.plots = plotting.sweep_plots(out, spec.keys, rows)
        except (OSError, ValueError) as exc:
            report.plot_error = str(exc)
    return report


def comparable(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Rows without their wall time: what must be identical whatever the backend."""
    return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in rows]


@contextlib.contextmanager
def backend_of(name: str, workers: int, address: str | None = None):
    """A backend, closed on the way out (terminated on Ctrl-C)."""
    runner = make_backend(name, workers, address)
    try:
        yield runner
    except KeyboardInterrupt:
        getattr(runner, "terminate", runner.close)()
        raise
    else:
        runner.close()
