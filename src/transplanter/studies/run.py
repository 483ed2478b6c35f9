"""One trial of any scenario from Python, every robot on every job, as the studies count it.

`run_scenario("delta_refill", seed=2, units=3)` runs what `transplanter trial delta_refill
--seed 2 --seedlings 3` runs and returns the row `sweep` and `compare` pool: the same
columns for every machine (docs/results.md), so a script reads every machine alike:

- `successes` / `seedlings` (the job's units: pots, serviced cells, tomatoes, picks) and
  `success_rate`;
- `cycle_time_s` over `cycles` (the job's cycle: a pot's pick to release, a tray's time per
  operation, a tomato's pick to the next);
- `plants_per_hour`, the failures by kind (`fail_<kind>`), the drives' peak torque and
  energy, `sim_time_s` (None for the claws' bench: its result carries no simulated time),
  `wall_time_s`;
- the job's own columns (the delta's `trays_per_hour`, `substrate_retention`, ...).

Headless, with MUJOCO_GL unset and MuJoCo not yet imported, it chooses the machine's
offscreen backend as the command line does (EGL, else OSMesa), so that a job that
photographs its trays runs on a server.

A scenario or a setting it refuses raises `ScenarioError` with the reason; a trial whose
physics or controller raised raises `TrialFailed` with the row (its `error`) attached.
`run_job` returns each job's own result instead, with its per-unit records, as `transplanter
trial --json` writes it (its job's run, `transplanter.runs`, or the twin's own trial of the
five-bar on the pot line).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from transplanter.errors import TransplanterError

__all__ = ["TrialFailed", "run_job", "run_scenario"]


class TrialFailed(TransplanterError, RuntimeError):
    """The trial raised (its physics or its controller): `row` holds what was measured and
    the error."""

    def __init__(self, message: str, row: dict[str, Any]) -> None:
        super().__init__(message)
        self.row = row


REFUSED = "setting refused: "


def run_job(
    scenario: Any,
    seed: int | None = None,
    units: int | None = None,
    overrides: Mapping[str, Any] | None = None,
    *,
    progress: Any = None,
    observers: Any = (),
) -> Any:
    """One trial of `scenario` (a packaged name or a file; or a loaded `Scenario`, with no
    `units` or `overrides` then) by its job, whatever its robot: the job's own result, with
    its per-unit records, as `transplanter trial --json` writes it (`to_dict()`): the pot
    line's per seedling (every robot on it), the trays' per cell, the tomatoes' per pick.
    `seed`: None for the scenario's; `units`: `--seedlings`; `overrides`: 'section.key' ->
    value in file units, as `--set`. ScenarioError with the reason for what the job refuses,
    before any step (the five-bar's taught points and moves are checked as `trial` checks
    them)."""
    from transplanter.scenario.schema import Scenario, load_scenario, with_units

    given = dict(overrides or {})
    if seed is not None:
        given["scenario.seed"] = int(seed)
    if isinstance(scenario, Scenario):
        if units is not None or overrides:
            raise ValueError("give units and overrides with a scenario's name or file")
        sc = scenario
        if seed is not None and seed != scenario.seed:
            if scenario.path is None:
                raise ValueError("a scenario built without a file: give its seed in it")
            sc = load_scenario(scenario.path, dict(scenario.overrides) | given)
    else:
        sc = load_scenario(scenario, with_units(scenario, given, units))
    from transplanter import runs

    run = runs.of(sc)
    if run is None:  # the five-bar's PGF on the pot line: the twin's own trial
        from transplanter.scenario.assemble import assemble
        from transplanter.twin.trial import run_trial

        return run_trial(assemble(sc), progress=progress, observers=observers)
    run.check(sc)
    return run.run(sc, sc.seed, progress=progress, observers=observers)


def run_scenario(
    scenario: str | os.PathLike,
    seed: int | None = None,
    units: int | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """One trial of `scenario` (a file or a packaged name) at `seed` (default the
    scenario's), doing `units` of its job (default the scenario's; `--seedlings`), with the
    'section.key' `overrides` (file units, as `--set`): the study row (module docstring)."""
    import sys

    if "mujoco" not in sys.modules:  # headless: the offscreen backend this machine has, as
        from transplanter.viewing.video import prepare_gl  # the command line chooses it

        prepare_gl()
    from transplanter.scenario.schema import ScenarioError, load_scenario, with_units
    from transplanter.studies.backends import run_one

    given = dict(overrides or {})
    if seed is None:  # the scenario's own seed, from the file with the overrides
        seed = load_scenario(scenario, with_units(scenario, given, units)).seed
    task = {"scenario": os.fspath(scenario), "setting": {}, "seed": int(seed),
            "overrides": given, "seedlings": units}  # fmt: skip
    row = run_one(task)
    error = row.get("error")
    if error is not None and error.startswith(REFUSED):
        raise ScenarioError(error.removeprefix(REFUSED))
    if error is not None:
        raise TrialFailed(f"{os.fspath(scenario)} seed {seed}: {error}", row)
    return row
