"""The jobs a study runs besides the five-bar's trial: each job kind's run
(`transplanter.runs`, named by `JobKind.RUN`: the delta's trays, the claws' bench, the serial
arm's tomatoes, every other robot on the pot line). `sweep_backends.run_one` asks
`job_of(scenario)`; None is the five-bar's trial, run as before.

A job's row has the sweep's columns (`RESULT_FIELDS`) with the studies' meaning, so that the
pooling, the interval, resume and tuning work unchanged:

- `successes` / `seedlings`: the job's units done / its units (the delta tray's serviced
  cells done, by its judge: culled plug in the bin, refill seated, no torn leaf / serviced
  cells; the bench's seedlings whose plug arrived seated / seedlings picked; tomatoes on the
  belt / tomatoes picked; pots into the tube / seedlings);
- `cycle_time_s` over `cycles`: the delta's time per operation over its operations; the
  bench's mean pick over its picks; a pick's start to the next's for the others;

plus the job's own columns (`Job.fields`), of which `Job.means` are averaged over a
setting's runs in settings.csv.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from transplanter.twin.results import DAMAGE_FIELDS, WARNING_SEPARATOR, trial_row

__all__ = ["POT_LINE_DAMAGE", "WARNING_SEPARATOR", "Job", "job_of", "run_job", "trial_row"]

POT_LINE_DAMAGE = DAMAGE_FIELDS  # the pot line judge's damaged seedlings (twin.results)
"""The pot line judge's failures that are a damaged seedling (its shoot bent past
`metrics.damage_bend_deg` or crushed by the gripper's bridge), whatever robot works it."""


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
    damage: tuple[str, ...] | None = None
    """The failure columns that count a damaged seedling (`transplanter compare`'s damage
    rate); None: the job does not judge damage."""
    label: str = "cycle"
    """What its `cycle_time_s` is."""
    pictures: Callable[[Any, Mapping[str, Sequence[Any]]], bool] | None = None
    """Whether a run photographs (needs an offscreen OpenGL context), given the scenario and
    the study's varied values by key; None: never."""
    pictures_why: str = ""
    """What photographs, for the refusal when no offscreen OpenGL context can be made."""
    no_pictures: str = ""
    """How to run the job without pictures (the same refusal's way out)."""


def job_of(scenario) -> Job | None:
    """The scenario's job (its run's `study` and `row`: `transplanter.runs`), or None for the
    five-bar's trial."""
    from transplanter import runs

    run = runs.of(scenario)
    if run is None:
        return None
    return Job(**run.study(scenario), run=run.row)


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
