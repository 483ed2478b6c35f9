"""The pot line's judge: follows the pick cycle and the physics and fills the seedling records,
whatever robot works the line.

It samples the physics at the moments that decide a seedling's fate: the approach (is there
a pot in the cell, still standing?), the lift (did the pot come up with the gripper?), the
arrival over the drop tube (is it still in the gripper?) and the next cycle (is it in the
tube?). Nothing is assumed: a pot that is not in the tube is a failure, named by the first
check it failed (`Judge.failure_kind`). Between those moments it follows each shoot's sway
from its pot's motion and the gripper's bridge over it (damage), the grip force, the leaves
the gripper strikes and the belt.

The cycle comes to it as phases (`machine.pgf.LinePhase`): `sent(phase, seedling, t)` when
the host starts one (its line goes on the bus), `done(phase, seedling, t)` when the machine
has finished it. The five-bar's PGF reports its lines (`on_line`: a line's phase, sent and
acknowledged); another robot's host program reports the same phases from its own lines
(`twin.pot_job`). What the judge reads of the machine is a `PotRig`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import mujoco
import numpy as np

from transplanter.machine.pgf import LineEvent, LineEventKind, LinePhase
from transplanter.scenario.assemble import JudgeConfig
from transplanter.scene.config import SHOOT_COM_SHARE, SHOOT_SPREAD
from transplanter.scene.conveyor import ConveyorDrive
from transplanter.scene.handles import PotLine
from transplanter.twin.results import EventKind, Outcome, SeedlingRecord
from transplanter.twin.shoot import ShootSway, shoot_params
from transplanter.units import M_PER_MM

__all__ = ["Judge", "EventSink", "PotRig"]


class PotRig(Protocol):
    """What the pot line's judge reads of the machine that works it (`twin.sim.Twin`, the
    five-bar's; `twin.pot_job.PotJobRig`, any other robot's)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    scene: PotLine  # the line's handles: pots, tube, leaves, the gripper's contacts
    conveyor: ConveyorDrive
    k: int  # physics steps done
    pickups_xy: Sequence[Any]  # each pickup's grip point on the belt (x, y), m
    lift_m: float  # how far the gripper lifts a pot off the belt, m
    microsteps_lost: np.ndarray  # per drive since power-on (zeros: drives that cannot slip)
    lost_step_events: list  # twin.sim.LostStepEvent, in time order
    stem_bend_deg: float  # the judge writes the largest bend of the shoots it follows

    def max_motor_lag_full_steps(self) -> float: ...


_HOMING = (LinePhase.HOME, LinePhase.REHOME, LinePhase.STALL_REHOME)
# A pot that rose less than this at the lift still stands on the belt (m).
_ON_BELT_M = 0.002
# The watched shoots follow their pots' motion every this long (s of simulated time), the
# same at every timestep up to it: fast enough to resolve the pot's vibration from the arms'
# steppers (their rotors ring at 50-90 Hz on each microstep) instead of aliasing it into the
# shoots' few hertz. The paper trial, seed 1 (largest bend over 40 shoots, wall time): every
# 10 ms 22.8 deg, 8.5 s; 5 ms 25.4 deg, 8.4 s; 2 ms 25.6 deg, 9.5 s; 1 ms 26.1 deg, 11.2 s.
SHOOT_PERIOD_S = 0.002
# The rest of the seedling in progress (grip force, leaf hits, belt, motor lag, lost-step
# events) is sampled every this long.
SAMPLE_PERIOD_S = 0.01

# (time s, kind, text, seedling index or None): what the judge reports as it goes.
EventSink = Callable[[float, EventKind, str, "int | None"], None]


def _upright(mat: list[float], half: list[float]) -> tuple[list[float], list[float]]:
    """A box's frame (rotation as 9 floats row-major, half sizes) with its axes renamed so
    that its z axis is the one nearest the world's vertical, pointing up (a right-handed
    frame, the same box): the shoot's press (`ShootSway.press_out_of_box`) bends a stem from
    the box's z axis. The parallel jaws' bridge lies flat (unchanged); the fuzzy gripper's
    palm stands on its edge under a delta's platform or at the end of a serial arm."""
    j = max(range(3), key=lambda c: abs(mat[6 + c]))
    sign = 1.0 if mat[6 + j] > 0 else -1.0
    if j == 2 and sign > 0:
        return mat, half
    col = [(mat[c], mat[3 + c], mat[6 + c]) for c in range(3)]
    z = tuple(sign * v for v in col[j])
    x = col[(j + 1) % 3]
    y = (z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0])
    rows = [[x[i], y[i], z[i]] for i in range(3)]
    return [v for r in rows for v in r], [half[(j + 1) % 3], half[(j + 2) % 3], half[j]]


class Judge:
    """Fills one SeedlingRecord per seedling from the twin's line events and physics."""

    def __init__(
        self,
        twin: PotRig,
        config: JudgeConfig,
        records: list[SeedlingRecord],
        on_event: EventSink | None = None,
    ) -> None:
        self.twin, self.config, self.records = twin, config, records
        self.on_event = on_event
        self.current: SeedlingRecord | None = None
        self.pending_outcome: list[SeedlingRecord] = []
        self.jams: list[SeedlingRecord] = []  # funnel jams whose pot is still in the funnel
        self.parked = 0
        self.indexes_done = 0  # conveyor indexes acknowledged so far
        scene, model = twin.scene, twin.model
        self.pickups_xy = [np.asarray(p, dtype=float)[:2] for p in twin.pickups_xy]
        self.pot_bodies = np.asarray(scene.pot_bodies).ravel()
        self.active = np.ones(self.pot_bodies.size, dtype=bool)
        self.pot_cells = np.asarray(scene.pots.cell_xy, dtype=float)
        self.pot_qadr = scene.pot_qpos_adr
        self.pot_dadr = scene.pot_dof_adr
        self.damage_bend_deg = math.degrees(config.damage_bend_rad)
        # the monitor's periods in physics steps (at least one)
        dt = float(model.opt.timestep)
        self._shoot_every = max(1, round(SHOOT_PERIOD_S / dt))
        self._sample_every = max(1, round(SAMPLE_PERIOD_S / dt))
        # seedlings whose shoot's sway is followed, from the approach until judged: record,
        # sway, the pot's qpos and dof address, its body and its stem's length (m)
        self.shoot_watch: list[tuple[SeedlingRecord, ShootSway, int, int, int, float]] = []
        # the gripper's bridge (the palm), an obstacle for the shoots under it
        self.bridge = scene.palm_geom
        self.bridge_half = model.geom_size[self.bridge].tolist()
        self.stem_radius = scene.config.stem_radius_m
        # a stem reaches no further than its length (xy) from its pot's axis, the bridge's
        # box no further than its half diagonal from its centre (however the gripper turns it)
        self.bridge_reach = math.sqrt(sum(h * h for h in self.bridge_half)) + self.stem_radius
        planes = np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE)
        self.floor_z = float(model.geom_pos[planes, 2].min()) if planes.size else -1.0
        self.lift_m = float(twin.lift_m)
        self.half_cell = 0.5 * config.cell_pitch_m
        self.gripping = False  # between the close and release lines
        drives = np.asarray(twin.microsteps_lost).size
        self.microsteps_lost0 = np.zeros(drives, dtype=np.int64)
        # what the motors had lost when the machine last homed, and the events until then
        self.lost_at_homing = np.zeros(drives, dtype=np.int64)
        self.events_at_homing = 0
        self.events_reported = 0
        self.z0 = 0.0
        # pots whose leaves a jaw has pushed so far (pots.canopy_contact)
        self.canopy_pushed = np.zeros(self.pot_bodies.size, dtype=bool)

    def _emit(self, t: float, kind: EventKind, text: str, seedling: int | None) -> None:
        if kind == EventKind.FAILURE and seedling is not None and self.jams:
            self._while_jammed(self.records[seedling])
        if self.on_event is not None:
            self.on_event(t, kind, text, seedling)

    def _while_jammed(self, rec: SeedlingRecord) -> None:
        """A failure judged while a funnel jam stands (its pot still in the funnel) names the
        jam, whatever the failure's own kind and wherever it was judged."""
        in_funnel = self.twin.scene.pot_in_funnel(self.twin.data)
        self.jams = [j for j in self.jams if in_funnel[j.pot]]
        if self.jams and rec.outcome != Outcome.FUNNEL_JAM and rec.after_jam is None:
            rec.after_jam = self.jams[0].index

    # -- the pick cycle ------------------------------------------------------------------
    def on_line(self, event: LineEvent) -> None:
        """Follow the five-bar's PGF: each line's phase as it is sent and acknowledged; a
        refused line (a stall the PGF recovers from, or a move the SGF rejected)."""
        line, t = event.line, event.t
        if event.kind == LineEventKind.SENT:
            self.sent(line.phase, line.seedling, t, f"{line.phase}: {line.text}")
            return
        rec = self.records[line.seedling] if line.seedling is not None else None
        if line.reply is not None and line.reply.startswith("error"):
            if line.phase == LinePhase.HOST:  # a remote host's own line: no seedling's
                self._emit(t, EventKind.FAILURE, f"refused {line.text}: {line.reply}", None)
                return
            if self.twin.pgf.fault is None:  # a stall the PGF recovers from: re-home, retry
                self._emit(t, EventKind.STALL, f"{line.phase}: {line.reply}", line.seedling)
                if rec is not None:
                    rec.stall_recoveries += 1
                    if rec.index in self.twin.pgf.abandoned and rec.outcome == Outcome.PENDING:
                        self._update_microsteps_lost(rec)
                        rec.outcome = self.failure_kind(rec)  # given up: never released
                        self._emit(t, EventKind.FAILURE, f"seedling {rec.index}: "
                                   f"{rec.outcome} (given up after {rec.stall_recoveries - 1} "
                                   "stall recoveries)", rec.index)  # fmt: skip
                        self.current = None
                return
            if rec is not None:
                rec.outcome = Outcome.MOVE_REJECTED
                rec.rejected_line = f"{line.text} -> {line.reply}"
                self.current = None
            self._emit(t, EventKind.FAILURE, f"rejected {line.text}: {line.reply}", line.seedling)
            return
        self.done(line.phase, line.seedling, t, f"{line.phase}: {line.reply}")

    def sent(self, phase: LinePhase, seedling: int | None, t: float, text: str = "") -> None:
        """The host starts `phase` of seedling `seedling`'s cycle (None: no seedling's): its
        cycle starts with its first phase, the approach is where the judge looks at its cell."""
        rec = self.records[seedling] if seedling is not None else None
        self._emit(t, EventKind.SENT, text or str(phase), seedling)
        if rec is not None and rec.t_start_s is None:
            rec.t_start_s = t  # the cycle starts with its first line (a re-home, if any)
        if rec is not None and phase == LinePhase.APPROACH:
            self._start(rec, t)

    def done(self, phase: LinePhase, seedling: int | None, t: float, text: str = "") -> None:
        """The machine has finished `phase` of seedling `seedling`'s cycle: the judge looks at
        the physics the phase decides (the lift, the arrival over the tube, the release)."""
        self._emit(t, EventKind.ACK, text or str(phase), seedling)
        if phase in _HOMING:  # homing re-references the motors
            self.lost_at_homing = self.twin.microsteps_lost.copy()
            self.events_at_homing = len(self.twin.lost_step_events)
        rec = self.records[seedling] if seedling is not None else None
        if rec is None:
            return
        d = self.twin.data
        if phase == LinePhase.APPROACH:
            self._resolve_pending(t)  # the previous pot has had a whole move to land
        elif phase == LinePhase.CLOSE:
            self._emit(t, EventKind.GRASP, f"seedling {rec.index} gripper closing", rec.index)
            self.gripping = True
        elif phase == LinePhase.LIFT and rec.pot is not None:
            z = float(d.xpos[self.pot_bodies[rec.pot], 2])
            rec.lifted = z - self.z0 > self.config.lifted_fraction * self.lift_m
            # a bonded pot still down on the belt: its bond held it against the jaws' grip
            rec.stuck_to_belt = not rec.lifted and rec.bond_force_n > 0 and z - self.z0 < _ON_BELT_M
        elif phase == LinePhase.TO_DROP and rec.pot is not None:
            rec.in_gripper_at_drop = self._between_jaws(rec.pot)
        elif phase == LinePhase.RELEASE:
            self.gripping = False
            self._emit(t, EventKind.RELEASE, f"seedling {rec.index} released", rec.index)
        elif phase == LinePhase.RELEASE_WAIT:
            rec.t_release_s = t
            rec.cycle_time_s = t - rec.t_start_s
            self._update_microsteps_lost(rec)
            self.pending_outcome.append(rec)
            self.current = None
        elif phase == LinePhase.INDEX:
            self.indexes_done += 1

    def give_up(self, seedling: int, t: float, why: str) -> None:
        """The host gave seedling `seedling` up before releasing it (`why`: for the event
        log): a failure named by the first check it failed."""
        rec = self.records[seedling]
        self.gripping = False
        if rec.outcome == Outcome.PENDING:
            self._update_microsteps_lost(rec)
            rec.outcome = self.failure_kind(rec)
        self._emit(t, EventKind.FAILURE, f"seedling {rec.index}: {rec.outcome} ({why})", rec.index)
        self.current = None
        self.shoot_watch = [w for w in self.shoot_watch if w[0] is not rec]

    def skipped(self, seedling: int, t: float) -> None:
        """The host's sensor read no pot in seedling `seedling`'s cell and it went on: no_pot
        where the cell held none; where it held one (knocked over, out of the sensor's view),
        the failure it is (the cell is looked at as at an approach)."""
        rec = self.records[seedling]
        if rec.t_start_s is None:
            rec.t_start_s = t
        self._start(rec, t)
        if rec.outcome == Outcome.PENDING:
            rec.lifted = False
            self.give_up(seedling, t, "the host read no pot in its cell")
        else:
            self.current = None
            self._emit(t, EventKind.FAILURE, f"seedling {rec.index}: {rec.outcome}", rec.index)

    def _start(self, rec: SeedlingRecord, t: float) -> None:
        self.current = rec
        self.microsteps_lost0 = self.twin.microsteps_lost.copy()
        off = int(np.abs(self.microsteps_lost0 - self.lost_at_homing).sum())
        rec.position_error_microsteps = off
        if off:
            rec.lost_step_event = self.events_at_homing  # the first strike since homing
        grip_xy = self.pickups_xy[rec.pickup]
        if not self._cell_had_a_pot(grip_xy):
            rec.outcome = Outcome.NO_POT
            return
        rec.pot, offset, tilt = self._target_pot(grip_xy)
        if rec.pot is not None:
            rec.bond_force_n = float(self.twin.scene.pots.bond_force[rec.pot])
        rec.knocked_before = (
            offset > self.config.knocked_offset_m or tilt > self.config.knocked_tilt_rad
        )
        rec.canopy_pushed = rec.pot is not None and bool(self.canopy_pushed[rec.pot])
        rec.soft = rec.pot is not None and bool(self.twin.scene.pots.soft[rec.pot])
        row_offset = self.twin.conveyor.grid_offset(self.twin.data)
        rec.row_offset_mm = row_offset / M_PER_MM
        rec.row_off = abs(row_offset) > 0.5 * self.config.knocked_offset_m
        scene_pots = self.twin.scene.pots
        if rec.pot is not None:
            rec.crook_deg = math.degrees(float(scene_pots.crook[rec.pot]))
            self.z0 = float(self.twin.data.xpos[self.pot_bodies[rec.pot], 2])
            a, v = int(self.pot_qadr[rec.pot]), int(self.pot_dadr[rec.pot])
            body, length = int(self.pot_bodies[rec.pot]), float(scene_pots.stem_length[rec.pot])
            self.shoot_watch.append((rec, self._shoot(rec.pot), a, v, body, length))

    def _shoot(self, pot: int) -> ShootSway:
        """The sway of a pot's shoot, at rest on its pot (transplanter.twin.shoot); on a crooked
        pot it stands on the leaning wall's top."""
        cfg, pots = self.twin.scene.config, self.twin.scene.pots
        g = -float(self.twin.model.opt.gravity[2])
        hinge = np.array([0.0, 0.0, pots.soil_z(pot)])
        mount, wall = None, pots.wall_frame(pot)
        if wall is not None:
            pivot, mount, _ = wall
            hinge = pivot + mount @ (hinge - pivot)
        params = shoot_params(
            mass=cfg.shoot_mass_kg,
            com_height=SHOOT_COM_SHARE * float(pots.stem_length[pot]),
            spread=SHOOT_SPREAD,
            sway_hz=float(pots.sway_hz[pot]),
            damping_ratio=cfg.stem_damping_ratio,
            hinge=tuple(hinge),
            gravity=g,
        )
        return ShootSway(params, gravity=g, mount=mount)

    def _cell_had_a_pot(self, grip_xy: np.ndarray) -> bool:
        """Whether a pot was placed, at the start, in the cell that the conveyor has since
        brought under the grip point (the pots move one row pitch towards -y per index)."""
        origin = grip_xy + np.array([0.0, self.indexes_done * self.config.row_pitch_m])
        dist = np.abs(self.pot_cells - origin)
        return bool(np.any((dist[:, 0] <= self.half_cell) & (dist[:, 1] <= self.half_cell)))

    def _update_microsteps_lost(self, rec: SeedlingRecord) -> None:
        rec.microsteps_lost = int(np.abs(self.twin.microsteps_lost - self.microsteps_lost0).sum())
        if rec.microsteps_lost and rec.lost_step_event is None:
            events = self.twin.lost_step_events
            rec.lost_step_event = next(
                i for i, e in enumerate(events) if e.t_s >= (rec.t_start_s or 0.0)
            )

    def _target_pot(self, grip_xy: np.ndarray) -> tuple[int | None, float, float]:
        """The pot standing nearest the grip point, its offset from it, and its tilt; None
        (and an infinite offset) when no pot on the belt is within half a cell of it.

        Only pots still on the belt count (a pot lying in the funnel or on the floor is
        not one the arm can be sent for)."""
        d = self.twin.data
        pos = d.xpos[self.pot_bodies]
        on_belt = self.active & (pos[:, 2] > 0.0) & (pos[:, 2] < self.config.pot_height_m)
        if self.twin.scene.window is not None:  # only pots that are bodies (scene.live_rows)
            on_belt &= self.twin.scene.pot_live
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
            np.hypot(rel[0], rel[1]) < self.config.between_jaws_m
            and abs(rel[2]) < self.config.pot_height_m / 2
        )

    def _resolve_pending(self, t: float) -> None:
        if not self.pending_outcome:
            return
        scene, data = self.twin.scene, self.twin.data
        in_tube = scene.pot_in_tube(data)
        in_funnel = scene.pot_in_funnel(data)
        # a jam stands while its pot is still caught in the funnel
        self.jams = [j for j in self.jams if in_funnel[j.pot]]
        for rec in self.pending_outcome:
            if rec.outcome == Outcome.PENDING:
                ok = rec.pot is not None and bool(in_tube[rec.pot])
                if not ok:
                    rec.outcome = self.failure_kind(rec)
                    caught = rec.pot is not None and bool(in_funnel[rec.pot])
                    if rec.outcome == Outcome.DROPPED_OUTSIDE and caught and not self.jams:
                        rec.outcome = Outcome.FUNNEL_JAM  # the jam itself
                        rec.jam = {"t_s": round(t, 6), **scene.funnel_place(data, rec.pot)}
                        self.jams.append(rec)
                elif rec.shoot_pressed_deg > self.damage_bend_deg:
                    rec.outcome = Outcome.SHOOT_CRUSHED  # the gripper's bridge bent it over
                elif rec.peak_stem_bend_deg > self.damage_bend_deg:
                    rec.outcome = Outcome.DAMAGED  # in the tube, its stem bent past the limit
                else:
                    rec.outcome = Outcome.SUCCESS
                if ok:
                    self._park(rec.pot)
            kind = EventKind.SUCCESS if rec.outcome == Outcome.SUCCESS else EventKind.FAILURE
            self._emit(t, kind, f"seedling {rec.index}: {rec.outcome}", rec.index)
        self.pending_outcome.clear()
        self.shoot_watch = [w for w in self.shoot_watch if w[0] is self.current]

    @staticmethod
    def failure_kind(rec: SeedlingRecord) -> Outcome:
        """The first check a seedling whose pot is not in the tube failed."""
        if rec.knocked_before:
            if rec.canopy_pushed:
                return Outcome.TIPPED_BY_LEAF
            if rec.crook_deg > 0:
                return Outcome.CROOKED_POT
            return Outcome.ROW_OFF if rec.row_off else Outcome.KNOCKED_OVER
        if rec.position_error_microsteps:  # off position from the start: the earlier strike
            return Outcome.POSITION_LOST
        if rec.microsteps_lost:
            return Outcome.LOST_STEPS
        if not rec.lifted:
            if rec.stuck_to_belt:
                return Outcome.STUCK_TO_BELT
            if rec.soft:
                return Outcome.SOFT_POT
            if rec.crook_deg > 0:
                return Outcome.CROOKED_POT
            return Outcome.ROW_OFF if rec.row_off else Outcome.NOT_GRIPPED
        if not rec.in_gripper_at_drop:
            return Outcome.SLIPPED
        return Outcome.DROPPED_OUTSIDE

    def _park(self, pot: int) -> None:
        """The planting unit takes the pot away: it rests far from the machine from now on."""
        d, model = self.twin.data, self.twin.model
        a, v = self.pot_qadr[pot], self.pot_dadr[pot]
        height = 2 * float(model.geom_size[model.body_geomadr[self.pot_bodies[pot]], 1])
        d.qpos[a : a + 3] = (
            1.0 + 0.1 * (self.parked % 10),
            -1.0 - 0.1 * (self.parked // 10),
            self.floor_z + height / 2 + 1e-3,
        )
        d.qpos[a + 3 : a + 7] = (1.0, 0.0, 0.0, 0.0)
        d.qvel[v : v + 6] = 0.0
        self.active[pot] = False
        self.parked += 1
        if self.twin.scene.window is not None:  # it leaves the physics (scene.live_rows)
            self.twin.scene.window.release(d, pot)

    # -- physics samples -----------------------------------------------------------------
    def monitor(self, twin: PotRig, i: int) -> None:
        """Called after every physics step: follow the watched shoots every SHOOT_PERIOD_S of
        simulated time, and every SAMPLE_PERIOD_S sample the lost-step events, grip force,
        leaf hits, belt and motor lag of the seedling in progress (periods in time, not in
        steps: the same sampling at every timestep)."""
        k = twin.k
        if self.shoot_watch and k % self._shoot_every == 0:
            self._follow_shoots(twin)
        if k % self._sample_every == 0:
            self._sample(twin)

    def _sample(self, twin: PotRig) -> None:
        events = twin.lost_step_events
        while self.events_reported < len(events):
            e = events[self.events_reported]
            touching = ", ".join(e.contacts) or "nothing"
            text = f"motor {e.motor + 1} lost {e.microsteps} microsteps touching {touching}"
            seedling = self.current.index if self.current is not None else None
            self._emit(e.t_s, EventKind.LOST_STEPS, text, seedling)
            self.events_reported += 1
        scene, d = twin.scene, twin.data
        if scene.has_canopy_contact and d.ncon:
            for pot in scene.pots_with_leaves_on_jaws(d):
                self.canopy_pushed[pot] = True
        if not self.shoot_watch:
            twin.stem_bend_deg = 0.0
        rec = self.current
        if rec is None:
            return
        if self.gripping and d.ncon:  # the clamping force while the gripper holds the pot
            force = 0.5 * scene.grip_force(d)  # each jaw's share of the total normal force
            if force > rec.peak_grip_force_n:
                rec.peak_grip_force_n = force
        if not rec.leaves_hit:
            hit = scene.leaf_hit_pots(d)
            rec.leaves_hit = bool((hit != rec.pot).any())  # the neighbours' leaves
        belt = abs(twin.conveyor.displacement(d)) / M_PER_MM
        if belt > rec.max_belt_displacement_mm:
            rec.max_belt_displacement_mm = belt
        lag = twin.max_motor_lag_full_steps()
        if lag > rec.max_lag_full_steps:
            rec.max_lag_full_steps = lag

    def _follow_shoots(self, twin: PotRig) -> None:
        """Advance the watched shoots' sway to now from their pots' motion (and the bridge
        over them)."""
        d = twin.data
        qpos, qvel, t = d.qpos, d.qvel, d.time
        bend = 0.0
        bridge_xyz = d.geom_xpos[self.bridge].tolist()
        bridge_mat, bridge_half = _upright(d.geom_xmat[self.bridge].tolist(), self.bridge_half)
        for watched, sway, a, v, body, length in self.shoot_watch:
            vel = qvel[v : v + 6].tolist()  # floats: numpy scalars are slow in scalar math
            sway.update(t, qpos[a + 3 : a + 7].tolist(), vel[:3], vel[3:])
            pot_xyz = d.xpos[body].tolist()
            reach = length + self.bridge_reach
            if (
                abs(pot_xyz[0] - bridge_xyz[0]) < reach and abs(pot_xyz[1] - bridge_xyz[1]) < reach
            ):  # the bridge may be over this shoot: it pushes the stem out of its way
                pressed = sway.press_out_of_box(
                    pot_xyz, d.xmat[body].tolist(), length, self.stem_radius,
                    bridge_xyz, bridge_mat, bridge_half,
                )  # fmt: skip
                if pressed > 0.0:  # the bend it forced, from the pot's axis
                    watched.shoot_pressed_deg = max(
                        watched.shoot_pressed_deg, math.degrees(sway.bend_rad)
                    )
                    watched.shoot_touched_by = "bridge"
            watched.peak_stem_bend_deg = math.degrees(sway.peak_rad)
            bend = max(bend, sway.bend_rad)
        twin.stem_bend_deg = math.degrees(bend)

    def finish(self, t: float, valid: bool) -> None:
        """Judge the last pots; on invalid physics nothing more is judged: not_run."""
        if self.current is not None:
            self._update_microsteps_lost(self.current)
        self._sample(self.twin)  # report the last lost-step events
        if valid:
            self._resolve_pending(t)
        for rec in self.records:
            if rec.outcome == Outcome.PENDING:
                rec.outcome = Outcome.NOT_RUN
