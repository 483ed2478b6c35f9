"""A job's run, the one interface `transplanter trial`, `render`, `view`, `export` and the
studies call for every job (the twin's own trial of the five-bar on the pot line aside:
`transplanter.twin.trial`).

A job kind (`transplanter.kinds`, `JobKind.RUN`) names the module of this package that runs
it: one module per job, whatever robot does it (`pot_line` runs every robot whose host
program the job kind names in `JobKind.runner`). The module's names below are its written
interface (:data:`MEMBERS`, checked for every registered job by a test). The command line
has one path for all of them: it refuses the options a job names in `REFUSED_OPTIONS`,
loads the scenario, asks `check`, then per seed `run` with a progress bar over `total`
units, printing `summary(result)` (`line(result)` for each of `--seeds`); `--seeds` pools
the results' `successes` / `seedlings` and prints `pool(results, pooled)`; `--record`,
`render`, `view` and `export` ask `recorder`, `filmer`, `viewer` and `export`, each of
which raises `ScenarioError` with the reason where the job has none. The studies row of a
run is `row(scenario, seed, row)`, with the columns `study(scenario)` declares.

An observer (a recorder, a filmer, a viewer) is attached by `run` and finished or aborted
by it: when `run` returns, each observer's file is written or its `error` says why not.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Mapping
from types import ModuleType
from typing import Any, Protocol, runtime_checkable

__all__ = ["MEMBERS", "JobRun", "finite", "of", "pooled_line", "problems", "read_sections"]


@runtime_checkable
class JobRun(Protocol):
    """The run of one job kind (module docstring)."""

    UNIT: str
    """One unit of the job, for the progress bar: 'seedling', 'cell', 'tomato'."""
    DEFINITIONS: Mapping[str, str]
    """What each number of its result means (`trial --explain`, the JSON)."""
    FILMED: str
    """What `render` films, as its output line names it ('the pot job'; '' for nothing
    more than 'video')."""
    REFUSED_OPTIONS: Mapping[str, str]
    """Command-line options the job cannot honour -> the reason (with the way out)."""

    def check(self, scenario: Any) -> None:
        """ScenarioError (or ValueError) for what the job cannot run with this scenario,
        before anything is built."""
        ...

    def total(self, scenario: Any) -> int | None:
        """The units a run does, for the progress bar (None: known once the run planned)."""
        ...

    def run(self, scenario: Any, seed: int | None, *, progress: Any = None,
            observers: Any = ()) -> Any:  # fmt: skip
        """One trial at `seed` (None: the scenario's); `progress(done, sim_t[, total])`;
        `observers` attached, then finished or aborted (module docstring). The result has
        `successes`, `seedlings` (its units), `recording_error` and `to_dict()`."""
        ...

    def summary(self, result: Any) -> str:
        """One run's result as `trial` prints it for a single seed."""
        ...

    def line(self, result: Any) -> str:
        """One run's result in a line, as `trial --seeds` prints each seed's."""
        ...

    def pool(self, results: list[Any], pooled: Any) -> tuple[dict[str, Any], list[str]]:
        """`trial --seeds`: the JSON keys it adds to the pooled rate `pooled`
        (`studies.stats.pooled_rate` of the results' successes over their units) and the
        lines it prints, the pooled rate's first."""
        ...

    def study(self, scenario: Any) -> Mapping[str, Any]:
        """Its studies' Job fields for this scenario (`transplanter.studies.jobs.Job`: kind,
        fields, means, sections, unit, ...; `run` aside)."""
        ...

    def row(self, scenario: Any, seed: int, row: dict[str, Any]) -> None:
        """One run filled into the studies' `row` (`transplanter.studies.jobs`)."""
        ...

    def recorder(self, scenario: Any, path: Any, rate_hz: float) -> Any:
        """The observer of `--record PATH`; ScenarioError where the job records nothing."""
        ...

    def filmer(self, scenario: Any, target: Any, size: tuple[int, int], fps: float,
               camera: str, shadows: bool, subset: str | None) -> Any:  # fmt: skip
        """The observer of `render` (`subset`: the units to film, as --cells-of gives them);
        ScenarioError, video.RenderRefused or video.GLUnavailable where it cannot film."""
        ...

    def viewer(self, scenario: Any, speed: float) -> Any:
        """The observer of `view`; ScenarioError where the job has no live view."""
        ...

    def export(self, scenario: Any, target: Any) -> Any:
        """Write the scene a trial builds to `target` (meshes beside it); ScenarioError
        where the job's scene cannot be written."""
        ...


MEMBERS = (
    "UNIT", "FILMED", "DEFINITIONS", "REFUSED_OPTIONS",
    "check", "total", "run", "summary", "line", "pool", "study", "row",
    "recorder", "filmer", "viewer", "export",
)  # fmt: skip
"""The members of :class:`JobRun`, which :func:`problems` checks."""


def problems(module: ModuleType | Any) -> list[str]:
    """What a run module lacks of :class:`JobRun` ([] when it implements it)."""
    out = []
    for name in MEMBERS:
        if not hasattr(module, name):
            out.append(f"has no {name}")
        elif name == "UNIT":
            if not (isinstance(module.UNIT, str) and module.UNIT):
                out.append("UNIT is not a name")
        elif name == "FILMED":
            if not isinstance(module.FILMED, str):
                out.append("FILMED is not a string")
        elif name.isupper():
            if not isinstance(getattr(module, name), Mapping):
                out.append(f"{name} is not a mapping")
        elif not callable(getattr(module, name)):
            out.append(f"{name} is not callable")
    return out


def of(scenario: Any) -> Any:
    """The run module of the scenario's job with its robot, or None where the twin's own
    trial runs it (`transplanter.twin.trial`)."""
    from transplanter import kinds

    job = kinds.job(scenario.workcell.kind)
    if not job.runner(scenario.robot.kind):
        return None
    return importlib.import_module(job.RUN)


def pooled_line(pooled, what: str, over: str = "runs") -> str:
    """`trial --seeds`'s pooled rate in a line: 'pooled over 3 runs: 95.0 % of <what>
    (57/60), 95 % CI ...' (`pooled`: `studies.stats.pooled_rate`'s result)."""
    lo, hi = pooled.ci95
    return (
        f"pooled over {pooled.trials} {over}: {100 * pooled.success_rate:.1f} % of {what} "
        f"({pooled.successes}/{pooled.seedlings}), 95 % CI {100 * lo:.1f}-{100 * hi:.1f} % "
        f"({pooled.method})"
    )


def read_sections(scenario: Any) -> tuple[str, ...]:
    """The sections a scenario's kinds read (`kinds.reads`), its name and kinds aside: what a
    tuning study of its job is identified by."""
    from transplanter import kinds

    reads = kinds.reads(scenario.robot.kind, scenario.effector.kind, scenario.workcell.kind)
    skip = ("scenario", "robot", "effector", "workcell", "costs")
    return tuple(sorted(s for s in reads if s not in skip))


def finite(v: float) -> float | None:
    """A row's value: None for a NaN or an infinity."""
    return v if math.isfinite(v) else None
