"""What a trial measured: per-seedling records, the trial's result and its statistics."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from transplanter.machine.faults import FaultKind

__all__ = [
    "WARNING_SEPARATOR",
    "trial_row",
    "FAILURE_KINDS",
    "EventKind",
    "FaultKind",
    "Outcome",
    "SeedlingRecord",
    "TrialResult",
    "wilson_interval",
]


class Outcome(StrEnum):
    """A seedling's fate. A failure is named by the first check it failed (see judge)."""

    PENDING = "pending"  # its cycle has not been judged yet
    SUCCESS = "success"  # its pot is in the drop tube
    NOT_GRIPPED = "not_gripped"  # the pot did not rise with the jaws
    STUCK_TO_BELT = "stuck_to_belt"  # a pot bonded to the belt stayed on it as the jaws rose
    SOFT_POT = "soft_pot"  # a soaked pot gave under the jaws and did not rise with them
    SLIPPED = "slipped"  # lifted, but no longer between the jaws over the drop tube
    DROPPED_OUTSIDE = "dropped_outside"  # released over the tube, but it did not land inside
    # ... its pot stuck in the funnel above the throat, no earlier jam standing there: the jam
    # itself (SeedlingRecord.jam says where; later failures while it stands name it: after_jam)
    FUNNEL_JAM = "funnel_jam"
    # in the tube, but its stem bent past metrics.damage_bend_deg on the way: the paper
    # counts a success only "without any damage"
    DAMAGED = "damaged"
    # ... bent past it by the gripper's bridge coming down on (or sweeping over) its shoot: the
    # approach was too low for the bridge (gripper.bridge_clearance_mm, taught.z_low_mm)
    SHOOT_CRUSHED = "shoot_crushed"
    KNOCKED_OVER = "knocked_over"  # the pot was out of its cell or tilted at the approach
    # ... after the jaws had pushed its leaves (pots.canopy_contact): the canopy did it
    TIPPED_BY_LEAF = "tipped_by_leaf"
    # ... or, knocked over or not lifted, its wall leant over its foot (pots.crooked_share)
    CROOKED_POT = "crooked_pot"
    # ... or the last index left its row off its place (conveyor.index_error_sd_mm)
    ROW_OFF = "row_off"
    NO_POT = "no_pot"  # the cell the pickup points at holds no pot
    LOST_STEPS = "lost_steps"  # a motor slipped during this cycle (the strike itself)
    POSITION_LOST = "position_lost"  # an earlier lost-step event left the arm off position
    MOVE_REJECTED = "move_rejected"  # the SGF refused one of its lines
    NOT_RUN = "not_run"  # never attempted: the firmware faulted or the physics went invalid


class EventKind(StrEnum):
    """Kinds of the trial's event log (recordings show them on the timeline)."""

    LOST_STEPS = "lost_steps"  # a motor slipped (with what the machine was touching)
    SENT = "sent"  # a G-code line went on the bus
    ACK = "ack"  # its reply came back
    GRASP = "grasp"  # the gripper starts closing on a pot
    RELEASE = "release"  # the gripper opens over the drop tube
    SUCCESS = "success"  # a seedling's pot is in the tube
    FAILURE = "failure"  # a seedling failed, or a line was refused
    STALL = "stall"  # a driver reported a stall: the SGF stopped, the PGF re-homes


DAMAGE_KINDS: tuple[str, ...] = (str(Outcome.DAMAGED), str(Outcome.SHOOT_CRUSHED))
"""The pot line judge's failure kinds that are a damaged seedling (its shoot bent past
`metrics.damage_bend_deg`, or crushed by the gripper), whatever robot works the line."""
DAMAGE_FIELDS: tuple[str, ...] = tuple(f"fail_{k}" for k in DAMAGE_KINDS)
"""The same as a study row's columns (`compare`'s damage)."""

FAILURE_KINDS: tuple[Outcome, ...] = tuple(
    o for o in Outcome if o not in (Outcome.PENDING, Outcome.SUCCESS)
)


@dataclass
class SeedlingRecord:
    """What happened to one seedling."""

    index: int
    pickup: int
    pot: int | None = None
    outcome: Outcome = Outcome.PENDING
    t_start_s: float | None = None
    t_release_s: float | None = None
    cycle_time_s: float | None = None
    peak_grip_force_n: float = 0.0  # largest clamping force per jaw while holding
    leaves_hit: bool = False  # the gripper touched a neighbour's leaves
    microsteps_lost: int = 0  # microsteps the motors slipped during this cycle (all motors)
    position_error_microsteps: int = 0  # lost since the last homing, at the cycle's start
    lost_step_event: int | None = None  # index in lost_step_events of the strike behind it
    max_lag_full_steps: float = 0.0
    # the shoot's largest bend from its pot's axis, approach to landing
    peak_stem_bend_deg: float = 0.0
    # what of the gripper pushed the shoot over ("bridge"; "" untouched), and the largest
    # bend it forced (deg; past metrics.damage_bend_deg: shoot_crushed)
    shoot_touched_by: str = ""
    shoot_pressed_deg: float = 0.0
    knocked_before: bool = False
    canopy_pushed: bool = False  # before its approach a jaw had pushed its pot's leaves
    soft: bool = False  # its pot is soaked (pots.soft_share): the wall gives under the jaws
    crook_deg: float = 0.0  # how far its pot's wall leans over its foot (pots.crooked_share)
    row_offset_mm: float = 0.0  # the belt's offset from its row grid at the approach
    row_off: bool = False  # ... more than half metrics.knocked_offset_mm: the row is off
    lifted: bool | None = None
    in_gripper_at_drop: bool | None = None
    stuck_to_belt: bool = False  # bonded, and still on the belt after the lift
    rejected_line: str | None = None
    stall_recoveries: int = 0  # stalls in this cycle the PGF re-homed and went on from
    max_belt_displacement_mm: float = 0.0  # largest carriage offset from its held position
    bond_force_n: float = 0.0  # strength of its pot's bond to the belt (pots.bond_*; 0: none)
    # a funnel_jam's pot as it was found stuck: t_s, below_top_mm (its centre under the
    # funnel's top), off_axis_mm, tilt_deg (its axis from upright; None: not a body)
    jam: dict[str, Any] | None = None
    # a failure judged while a jam stood in the funnel: the jam's seedling (its index)
    after_jam: int | None = None


DEFINITIONS = {
    "success": "the pot fell into the drop tube below the funnel's throat with its shoot bent no "
    "further than metrics.damage_bend_deg on the way (the pot line's judge, twin.judge)",
    "failures": "each failed seedling named by the first check it failed (docs/results.md): "
    "knocked_over, not_gripped, slipped, dropped_outside, damaged, ...",
    "no_pot": "the cell held no pot (the host's sensor read none and it went on)",
    "cycle_time_s": "mean time from a pot's approach to the end of its release (the row's "
    "index not included), whatever robot works the line",
    "pick_pitch_s": "the job's time per seedling, one pick's start to the next: from the first "
    "pick's start to the last start at the same pickup, over the picks between (whole rows: "
    "each pick's cycle, the rows' indexes and any recovery; a run within one row: its picks "
    "alone, pick_pitch_whole_rows false); the homing before the first pick "
    "(first_pick_start_s) left out",
    "plants_per_hour": "3600 / pick_pitch_s: the pot line's one throughput, the same in the "
    "summary, the JSON, sweep and compare for every robot (None with fewer than two picks)",
    "placed_per_hour": "3600 x successes / sim_time_s: the seedlings placed in the tube an hour "
    "of the whole run (the homing, the indexes, the failed picks, jams, cascades and recoveries "
    "in it): a long run's shift in one number, beside plants_per_hour (the pace of the picks)",
}
"""What the pot line's numbers mean (the JSON's `definitions`, `trial --explain`)."""


def wilson_interval(successes: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """95 % Wilson score interval of a binomial proportion."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return (max(0.0, centre - half), min(1.0, centre + half))


@dataclass
class TrialResult:
    """A whole trial: its seedlings, the simulated and wall time, and whether it is valid."""

    scenario: str
    seed: int
    per_seedling: list[SeedlingRecord]
    sim_time_s: float
    wall_time_s: float
    valid: bool = True
    invalid_reason: str | None = None
    fault: str | None = None
    fault_kind: FaultKind | None = None  # why the firmware stopped (machine.faults.FaultKind)
    interrupted: bool = False  # stopped by the user: seedlings not yet judged are not_run
    recording_error: str | None = None  # the recording failed; the results stand
    lost_step_events: list[dict[str, Any]] = field(default_factory=list)
    overrides: dict[str, Any] = field(default_factory=dict)  # scenario keys set on the file
    # what the machine did other than it was told, without failing (the SGF's moves that
    # cruised slower than their F: a motor's top step rate, the IK's compute time)
    warnings: list[str] = field(default_factory=list)
    belt_realignments: list[dict[str, float]] = field(default_factory=list)  # at each index
    motors: dict[str, Any] | None = None  # the drives' peak torque and work (twin.motors)

    @property
    def failures_clustered(self) -> bool:
        """Whether one event failed several seedlings (a lost-step cascade, failures while a
        funnel jam stood): the picks are not independent, so an interval over this trial's
        picks would be too narrow."""
        return any(
            r.outcome == Outcome.POSITION_LOST or r.after_jam is not None for r in self.per_seedling
        )

    @property
    def funnel_jams(self) -> list[dict[str, Any]]:
        """Each funnel jam: its seedling and pot, when it was released, where it stuck, the
        later failures judged while it stood (by kind), and the first lost-step event at or
        after its release (`next_strike`: its index in lost_step_events, None without one;
        `next_strike_after_s`: how long after the release) with the seedlings it cost: a
        strike carries a cascade on after the jam's pot has left the funnel."""
        out = []
        for r in self.per_seedling:
            if r.outcome != Outcome.FUNNEL_JAM or r.jam is None:
                continue
            later: dict[str, int] = {}
            for o in self.per_seedling:
                if o.after_jam == r.index:
                    later[str(o.outcome)] = later.get(str(o.outcome), 0) + 1
            t0 = r.t_release_s if r.t_release_s is not None else r.jam["t_s"]
            strike = next((i for i, e in enumerate(self.lost_step_events) if e["t_s"] >= t0), None)
            cost = None
            if strike is not None:
                cost = sum(o.lost_step_event == strike and o.outcome != Outcome.SUCCESS
                           for o in self.per_seedling)  # fmt: skip
            out.append({"seedling": r.index, "pot": r.pot, "t_release_s": r.t_release_s,
                        **r.jam, "later_failures": sum(later.values()),
                        "later_failures_by_kind": dict(sorted(later.items())),
                        "next_strike": strike,
                        "next_strike_after_s": None if strike is None else
                        round(self.lost_step_events[strike]["t_s"] - t0, 6),
                        "next_strike_cost": cost})  # fmt: skip
        return out

    @property
    def judged(self) -> int:
        """Seedlings with a verdict (success or a failure other than not_run)."""
        return sum(r.outcome not in (Outcome.NOT_RUN, Outcome.PENDING) for r in self.per_seedling)

    @property
    def seedlings(self) -> int:
        return len(self.per_seedling)

    @property
    def attempted(self) -> int:
        """Seedlings whose cycle ran (not stopped by a fault or invalid physics first)."""
        return sum(r.outcome != Outcome.NOT_RUN for r in self.per_seedling)

    @property
    def successes(self) -> int:
        return sum(r.outcome == Outcome.SUCCESS for r in self.per_seedling)

    @property
    def success_rate(self) -> float:
        return self.successes / self.seedlings if self.seedlings else 0.0

    @property
    def cycle_times(self) -> np.ndarray:
        return np.array([r.cycle_time_s for r in self.per_seedling if r.cycle_time_s is not None])

    def _pitch(self) -> tuple[float, int, bool] | None:
        """(pitch s, picks it spans, whether over whole rows) or None (`pick_pitch_s`)."""
        started = sorted((r for r in self.per_seedling if r.t_start_s is not None),
                         key=lambda r: r.t_start_s)  # fmt: skip
        if len(started) < 2:
            return None
        # over whole rows: to the last start at the first pick's pickup, so that every row's
        # picks (near and far pickups) and its index count once, whatever the run's size
        m = max(i for i, r in enumerate(started) if r.pickup == started[0].pickup)
        whole = m > 0
        if not whole:
            m = len(started) - 1
        span = started[m].t_start_s - started[0].t_start_s
        return (span / m, m, whole) if span > 0 else None

    @property
    def pick_pitch_s(self) -> float | None:
        """The job's time per seedling, start to start: from the first pick's start to the
        last start at the same pickup, over the picks between (whole rows: each pick's cycle,
        the rows' indexes and any recovery; a run within one row: its picks alone, no index);
        the homing before the first pick is left out (a start-up cost). None with fewer than
        two picks started."""
        pitch = self._pitch()
        return None if pitch is None else pitch[0]

    @property
    def plants_per_hour(self) -> float | None:
        """Seedlings an hour at the pick pitch (`pick_pitch_s`): the one throughput of the
        pot line, whatever robot works it, in the summary, the JSON, `compare` and `sweep`."""
        pitch = self.pick_pitch_s
        return None if pitch is None else 3600.0 / pitch

    @property
    def stem_bends_in_tube(self) -> list[float]:
        """Each shoot's largest bend (deg), for the pots that reached the tube (success or
        damaged; a pot left behind or dropped may lie on its side, its shoot drooping)."""
        landed = (Outcome.SUCCESS, Outcome.DAMAGED)
        return [r.peak_stem_bend_deg for r in self.per_seedling if r.outcome in landed]

    @property
    def max_stem_bend_deg(self) -> float:
        """The largest shoot bend among the pots that reached the tube."""
        return max(self.stem_bends_in_tube, default=0.0)

    def failures(self) -> dict[str, int]:
        return {str(k): sum(r.outcome == k for r in self.per_seedling) for k in FAILURE_KINDS}

    def to_dict(self) -> dict[str, Any]:
        """The results as plain JSON types (the same trial gives the same dict, bar the
        wall time and the real-time factor)."""
        cycles = self.cycle_times
        pitch = self._pitch()
        starts = [r.t_start_s for r in self.per_seedling if r.t_start_s is not None]
        ci95 = (
            None
            if self.failures_clustered
            else list(wilson_interval(self.successes, self.seedlings))
        )
        per_seedling = []
        for r in self.per_seedling:
            row = asdict(r)
            row["outcome"] = str(r.outcome)
            per_seedling.append(row)
        return {
            "scenario": self.scenario,
            "seed": self.seed,
            "overrides": self.overrides,
            "valid": self.valid,
            "invalid_reason": self.invalid_reason,
            "fault": self.fault,
            "fault_kind": None if self.fault_kind is None else str(self.fault_kind),
            "interrupted": self.interrupted,
            "seedlings": self.seedlings,
            "successes": self.successes,
            "success_rate": self.success_rate,
            "success_rate_ci95": ci95,  # None when the failures cluster (see pooled trials)
            "failures_clustered": self.failures_clustered,
            "lost_step_events": self.lost_step_events,
            "max_belt_displacement_mm": max(
                (r.max_belt_displacement_mm for r in self.per_seedling), default=0.0
            ),
            "belt_realignments": self.belt_realignments,
            "max_stem_bend_deg": self.max_stem_bend_deg,
            "warnings": list(self.warnings),
            "failures": self.failures(),
            "funnel_jams": self.funnel_jams,
            "cycle_time_s": float(cycles.mean()) if cycles.size else None,
            "cycle_time_sd_s": float(cycles.std(ddof=1)) if cycles.size > 1 else None,
            # seedlings an hour at the pick pitch, first pick's start to last (cycles, indexes
            # and recoveries; not the homing before): what `transplanter compare` ranks by
            "plants_per_hour": None if pitch is None else 3600.0 / pitch[0],
            "pick_pitch_s": None if pitch is None else pitch[0],
            # the picks the pitch spans and whether over whole rows (indexes included)
            "pick_pitch_picks": None if pitch is None else pitch[1],
            "pick_pitch_whole_rows": None if pitch is None else pitch[2],
            "first_pick_start_s": min(starts) if starts else None,
            # the run as a shift: seedlings placed an hour of its whole simulated time
            "placed_per_hour": (
                3600.0 * self.successes / self.sim_time_s if self.sim_time_s > 0 else None
            ),
            "sim_time_s": self.sim_time_s,
            "wall_time_s": self.wall_time_s,
            "real_time_factor": self.sim_time_s / self.wall_time_s if self.wall_time_s else None,
            "motors": self.motors,
            "per_seedling": per_seedling,
            "definitions": DEFINITIONS,
        }


WARNING_SEPARATOR = " | "
"""The trial's warnings in one cell of a row (none: an empty string)."""


def trial_row(result, row: dict[str, Any]) -> dict[str, Any]:
    """A pot-line trial's result (`twin.results.TrialResult`, whatever robot worked the line)
    in `row`: the counts, times, the judge's failure kinds and damage, the motors; the
    error of an invalid or faulted trial."""
    from transplanter.twin.motors import motor_columns

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
