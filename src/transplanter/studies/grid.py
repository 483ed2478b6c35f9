"""The grid of a sweep: varied keys and their values (`--vary`, `--param`), checked with the
scenario schema, and the spec that lists every (setting, seed) run and the manifest that
identifies a sweep's results."""

from __future__ import annotations

import itertools
import json
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from typing import Any

from transplanter.errors import TransplanterError
from transplanter.scenario.assemble import key_quantum
from transplanter.scenario.schema import (
    ScenarioError,
    check_value,
    key_spec,
    load_scenario,
    parse_value,
    scenario_digest,
    with_units,
)

MAX_GRID_VALUES = 10000  # values of one --vary key; more is a typo, not a sweep
MAX_RUNS = 1_000_000
# Keys a sweep sets itself (one trial per seed, --seedlings), never varied.
RESERVED_KEYS = ("scenario.seed", "scenario.seedlings")

_DECIMAL_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


class SweepRefused(TransplanterError, ValueError):
    """A sweep that cannot start (bad grid, output directory of another sweep); the message
    says why and what to do."""


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
    if (hi - lo) > step * MAX_GRID_VALUES:  # before divmod: 10/1e-30 is too many to divide
        raise SweepRefused(
            f"{where}: the step {step} makes more than {MAX_GRID_VALUES} values of "
            f"{lo}..{hi}; use a coarser step"
        )
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


def parse_param_range(text: str, option: str = "--param") -> tuple[str, str, Any, Any]:
    """`KEY=LO..HI` for tuning (`--param`) or calibration (`--fit`) -> (key, kind 'float' or
    'int', lo, hi), both ends checked with the schema; SweepRefused naming the problem (and
    `option`)."""
    key, eq, spec = text.partition("=")
    key = key.strip()
    where = f"{option} {text!r}"
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
    for v in ends:  # the key's own range first: 1e30 is refused as such
        try:
            check_value(key, v)
        except ScenarioError as exc:
            raise SweepRefused(f"{option} {key}: {exc}") from None
    step = key_quantum(key) if kind == "float" else None
    if step is not None and any(v % Decimal(str(step)) for v in (lo, hi)):
        raise SweepRefused(
            f"{where}: the EEPROM stores {key} in steps of {step:g}; give LO and HI as "
            "whole multiples of it"
        )
    return key, kind, ends[0], ends[1]


@dataclass(frozen=True)
class SweepSpec:
    """What a sweep runs: a scenario (file or packaged name) with `overrides` (--set), the
    varied axes, the seeds and the seedlings per trial."""

    scenario: str
    axes: tuple[Axis, ...]
    seeds: tuple[int, ...]
    seedlings: int | None  # None: the scenario's own count (its file and --set give it)
    overrides: Mapping[str, Any] = field(default_factory=dict)
    design: str = "full"
    """'full': every combination of the axes' values; 'L9': the nine runs of the L9(3^4)
    orthogonal array over 2-4 axes of three values each (studies.orthogonal.L9)."""

    def __post_init__(self) -> None:
        keys = [a.key for a in self.axes]
        if self.design == "one" and keys:
            raise SweepRefused("--design one runs the scenario as given: drop --vary")
        if not keys and self.design != "one":
            raise SweepRefused("a sweep needs at least one --vary KEY=...")
        if self.design not in DESIGNS:
            raise SweepRefused(f"--design {self.design!r}: choose one of {', '.join(DESIGNS)}")
        if self.design == "L9" and (
            not 2 <= len(keys) <= 4 or any(len(a.values) != 3 for a in self.axes)
        ):
            given = ", ".join(f"{a.key} ({len(a.values)} values)" for a in self.axes)
            raise SweepRefused(
                "--design L9 takes 2 to 4 varied keys of three values each (its nine runs "
                f"cover 4 factors at 3 levels); got {given}"
            )
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
        """Every combination of the axes' values, the first key outermost (with the L9
        design: its nine runs, in the array's order)."""
        if self.design == "L9":
            from transplanter.studies.orthogonal import L9

            return [
                {a.key: a.values[int(row[i]) - 1] for i, a in enumerate(self.axes)} for row in L9
            ]
        return [
            dict(zip(self.keys, combo, strict=True))
            for combo in itertools.product(*(a.values for a in self.axes))
        ]

    @property
    def runs_total(self) -> int:
        if self.design == "L9":
            return 9 * len(self.seeds)
        return math.prod(len(a.values) for a in self.axes) * len(self.seeds)

    def base_overrides(self) -> dict[str, Any]:
        return with_units(self.scenario, self.overrides, self.seedlings)

    def check(self):
        """The scenario with the --set overrides and seedlings, or ScenarioError (before any
        run: a bad --set key, too many seedlings for the conveyor)."""
        return load_scenario(self.scenario, self.base_overrides())

    def tasks(self) -> list[dict[str, Any]]:
        """One task per (setting, seed), in grid order: what `run_one` takes."""
        return [
            task(self.scenario, self.overrides, setting, seed, self.seedlings)
            for setting in self.settings()
            for seed in self.seeds
        ]

    def manifest(self) -> dict[str, Any]:
        """What identifies the sweep's results (not how it is run: backend, workers)."""
        scenario = self.check()
        # the keys its kinds read: each run sets its own seed, the seedlings are a field
        digest = scenario_digest(scenario)
        return {
            "scenario": str(self.scenario),
            "scenario_name": scenario.name,
            "scenario_digest": digest,
            "overrides": dict(self.overrides),
            "vary": [{"key": a.key, "values": list(a.values)} for a in self.axes],
            "seeds": list(self.seeds),
            "seedlings": self.seedlings,
        } | ({"design": self.design} if self.design != "full" else {})


# Manifest fields that must match for a rerun to add to the results ("scenario" is the
# text given on the command line: the digest says whether it is the same scenario).
MANIFEST_IDENTITY = (
    "scenario_name",
    "scenario_digest",
    "overrides",
    "vary",
    "seeds",
    "seedlings",
    "design",  # absent for the full grid (a manifest written before designs existed)
)
DESIGNS = ("full", "L9", "one")
"""full: every combination of the varied keys' values; L9: the orthogonal array's nine runs;
one: the scenario as given over the seeds, no varied key (`transplanter compare`)."""


def task(
    scenario: str,
    overrides: Mapping[str, Any],
    setting: Mapping[str, Any],
    seed: int,
    seedlings: int,
) -> dict[str, Any]:
    """One run as `sweep_backends.run_one` takes it (plain data: it crosses processes)."""
    return {
        "scenario": scenario,
        "overrides": dict(overrides),
        "setting": dict(setting),
        "seed": seed,
        "seedlings": seedlings,
    }


def run_key(setting: Mapping[str, Any], seed: int, keys: Sequence[str]) -> str:
    """The identity of a run: its varied values (in the keys' order) and seed, as JSON."""
    return json.dumps([[k, setting[k]] for k in keys] + [["seed", seed]])


def format_value(v: Any) -> str:
    """A grid value as text: 26.0 -> '26', 26.5 -> '26.5', 'scurve' -> 'scurve'."""
    return f"{v:g}" if isinstance(v, float) else str(v)
