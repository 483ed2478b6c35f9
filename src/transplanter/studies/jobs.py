"""The jobs a study runs besides the five-bar's trial, by the scenario's workcell kind (as
`transplanter trial` dispatches): the delta's cull-and-refill tray (`plug_trays`,
transplanter.twin.delta_refill) and the claws' bench (`plug_bench`,
transplanter.twin.plug_bench_trial). `sweep_backends.run_one` asks `job_of(scenario)`; None is
the five-bar's trial, run as before.

A job's row has the sweep's columns (`RESULT_FIELDS`) with the studies' meaning, so that the
pooling, the interval, resume and tuning work unchanged:

- `successes` / `seedlings`: the delta tray's serviced cells done (its judge: culled plug in the
  bin, refill seated, no torn leaf) / serviced cells; the bench's seedlings whose plug arrived
  seated in the target cell / seedlings picked;
- `cycle_time_s` over `cycles`: the delta's time per operation over its operations; the
  bench's mean pick over its picks;

plus the job's own columns (`Job.fields`), of which `Job.means` are averaged over a
setting's runs in settings.csv.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = ["JOBS", "Job", "job_of", "run_job"]

PLUG_SECTIONS = ("plugs", "plug_claws", "plug_bench", "vision")
"""The scenario sections only these jobs read."""

DELTA_FAILURES = (
    "cull_dropped",
    "cull_left",
    "refill_dropped",
    "refill_not_seated",
    "refill_no_supply",
    "leaf_damage",
    "neighbour_leaf_damage",
    "drive_alarm",
    "controller_error",
)


@dataclass(frozen=True)
class Job:
    """A job kind: its own row columns, those averaged per setting, the scenario sections it
    reads (a tuning study's identity) and `run(scenario, seed, row)` filling a row."""

    kind: str
    fields: tuple[str, ...]
    means: tuple[str, ...]
    sections: tuple[str, ...]
    run: Callable[[Any, int, dict[str, Any]], None]
    unit: str = "seedlings"
    """What a row's `seedlings` counts."""
    more: str = "--seedlings x seeds"
    """How a user gives a point more of them."""


def _delta(scenario, seed: int, row: dict[str, Any]) -> None:
    from transplanter.twin.delta_refill import run_delta_refill

    r = run_delta_refill(scenario, seed)
    spans = [c.end_s - c.start_s for c in r.cells if math.isfinite(c.end_s - c.start_s)]
    sd = float(_sd(spans)) if len(spans) > 1 else None
    row.update(
        successes=r.successes,
        seedlings=r.seedlings,
        success_rate=r.successes / r.seedlings if r.seedlings else None,
        cycle_time_s=r.time_per_operation_s if r.operations else None,
        cycle_time_sd_s=sd,
        cycles=r.operations,
        valid=r.valid,
        fault=r.fault,
        fault_kind=None
        if r.fault is None
        else next((k for k in ("drive_alarm", "controller_error") if k in r.failures), None),
        sim_time_s=r.sim_time_s,
        wall_time_s=r.wall_time_s,
        warnings="",
        substrate_retention=r.substrate_retention,
        leaf_damage_rate=r.leaf_damage_rate,
        tray_leaf_damage_rate=r.tray_leaf_damage_rate,
        plants_per_hour=_finite(r.plants_per_hour),
        trays_per_hour=_finite(r.trays_per_hour),
        dropped=r.dropped,
    )
    for kind in DELTA_FAILURES:
        row[f"fail_{kind}"] = r.failures.get(kind, 0)
    if r.seedlings == 0:
        row.update(successes=None, seedlings=None, error="no cell to service on this tray")
    elif not r.valid:
        row["error"] = "trial not valid: MuJoCo warned or the job ran out of simulated time"
    elif r.fault:
        row["error"] = f"fault: {r.fault}"


def _bench(scenario, seed: int, row: dict[str, Any]) -> None:
    from transplanter.twin.plug_bench_trial import run_bench_trial

    r = run_bench_trial(scenario, seed)
    row.update(
        successes=r.successes,
        seedlings=r.seedlings,
        success_rate=r.success_rate,
        cycle_time_s=r.cycle_time_s,
        cycle_time_sd_s=r.cycle_time_sd_s,
        cycles=r.seedlings,
        valid=True,
        wall_time_s=r.wall_time_s,
        warnings="",
        substrate_retention=r.substrate_retention,
        leaf_damage_rate=r.leaf_damage_rate,
        dropped=r.dropped,
        moisture_pct_drawn=r.moisture_pct,
    )


def _sd(values) -> float:
    m = sum(values) / len(values)
    return math.sqrt(sum((v - m) ** 2 for v in values) / (len(values) - 1))


def _finite(v: float) -> float | None:
    return v if math.isfinite(v) else None


JOBS: dict[str, Job] = {
    "plug_trays": Job(
        "plug_trays",
        fields=(
            "substrate_retention",
            "leaf_damage_rate",
            "tray_leaf_damage_rate",
            "plants_per_hour",
            "trays_per_hour",
            "dropped",
            *(f"fail_{k}" for k in DELTA_FAILURES),
        ),
        means=(
            "substrate_retention",
            "leaf_damage_rate",
            "tray_leaf_damage_rate",
            "plants_per_hour",
            "trays_per_hour",
        ),
        sections=("delta", "delta_refill", "plugs", "plug_claws", "bus", "vision"),
        run=_delta,
        unit="serviced cells",
        more="delta_refill.max_cells (0: every cell of a tray) x seeds",
    ),
    "plug_bench": Job(
        "plug_bench",
        fields=(
            "substrate_retention",
            "leaf_damage_rate",
            "dropped",
            "moisture_pct_drawn",
        ),
        means=("substrate_retention", "leaf_damage_rate", "moisture_pct_drawn"),
        sections=("plugs", "plug_claws", "plug_bench"),
        run=_bench,
    ),
}
"""The jobs by workcell kind; any other kind is the five-bar's trial."""


def job_of(scenario) -> Job | None:
    """The scenario's job, or None for the five-bar's trial."""
    return JOBS.get(scenario.workcell.kind)


def run_job(job: Job, scenario, seed: int, row: dict[str, Any], t0: float) -> dict[str, Any]:
    """`row` (the setting, the seed, empty results) filled by one run of `job`; a value the
    job's configs refuse (ValueError) is a refused setting, anything else that raises is the
    row's error: never an exception."""
    row.update({f: None for f in job.fields if f not in row})
    try:
        job.run(scenario, seed, row)
    except ValueError as exc:
        row["error"] = f"setting refused: {exc}"
    except Exception as exc:  # the physics or the controller raised: a row, not a crash
        row["error"] = f"{type(exc).__name__}: {exc}"
    if row.get("wall_time_s") is None or row.get("error"):
        row["wall_time_s"] = time.perf_counter() - t0
    return row
