"""The jobs a study runs besides the five-bar's trial, by the scenario's workcell kind (and
robot, where one workcell serves several: as `transplanter trial` dispatches): the delta's
cull-and-refill tray (`plug_trays`, transplanter.twin.delta_refill), the claws' bench
(`plug_bench`, transplanter.twin.plug_bench_trial), the serial arm's tomatoes to the belt
(`pool_to_belt`, transplanter.twin.serial_arm's pick and place), the serial arm on the
five-bar's pot line (`serial4` in `conveyor_tube`, transplanter.twin.serial_pots) and the
delta on it (`delta` in `conveyor_tube`, transplanter.twin.delta_pots).
`sweep_backends.run_one` asks `job_of(scenario)`; None is the five-bar's trial, run as before.

A job's row has the sweep's columns (`RESULT_FIELDS`) with the studies' meaning, so that the
pooling, the interval, resume and tuning work unchanged:

- `successes` / `seedlings`: the delta tray's serviced cells done (its judge: culled plug in the
  bin, refill seated, no torn leaf) / serviced cells; the bench's seedlings whose plug arrived
  seated in the target cell / seedlings picked;
- `cycle_time_s` over `cycles`: the delta's time per operation over its operations; the
  bench's mean pick over its picks;
- the serial arm: tomatoes on the belt / tomatoes picked; pots into the tube / seedlings; its
  mean time from one pick's start to the next's; the delta on the pot line likewise;

plus the job's own columns (`Job.fields`), of which `Job.means` are averaged over a
setting's runs in settings.csv.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from transplanter.twin.motors import motor_columns

__all__ = ["JOBS", "Job", "job_of", "run_job"]

PLUG_SECTIONS = ("plugs", "plug_claws", "plug_bench", "vision")
"""The scenario sections only the delta's jobs read."""
SERIAL_ONLY_SECTIONS = ("fuzzy_gripper", "pool_to_belt", "serial_arm", "serial_pots")
"""The scenario sections only the serial arm's jobs read (added after the five-bar's sweeps
had their digests: left out of them, as the plug sections are)."""

POT_FIELDS = ("peak_squeeze_n",)
"""The pot jobs' own column beside the five-bar's (the serial arm's and the delta's on the
pot line, judged alike: `_pot_row`)."""

DELTA_FAILURES = (
    "cull_dropped",
    "cull_left",
    "cull_jammed",
    "refill_dropped",
    "refill_jammed",
    "refill_not_seated",
    "refill_no_supply",
    "leaf_damage",
    "neighbour_leaf_damage",
    "drive_alarm",
    "controller_error",
)


POT_LINE_DAMAGE = ("fail_damaged", "fail_shoot_crushed")
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


def _delta(scenario, seed: int, row: dict[str, Any]) -> None:
    from transplanter.twin.delta_refill import FAULT_KINDS, run_delta_refill

    r = run_delta_refill(scenario, seed)
    # each operation from the end of the one before (the first from the claws' arrival):
    # the spans whose mean is the time per operation
    ends = [c.end_s for c in r.cells if math.isfinite(c.end_s)]
    starts = [ends[-1] - r.work_time_s, *ends[:-1]] if ends else []
    spans = [b - a for a, b in zip(starts, ends, strict=True)]
    sd = float(_sd(spans)) if len(spans) > 1 and math.isfinite(r.work_time_s) else None
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
        else next(
            (k for k in (*(k for k, _ in FAULT_KINDS), "controller_error") if k in r.failures),
            None,
        ),
        sim_time_s=r.sim_time_s,
        wall_time_s=r.wall_time_s,
        warnings="",
        substrate_retention=r.substrate_retention,
        leaf_damage_rate=r.leaf_damage_rate,
        tray_leaf_damage_rate=r.tray_leaf_damage_rate,
        plants_per_hour=_finite(r.plants_per_hour),
        trays_per_hour=_finite(r.trays_per_hour),
        dropped=r.dropped,
        **motor_columns(r.motors),
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


SERIAL_SECTIONS = ("serial4", "fuzzy_gripper", "serial_arm", "bus", "physics")
"""The sections every serial-arm job reads."""


def _serial_pick(scenario, seed: int, row: dict[str, Any]) -> None:
    from transplanter.machine.servo_drives import frame_steps
    from transplanter.twin.serial_arm import run_pick_place

    frame_steps(scenario.physics.timestep_s)  # ValueError: a refused setting
    t0 = time.perf_counter()
    records, totals, error, valid = run_pick_place(scenario, seed)
    picked = totals["picked"]
    cycle = totals["cycle_time_s"]
    row.update(
        successes=totals["successes"] if picked else None,
        seedlings=picked or None,
        success_rate=totals["success_rate"] if picked else None,
        cycle_time_s=_finite(cycle),
        cycle_time_sd_s=None,
        cycles=max(picked - 1, 0),
        valid=valid,
        fault=error,
        sim_time_s=max((r.end_s or 0.0 for r in records), default=0.0),
        wall_time_s=time.perf_counter() - t0,
        warnings="",
        plants_per_hour=_finite(totals["tomatoes_per_hour"]),
        peak_squeeze_n=totals["peak_squeeze_n"],
        **motor_columns(totals.get("motors")),
        **{f"fail_{k}": totals["outcomes"].get(k, 0) for k in ("bruised", "dropped", "missed")},
    )
    if not picked:
        row["error"] = "no tomato picked"
    elif not valid:
        row["error"] = "trial not valid: MuJoCo warned"
    elif error:
        row["error"] = f"fault: {error}"


def _serial_pots(scenario, seed: int, row: dict[str, Any]) -> None:
    from transplanter.machine.servo_drives import frame_steps
    from transplanter.twin.serial_pots import run_serial_pots

    frame_steps(scenario.physics.timestep_s)
    _pot_row(run_serial_pots(scenario, seed), row)


def _delta_pots(scenario, seed: int, row: dict[str, Any]) -> None:
    from transplanter.twin.delta_pots import run_delta_pots

    _pot_row(run_delta_pots(scenario, seed), row)


WARNING_SEPARATOR = " | "
"""The trial's warnings in one cell of a row (none: an empty string)."""


def trial_row(result, row: dict[str, Any]) -> dict[str, Any]:
    """A pot-line trial's result (`twin.results.TrialResult`, whatever robot worked the line)
    in `row`: the counts, times, the judge's failure kinds and damage, the motors; the
    error of an invalid or faulted trial."""
    d = result.to_dict()
    row.update(
        successes=d["successes"],
        seedlings=d["seedlings"],
        success_rate=d["success_rate"],
        cycle_time_s=d["cycle_time_s"],
        cycle_time_sd_s=d["cycle_time_sd_s"],
        cycles=int(result.cycle_times.size),
        plants_per_hour=d["plants_per_hour"],
        lost_step_events=len(d["lost_step_events"]),
        max_stem_bend_deg=d["max_stem_bend_deg"],
        valid=d["valid"],
        fault=d["fault"],
        fault_kind=d["fault_kind"],  # why the firmware stopped, by kind (FaultKind)
        sim_time_s=d["sim_time_s"],
        wall_time_s=d["wall_time_s"],
        # what the trial summary warns of (speeds the drives could not reach, ...), one cell
        warnings=WARNING_SEPARATOR.join(d["warnings"]),
        **motor_columns(d["motors"]),
    )
    for kind, count in d["failures"].items():
        row[f"fail_{kind}"] = count
    if not d["valid"]:
        row["error"] = f"trial not valid: {d['invalid_reason']}"
    elif d["fault"]:
        row["error"] = f"firmware fault: {d['fault']}"
    return row


def _pot_row(r, row: dict[str, Any]) -> None:
    """A pot job's result (any robot's on the pot line, judged by the pot line's judge) as
    the five-bar's trial row, with the gripper's peak squeeze."""
    trial_row(r, row)
    row["peak_squeeze_n"] = round(r.peak_squeeze_n, 4)


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
        damage=("fail_leaf_damage",),
        label="time per operation",
        pictures=lambda sc, varied: (
            "pipeline" in (sc.delta_refill.vision, *varied.get("delta_refill.vision", ()))
        ),
        pictures_why='delta_refill.vision = "pipeline" photographs the trays in every run',
        no_pictures="or grade from the drawn truth: --set delta_refill.vision=truth",
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
    "pool_to_belt": Job(
        "pool_to_belt",
        fields=(
            "peak_squeeze_n",
            "fail_bruised",
            "fail_dropped",
            "fail_missed",
        ),  # fmt: skip
        means=("plants_per_hour", "peak_squeeze_n"),
        sections=(*SERIAL_SECTIONS, "pool_to_belt"),
        run=_serial_pick,
        unit="tomatoes",
        more="pool_to_belt.count x seeds",
        damage=("fail_bruised",),
    ),
    "serial4:conveyor_tube": Job(
        "serial4:conveyor_tube",
        fields=POT_FIELDS,
        means=("plants_per_hour", "peak_squeeze_n"),
        sections=(*SERIAL_SECTIONS, "serial_pots", "conveyor", "pots", "drop_tube", "metrics"),
        run=_serial_pots,
        damage=POT_LINE_DAMAGE,
    ),
    "delta:conveyor_tube": Job(
        "delta:conveyor_tube",
        fields=POT_FIELDS,
        means=("plants_per_hour", "peak_squeeze_n"),
        sections=(
            "delta",
            "delta_pots",
            "motion",
            "fuzzy_gripper",
            "serial4",  # its gripper_servo: the gripper's servo class
            "serial_arm",  # its sensor_resolution_mm: the cells' HC-SR04s
            "bus",
            "physics",
            "conveyor",
            "pots",
            "drop_tube",
            "metrics",
        ),
        run=_delta_pots,
        damage=POT_LINE_DAMAGE,
    ),
}
"""The jobs by workcell kind, or by "robot:workcell" where the workcell's own job is another
robot's; any other is the five-bar's trial."""


def job_of(scenario) -> Job | None:
    """The scenario's job, or None for the five-bar's trial."""
    both = f"{scenario.robot.kind}:{scenario.workcell.kind}"
    return JOBS.get(both, JOBS.get(scenario.workcell.kind))


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
