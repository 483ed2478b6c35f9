"""Headless pick-and-drop trials: per-seedling outcomes measured from the physics.

The trial watches the PGF's lines as their replies arrive and samples the physics at the
moments that decide a seedling's fate: the approach (is the pot still standing in its
cell?), the lift (did the pot come up with the jaws?), the arrival over the drop tube (is it
still between the jaws?) and the next cycle (is it in the tube?). Nothing is assumed: a pot
that is not in the tube is a failure, classified by the first check it failed.
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from transplanter.scenario import Scenario, load_scenario
from transplanter.sim import SCALAR_NAMES, LineEvent, SimulationInvalid, Twin

__all__ = ["FAILURE_KINDS", "SeedlingRecord", "TrialResult", "run_trial", "wilson_interval"]

FAILURE_KINDS = (
    "not_gripped",
    "slipped",
    "dropped_outside",
    "knocked_over",
    "lost_steps",
    "move_rejected",
    "not_run",  # never attempted: the firmware faulted or the simulation became invalid
)

# Grip force, leaf contacts and motor lag are sampled every this many physics steps (10 ms
# at the paper's 1 ms step: the gripper moves at most 1.5 mm between samples).
MONITOR_EVERY_STEPS = 10


@dataclass
class SeedlingRecord:
    """What happened to one seedling."""

    index: int
    pickup: int
    pot: int | None = None
    outcome: str = "pending"
    t_start_s: float | None = None
    t_release_s: float | None = None
    cycle_time_s: float | None = None
    peak_grip_force_n: float = 0.0
    leaves_hit: bool = False
    lost_steps: bool = False
    steps_lost: int = 0  # microsteps the motors slipped during this cycle (all motors)
    max_lag_full_steps: float = 0.0
    knocked_before: bool = False
    lifted: bool | None = None
    in_gripper_at_drop: bool | None = None
    rejected_line: str | None = None


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
    scenario: str
    seed: int
    per_seedling: list[SeedlingRecord]
    sim_time_s: float
    wall_time_s: float
    valid: bool = True
    invalid_reason: str | None = None
    fault: str | None = None

    @property
    def seedlings(self) -> int:
        return len(self.per_seedling)

    @property
    def attempted(self) -> int:
        """Seedlings whose cycle ran (not stopped by a fault or invalid physics first)."""
        return sum(r.outcome != "not_run" for r in self.per_seedling)

    @property
    def successes(self) -> int:
        return sum(r.outcome == "success" for r in self.per_seedling)

    @property
    def success_rate(self) -> float:
        return self.successes / self.seedlings if self.seedlings else 0.0

    @property
    def cycle_times(self) -> np.ndarray:
        return np.array([r.cycle_time_s for r in self.per_seedling if r.cycle_time_s is not None])

    def failures(self) -> dict[str, int]:
        return {k: sum(r.outcome == k for r in self.per_seedling) for k in FAILURE_KINDS}

    def to_dict(self) -> dict[str, Any]:
        cycles = self.cycle_times
        lo, hi = wilson_interval(self.successes, self.seedlings)
        return {
            "scenario": self.scenario,
            "seed": self.seed,
            "valid": self.valid,
            "invalid_reason": self.invalid_reason,
            "fault": self.fault,
            "seedlings": self.seedlings,
            "successes": self.successes,
            "success_rate": self.success_rate,
            "success_rate_ci95": [lo, hi],
            "failures": self.failures(),
            "cycle_time_s": float(cycles.mean()) if cycles.size else None,
            "cycle_time_sd_s": float(cycles.std(ddof=1)) if cycles.size > 1 else None,
            "seedlings_per_min": (
                60.0 * self.attempted / self.sim_time_s if self.sim_time_s else 0.0
            ),
            "sim_time_s": self.sim_time_s,
            "wall_time_s": self.wall_time_s,
            "real_time_factor": self.sim_time_s / self.wall_time_s if self.wall_time_s else None,
            "per_seedling": [asdict(r) for r in self.per_seedling],
        }


@dataclass
class _Watcher:
    """Follows the PGF's lines and the physics to fill the seedling records."""

    twin: Twin
    records: list[SeedlingRecord]
    recorder: Any = None
    current: SeedlingRecord | None = None
    pending_outcome: list[SeedlingRecord] = field(default_factory=list)
    parked: int = 0

    def __post_init__(self) -> None:
        scene = self.twin.scene
        self.taught = self.twin.machine.eeprom
        self.pot_bodies = np.asarray(scene.pot_bodies).ravel()
        self.active = np.ones(self.pot_bodies.size, dtype=bool)
        model = self.twin.model
        self.pot_qadr = scene.pot_qpos_adr
        self.pot_dadr = scene.pot_dof_adr
        planes = np.flatnonzero(model.geom_type == 0)  # mjGEOM_PLANE
        self.floor_z = float(model.geom_pos[planes, 2].min()) if planes.size else -1.0
        self.lift_m = self.taught.z_up_m - self.taught.z_low_m
        self.pot_height = float(self.twin.scenario["pots"]["height_m"])
        self.metrics = self.twin.scenario["metrics"]
        self.half_cell = 0.5 * float(self.twin.scenario["conveyor"]["cell_pitch_m"])
        self.gripping = False  # between the close and release lines
        self.steps_lost0 = np.zeros(3, dtype=np.int64)
        self.z0 = 0.0

    def on_line(self, event: LineEvent) -> None:
        """Follow the PGF: a seedling's cycle starts when its approach line is sent."""
        line, t = event.line, event.t
        rec = self.records[line.seedling] if line.seedling is not None else None
        if event.kind == "sent":
            if self.recorder is not None:
                self.recorder.event(t, "sent", f"{line.phase}: {line.text}", line.seedling)
            if rec is not None and line.phase == "approach":
                self._start(rec, t)
            return
        if line.reply is not None and line.reply.startswith("error"):
            if rec is not None:
                rec.outcome = "move_rejected"
                rec.rejected_line = f"{line.text} -> {line.reply}"
                self.current = None
            if self.recorder is not None:
                self.recorder.event(
                    t, "failure", f"rejected {line.text}: {line.reply}", line.seedling
                )
            return
        if self.recorder is not None:
            self.recorder.event(t, "ack", f"{line.phase}: {line.reply}", line.seedling)
        if rec is None:
            return
        d = self.twin.data
        if line.phase == "approach":
            self._resolve_pending(t)  # the previous pot has had a whole move to land
        elif line.phase == "close":
            if self.recorder is not None:
                self.recorder.event(t, "grasp", f"seedling {rec.index} gripper closing", rec.index)
            self.gripping = True
        elif line.phase == "lift" and rec.pot is not None:
            z = float(d.xpos[self.pot_bodies[rec.pot], 2])
            rec.lifted = z - self.z0 > self.metrics["lifted_fraction"] * self.lift_m
        elif line.phase == "to_drop" and rec.pot is not None:
            rec.in_gripper_at_drop = self._between_jaws(rec.pot)
        elif line.phase == "release":
            self.gripping = False
            if self.recorder is not None:
                self.recorder.event(t, "release", f"seedling {rec.index} released", rec.index)
        elif line.phase == "release_wait":
            rec.t_release_s = t
            rec.cycle_time_s = t - rec.t_start_s
            self._update_lost_steps(rec)
            self.pending_outcome.append(rec)
            self.current = None

    def _start(self, rec: SeedlingRecord, t: float) -> None:
        rec.t_start_s = t
        self.current = rec
        self.steps_lost0 = self.twin.steps_lost.copy()
        pickup = self.taught.pickups[rec.pickup]
        rec.pot, offset, tilt = self._target_pot(np.asarray(pickup.grip_xy_m))
        rec.knocked_before = (
            offset > self.metrics["knocked_offset_m"] or tilt > self.metrics["knocked_tilt_rad"]
        )
        if rec.pot is not None:
            self.z0 = float(self.twin.data.xpos[self.pot_bodies[rec.pot], 2])

    def _update_lost_steps(self, rec: SeedlingRecord) -> None:
        lost = np.abs(self.twin.steps_lost - self.steps_lost0)
        rec.steps_lost = int(lost.sum())
        rec.lost_steps = rec.steps_lost > 0

    def _target_pot(self, grip_xy: np.ndarray) -> tuple[int | None, float, float]:
        """The pot standing nearest the grip point, its offset from it, and its tilt; None
        (and an infinite offset) when no pot on the belt is within half a cell of it.

        Only pots still on the belt count (a pot lying in the funnel or on the floor is
        not one the arm can be sent for)."""
        d = self.twin.data
        pos = d.xpos[self.pot_bodies]
        on_belt = self.active & (pos[:, 2] > 0.0) & (pos[:, 2] < self.pot_height)
        idx = np.flatnonzero(on_belt)
        if idx.size == 0:
            return None, math.inf, 0.0
        dist = np.linalg.norm(pos[idx, :2] - grip_xy, axis=1)
        j = int(np.argmin(dist))
        if dist[j] > self.half_cell:
            return None, math.inf, 0.0
        pot = int(idx[j])
        zaxis_z = d.xmat[self.pot_bodies[pot], 8]  # R[2,2]: cos of the tilt
        return pot, float(dist[j]), float(math.acos(np.clip(zaxis_z, -1.0, 1.0)))

    def _between_jaws(self, pot: int) -> bool:
        d = self.twin.data
        grip = d.site_xpos[self.twin.scene.grip_site]
        rel = d.xpos[self.pot_bodies[pot]] - grip
        return bool(
            np.hypot(rel[0], rel[1]) < self.metrics["between_jaws_m"]
            and abs(rel[2]) < self.pot_height / 2
        )

    def _resolve_pending(self, t: float) -> None:
        if not self.pending_outcome:
            return
        in_tube = self.twin.scene.pot_in_tube(self.twin.data)
        for rec in self.pending_outcome:
            ok = rec.pot is not None and bool(in_tube[rec.pot])
            rec.outcome = "success" if ok else self._failure_kind(rec)
            if ok:
                self._park(rec.pot)
            if self.recorder is not None:
                kind = "success" if ok else "failure"
                self.recorder.event(t, kind, f"seedling {rec.index}: {rec.outcome}", rec.index)
        self.pending_outcome.clear()

    @staticmethod
    def _failure_kind(rec: SeedlingRecord) -> str:
        if rec.knocked_before:
            return "knocked_over"
        if rec.lost_steps:
            return "lost_steps"
        if not rec.lifted:
            return "not_gripped"
        if not rec.in_gripper_at_drop:
            return "slipped"
        return "dropped_outside"

    def _park(self, pot: int) -> None:
        """The planting unit takes the pot away: it rests far from the machine from now on."""
        d = self.twin.data
        a, v = self.pot_qadr[pot], self.pot_dadr[pot]
        height = 2 * float(
            self.twin.model.geom_size[self.twin.model.body_geomadr[self.pot_bodies[pot]], 1]
        )
        d.qpos[a : a + 3] = (
            1.0 + 0.1 * (self.parked % 10),
            -1.0 - 0.1 * (self.parked // 10),
            self.floor_z + height / 2 + 1e-3,
        )
        d.qpos[a + 3 : a + 7] = (1.0, 0.0, 0.0, 0.0)
        d.qvel[v : v + 6] = 0.0
        self.active[pot] = False
        self.parked += 1

    def monitor(self, twin: Twin, i: int) -> None:
        rec = self.current
        if rec is None:
            return
        scene, d = twin.scene, twin.data
        if self.gripping and d.ncon:  # the clamping force while the gripper holds the pot
            force = 0.5 * scene.grip_force(d)  # each jaw's share of the total normal force
            if force > rec.peak_grip_force_n:
                rec.peak_grip_force_n = force
        if not rec.leaves_hit:
            hit = scene.leaf_hit_pots(d)
            rec.leaves_hit = bool((hit != rec.pot).any())  # the neighbours' leaves
        lag = float(twin.motor_lag_full_steps().max())
        if lag > rec.max_lag_full_steps:
            rec.max_lag_full_steps = lag

    def finish(self, t: float, valid: bool) -> None:
        """Judge the last pots; on invalid physics nothing more is judged: not_run."""
        if self.current is not None:
            self._update_lost_steps(self.current)
        if valid:
            self._resolve_pending(t)
        for rec in self.records:
            if rec.outcome == "pending":
                rec.outcome = "not_run"


class _Progress:
    def __init__(self, total: int, enabled: bool) -> None:
        self.total, self.enabled, self.t0 = total, enabled, time.perf_counter()

    def update(self, done: int, sim_t: float) -> None:
        if not self.enabled:
            return
        width = 30
        fill = int(width * done / max(self.total, 1))
        wall = time.perf_counter() - self.t0
        sys.stderr.write(
            f"\r[{'#' * fill}{'.' * (width - fill)}] {done}/{self.total} seedlings  "
            f"sim {sim_t:7.1f} s  wall {wall:6.1f} s"
        )
        sys.stderr.flush()

    def close(self) -> None:
        if self.enabled:
            sys.stderr.write("\n")


def run_trial(
    scenario: Scenario,
    recorder_path: str | Path | None = None,
    record_rate_hz: float = 60.0,
    progress: bool = False,
) -> TrialResult:
    """Run the scenario's seedlings through the whole twin and measure what happens."""
    t_wall = time.perf_counter()
    twin = Twin(scenario)
    m_pp = twin.machine.eeprom.m_pp
    records = [
        SeedlingRecord(index=i, pickup=i % m_pp) for i in range(scenario["scenario"]["seedlings"])
    ]
    recorder = None
    if recorder_path is not None:
        from transplanter.recording import TrialRecorder

        recorder = TrialRecorder(
            twin.model, recorder_path, rate_hz=record_rate_hz, scalar_names=SCALAR_NAMES
        )
    watcher = _Watcher(twin, records, recorder)
    twin.line_listeners.append(watcher.on_line)
    bar = _Progress(len(records), progress)
    monitor = watcher.monitor if recorder is None else _RecordingMonitor(watcher, recorder)
    every = MONITOR_EVERY_STEPS if recorder is None else 1
    if recorder is not None:
        monitor.record(twin, np.zeros(3, dtype=np.int64))  # the power-on state at t = 0
    valid, reason = True, None
    try:
        horizon = 60.0 + 30.0 * len(records)
        while not (twin.pgf.done or twin.pgf.fault) and twin.time < horizon:
            twin.step_until(min(twin.time + 1.0, horizon), monitor=monitor, monitor_every=every)
            bar.update(
                sum(r.outcome != "pending" or r.t_release_s is not None for r in records), twin.time
            )
        twin.step_until(
            twin.time + scenario["metrics"]["settle_s"],
            monitor=monitor,
            monitor_every=every,
            stop_when_done=False,
        )
        if not (twin.pgf.done or twin.pgf.fault):
            valid, reason = False, f"the PGF did not finish within {horizon:.0f} s simulated"
    except SimulationInvalid as exc:
        valid, reason = False, str(exc)
    finally:
        bar.close()
        watcher.finish(twin.time, valid)
        if recorder is not None:
            if twin.block is not None:
                monitor.record(twin, twin.block.pulses[-1], force=True)
            recorder.close()
    return TrialResult(
        scenario=scenario.name,
        seed=scenario.seed,
        per_seedling=records,
        sim_time_s=twin.time,
        wall_time_s=time.perf_counter() - t_wall,
        valid=valid,
        invalid_reason=reason,
        fault=twin.pgf.fault,
    )


class _RecordingMonitor:
    """Feeds the recorder its frames (poses and scalar channels) while monitoring the trial."""

    def __init__(self, watcher: _Watcher, recorder: Any) -> None:
        self.watcher, self.recorder = watcher, recorder
        self.pulses = np.zeros(3, dtype=np.int64)
        self.t_pulses = 0.0

    def __call__(self, twin: Twin, i: int) -> None:
        # called every physics step so that frames fall on the recording rate's grid
        if twin.k % MONITOR_EVERY_STEPS == 0:
            self.watcher.monitor(twin, i)
        if self.recorder.due(twin.time):
            self.record(twin, twin.block.pulses[i])

    def record(self, twin: Twin, pulses: np.ndarray, force: bool = False) -> None:
        t, d, scene = twin.time, twin.data, twin.scene
        dt = t - self.t_pulses
        rates = np.abs(pulses - self.pulses) / dt if dt > 0 else np.zeros(3)
        self.pulses, self.t_pulses = pulses.copy(), t
        cmd = twin.commanded_joints()
        act = scene.joint_positions(d)
        scalars = np.array([
            math.degrees(cmd[0]), math.degrees(act[0]),
            math.degrees(cmd[1]), math.degrees(act[1]),
            cmd[2] * 1e3, act[2] * 1e3,
            rates[0], rates[1], rates[2],
            twin.gripper_opening_cmd(np.array([t]))[0] * 1e3,
            scene.gripper_opening(d) * 1e3,
            0.5 * scene.grip_force(d),
            math.degrees(d.qpos[scene.wrist_qpos_adr]),
            scene.conveyor_position(d) * 1e3,
        ])  # fmt: skip
        self.recorder.frame(t, d, scalars, force=force)


def write_json_atomic(path: Path, payload: dict[str, Any]) -> None:
    """Write JSON so that the file is either the old one or the complete new one."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(payload, f, indent=2, sort_keys=True)
            f.write("\n")
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; results are for sharing
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def format_summary(result: TrialResult) -> str:
    d = result.to_dict()
    lo, hi = d["success_rate_ci95"]
    rows = [
        ("scenario", f"{d['scenario']} (seed {d['seed']})"),
        ("valid", "yes" if d["valid"] else f"NO: {d['invalid_reason']}"),
        ("seedlings", f"{d['seedlings']}"),
        (
            "success rate",
            f"{100 * d['success_rate']:.1f} % ({d['successes']}/{d['seedlings']}), "
            f"95 % CI {100 * lo:.1f}-{100 * hi:.1f} %",
        ),
        (
            "cycle time",
            "n/a"
            if d["cycle_time_s"] is None
            else f"{d['cycle_time_s']:.3f} s mean, sd {d['cycle_time_sd_s'] or 0:.3f} s",
        ),
        ("seedlings per minute", f"{d['seedlings_per_min']:.1f}"),
        ("simulated time", f"{d['sim_time_s']:.1f} s"),
        ("wall time", f"{d['wall_time_s']:.1f} s"),
        ("real-time factor", f"{d['real_time_factor']:.1f}x" if d["real_time_factor"] else "n/a"),
    ]
    rows += [(f"failures: {k}", str(v)) for k, v in d["failures"].items()]
    if d["fault"]:
        rows.append(("firmware fault", d["fault"]))
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def _output_problem(path: Path | None, suffix: str | None) -> str | None:
    """Why an output file cannot be written there (checked before simulating), or None."""
    if path is None:
        return None
    path = Path(path)
    if path.is_dir():
        return f"{path} is a directory; give a file name"
    if not path.parent.is_dir():
        return f"{path.parent} does not exist; create it first"
    if not os.access(path.parent, os.W_OK):
        return f"{path.parent} is not writable"
    if suffix is not None and path.suffix != suffix:
        return f"{path} must end in {suffix}"
    return None


def run_trial_cli(args) -> int:
    for option, path, suffix in (("--json", args.json, None), ("--record", args.record, ".rrd")):
        problem = _output_problem(path, suffix)
        if problem is not None:
            print(f"{option}: {problem}", file=sys.stderr)
            return 2
    if not args.record_rate > 0:
        print(f"--record-rate must be > 0 Hz, got {args.record_rate}", file=sys.stderr)
        return 2
    overrides: dict[str, Any] = {}
    if args.seedlings is not None:
        overrides["scenario.seedlings"] = args.seedlings
    if args.seed is not None:
        overrides["scenario.seed"] = args.seed
    from transplanter.preflight import check_scenario

    scenario = load_scenario(args.scenario, overrides, extra_checks=check_scenario)
    result = run_trial(
        scenario,
        recorder_path=args.record,
        record_rate_hz=args.record_rate,
        progress=not args.quiet and sys.stderr.isatty(),
    )
    print(format_summary(result))
    if args.json is not None:
        write_json_atomic(args.json, result.to_dict())
        print(f"results written to {args.json}")
    if args.record is not None:
        print(
            f"recording written to {args.record} (view it with: transplanter replay {args.record})"
        )
    if not result.valid:
        return 3
    return 4 if result.fault else 0
