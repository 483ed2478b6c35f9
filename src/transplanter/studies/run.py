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
physics or controller raised raises `TrialFailed` with the row (its `error`) attached. Each
job's own result, with its per-unit records, comes from its runner (`transplanter.kinds`:
`JobKind.runner`), as `transplanter trial --json` writes it.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from transplanter.errors import TransplanterError

__all__ = ["TrialFailed", "run_scenario"]


class TrialFailed(TransplanterError, RuntimeError):
    """The trial raised (its physics or its controller): `row` holds what was measured and
    the error."""

    def __init__(self, message: str, row: dict[str, Any]) -> None:
        super().__init__(message)
        self.row = row


REFUSED = "setting refused: "


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
