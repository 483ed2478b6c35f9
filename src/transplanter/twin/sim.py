"""The five-bar's firmware side of the one loop (`twin.loop.StepLoop`): the SGF's step events
drive the MuJoCo physics.

PGF -> COM bus -> SGF run on the simulated clock exactly as in `machine.rig`, but the
limit switches come from the model's sensors and, at every physics step, each stepper's field
stands where its SGF step pulses have put it at the step's start (`SGF.pulses_at`), never on a
smoothed trajectory, and the motor's torque over the step is its torque law at the load angle
then (`transplanter.scene.stepper`). The loop is event driven here: per-move work is done once
per firmware event (the loop's exchange, `Twin._exchange_block`): the fields, pull-out torques
and field speeds of every physics step until the next event are computed in one vectorised
call, so the per-step path (`Twin._before_step`, `Twin._after_step`) is one row copy, three
motor torques, `mj_step` and the drives' meter (plus the conveyor's drive while it indexes, a
slip check every few steps and the caller's monitor).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from transplanter.errors import TransplanterError
from transplanter.machine.bus import ComBus
from transplanter.machine.config import GRIPPER_SERVO, Machine
from transplanter.machine.faults import LostReplyTransport
from transplanter.machine.gcode import SERVO_MAX_DEG
from transplanter.machine.pgf import PGF, LineEvent, LineEventKind, SentLine  # noqa: F401
from transplanter.machine.rig import FirmwareLink
from transplanter.machine.sgf import SGF
from transplanter.scenario.assemble import TwinConfig
from transplanter.scene import ConveyorDrive, Scene, build_scene
from transplanter.scene.conveyor import INDEX_ERROR_STREAM
from transplanter.twin.loop import StepLoop
from transplanter.twin.motors import MotorMeter, drive_actuators

__all__ = ["Twin", "SimulationInvalid", "LineEvent", "LineEventKind", "LostStepEvent"]

# Longest block of physics steps whose commands are computed at once (bounds memory and how
# late a MuJoCo warning is noticed).
_MAX_BLOCK_STEPS = 500
# The motors are checked for slipping every this many physics steps.
SLIP_CHECK_STEPS = 5
# The field's speed (for the pull-out torque and the damping) is its pulses over this long
# (s) before each step: about the driver's current rise at the corner speed.
FIELD_SPEED_WINDOW_S = 0.002
# A motor counts as being stepped (its driver can sense a stall) when it got a pulse in this
# long (s): about 3 full steps/s at 16 microsteps, StallGuard's lower speed range.
STALL_WINDOW_S = 0.02
# Wrist servo angle at which the jaws point along passive link 1 (the wrist joint's zero).
WRIST_SERVO_ZERO_DEG = 90.0


@dataclass(frozen=True)
class LostStepEvent:
    """A motor slipped: when, which, by how many microsteps (signed), and what the machine
    (arm, gripper, jaws) was touching at that moment ('machine geom/other geom')."""

    t_s: float
    motor: int  # 0 arm 1, 1 arm 2, 2 Z
    microsteps: int
    contacts: tuple[str, ...]
    detected: bool = False  # the driver reported it as a stall and the SGF stopped


class SimulationInvalid(TransplanterError, RuntimeError):
    """The physics produced a MuJoCo warning or diverged: the trial is invalid."""


def _geom_name(model: mujoco.MjModel, geom: int) -> str:
    name = model.geom(geom).name
    return name or f"{model.body(model.geom_bodyid[geom]).name}:geom{geom}"


@dataclass
class _ServoRamp:
    """A hobby servo: holds its power-on angle, then turns at a constant speed towards its
    last command (degrees)."""

    speed_deg_s: float
    power_on_deg: float
    start_deg: float = field(init=False)
    target_deg: float = field(init=False)
    t0: float = 0.0

    def __post_init__(self) -> None:
        self.start_deg = self.target_deg = self.power_on_deg

    def command(self, t: float, target_deg: float) -> None:
        self.start_deg = self.at(np.array([t]))[0]
        self.target_deg = target_deg
        self.t0 = t

    def at(self, times: np.ndarray) -> np.ndarray:
        travel = self.target_deg - self.start_deg
        moved = np.minimum(self.speed_deg_s * np.maximum(times - self.t0, 0.0), abs(travel))
        return self.start_deg + math.copysign(1.0, travel) * moved


@dataclass
class _Block:
    """Commands for consecutive physics steps, computed once per firmware event: the
    actuators' controls (the motors' rows are written per step), the SGF's pulse counts and,
    per step and motor, the field (motor rad), its pull-out torque and the damping's
    field-speed term (N m), as lists for the per-step path."""

    ctrl: np.ndarray  # (n, nu)
    pulses: np.ndarray  # (n, 3)
    field: list  # n + 1 rows of 3: at each step's start, and at the last one's end
    amplitude: list
    feed: list
    conveyor: bool = False


@dataclass
class Twin:
    """One machine: scene, firmware and bus, stepped together on the simulated clock."""

    config: TwinConfig
    remote: Any = None
    """An external host (``transplanter.twin.serve.RemoteHost``): its ``attach(twin)`` returns the
    PGF's stand-in and the device layer in front of the SGF; None: the twin's own PGF."""
    machine: Machine = field(init=False)
    scene: Scene = field(init=False)

    def __post_init__(self) -> None:
        cfg = self.config
        self.machine = cfg.machine
        self.scene = build_scene(cfg.scene, seed=cfg.seed)
        self.model = self.scene.model
        self.data = self.scene.make_data()
        self.dt = float(self.model.opt.timestep)
        self.motors = MotorMeter(
            self.model, *drive_actuators(cfg.scene.robot_kind, cfg.scene.effector_kind)
        )
        self.sgf = SGF(self.machine.sgf)
        self.bus = ComBus(baud_bps=self.machine.baud_bps)
        self.faults = cfg.faults  # scenario [faults]: switches, a jam, a lost reply
        if self.faults.lost_reply_line:
            self.bus = LostReplyTransport(self.bus, self.faults.lost_reply_line)
        if self.remote is None:
            self.pgf = PGF(self.machine.eeprom, self.machine.pgf)
            self.link = FirmwareLink(self.pgf, self.bus, self.sgf)
        else:  # an external host on a serial line takes the PGF's place
            self.pgf, device = self.remote.attach(self)
            self.link = FirmwareLink(self.pgf, self.bus, self.sgf, device=device)
        self._max_opening = cfg.gripper_servo.max_opening_m
        self._open_m_per_deg = self._max_opening / SERVO_MAX_DEG
        # Servos hold their power-on pose (the keyframe's) until an M280 moves them.
        gripper_deg = self.scene.gripper_opening(self.data) / self._open_m_per_deg
        wrist_deg = math.degrees(self.data.qpos[self.scene.wrist_qpos_adr]) + WRIST_SERVO_ZERO_DEG
        self.gripper = _ServoRamp(cfg.gripper_servo.speed_deg_s, gripper_deg)
        self.wrist = _ServoRamp(cfg.wrist_servo.speed_deg_s, wrist_deg)
        self.conveyor = ConveyorDrive(self.scene)  # its state lives in self.data.userdata
        # where each index leaves the row (belt stretch, rib play): its own seeded stream
        self._index_error_sd = cfg.scene.conveyor_index_error_sd_m
        self._index_rng = np.random.default_rng((cfg.seed, INDEX_ERROR_STREAM))
        # Stepper positions are relative to where each motor was at power-on: the SGF's raw
        # pulse counters start at zero there, and homing only changes its logical counters.
        self.q_power_on = self.scene.joint_positions(self.data).copy()
        self.unit_per_step = np.array([d.unit_per_step for d in self.machine.drives])
        self.full_step_joint = np.array(
            [
                2 * math.pi / d.steps_per_rev / d.ratio
                if not d.linear
                else d.lead_m / d.steps_per_rev
                for d in self.machine.drives
            ]
        )
        # A stepper whose rotor falls more than two full steps behind its field has passed
        # the top of its torque curve's stable half: it slips to the next stable position,
        # four full steps (one electrical cycle) further (the torque law does it, the
        # bookkeeping here counts it): the steps are lost for good, the firmware never
        # learns of it.
        self.electrical_cycle = 4.0 * self.full_step_joint
        self.drives = self.scene.drives
        self._gears = self.scene.motor_gears
        # per motor, as Python numbers for the checks made every few steps: gear, qpos
        # address, full step and half an electrical cycle (motor rad)
        self._motor_terms = [
            (float(g), int(q), float(f * g), float(0.5 * c * g))
            for g, q, f, c in zip(
                self.scene.motor_gears,
                self.scene.motor_qpos_adr,
                self.full_step_joint,
                self.electrical_cycle,
                strict=True,
            )
        ]
        # the field (motor rad) the motors are pulled towards in the step being taken
        self._field_now = tuple(self.q_power_on * self._gears)
        self.microsteps_per_full_step = np.array([d.microsteps for d in self.machine.drives])
        self.slip_offset = np.zeros(3)  # joint units the motors have lost so far
        self.microsteps_lost = np.zeros(3, dtype=np.int64)  # microsteps lost per motor (signed)
        self.lost_step_events: list[LostStepEvent] = []
        # the largest bend (deg) of the seedling shoots followed now, written by the trial's
        # judge (transplanter.twin.shoot: the shoots are not bodies); a recording channel
        self.stem_bend_deg = 0.0
        self.belt_realignments: list[tuple[float, float]] = []
        """(t, m) at each conveyor index: how far the belt was off its held position, which
        the index's own profile then takes back."""
        root = self.scene.robot_root
        self._machine_body = self.model.body_rootid == self.model.body_rootid[root]
        # the one loop, event driven: an exchange computes a block of steps' commands
        self.loop = StepLoop(self.model, self.data, exchange=self._exchange_block)
        self.loop.before_step.append(self._before_step)
        self.loop.after_step.append(self._after_step)
        self.loop.after_block.append(self._check_valid)
        self._monitor: Callable[[Twin, int], None] | None = None
        self._monitor_every = 5
        self._idle_to_end = False
        self._switches_then: tuple[bool, ...] | None = None
        self._done_index = 0
        self._warnings0 = self._warning_counts()
        self.line_listeners: list[Callable[[LineEvent], None]] = []
        # Called with the twin at every firmware exchange, before the next block of physics
        # steps is computed: an observer may read the state or apply external forces.
        self.exchange_listeners: list[Callable[[Twin], None]] = []
        self.block: _Block | None = None
        # A jam (faults.jam_motor): a friction brake on the motor's joint while it lasts, the
        # jam torque at the motor shaft passed to the joint through the drive's gear.
        self._jam_dof, self._jam_frictionloss = -1, (0.0, 0.0)
        if self.faults.jam_motor:
            motor = self.faults.jam_motor - 1
            joint = self.model.actuator_trnid[self.scene.motor_actuators[motor], 0]
            self._jam_dof = int(self.model.jnt_dofadr[joint])
            free = float(self.model.dof_frictionloss[self._jam_dof])
            brake = float(self.scene.motor_gears[motor]) * self.faults.jam_torque_nm
            self._jam_frictionloss = (free, free + brake)
            # the hardest friction constraint MuJoCo allows: a brake that holds, where the
            # default impedance lets the light joint creep through it like a weak damper
            self.model.dof_solimp[self._jam_dof, :2] = mujoco.mjMAXIMP

    # -- time -------------------------------------------------------------------------
    @property
    def k(self) -> int:
        """Physics steps taken; time = k * dt exactly."""
        return self.loop.k

    @property
    def time(self) -> float:
        return self.loop.k * self.dt

    @property
    def pickups_xy(self) -> list[tuple[float, float]]:
        """Each taught pickup's grip point on the belt (x, y; m): what the judge looks at."""
        return [p.grip_xy_m for p in self.machine.eeprom.pickups]

    @property
    def lift_m(self) -> float:
        """How far the jaws lift a pot: the taught Z up less the taught Z low (m)."""
        taught = self.machine.eeprom
        return taught.z_up_m - taught.z_low_m

    def _warning_counts(self) -> np.ndarray:
        return np.array(self.data.warning.number, dtype=np.int64)

    # -- firmware exchange ------------------------------------------------------------
    def _exchange(self, t: float) -> None:
        """Deliver bus traffic due at t, advance SGF and PGF, start servos and conveyor."""
        if self._jam_dof >= 0:
            jammed = self.faults.jam_active(t)
            self.model.dof_frictionloss[self._jam_dof] = self._jam_frictionloss[jammed]
        sent_now = self.link.exchange(t, self._switches())
        # nothing asks for pulses older than a stall window (`_stall_flags`): keep the
        # SGF's motion history short, or every `pulses_at` searches the whole trial's
        self.sgf.forget_before(t - STALL_WINDOW_S)
        for ts, index, deg in self.sgf.drain_servo_commands():
            servo = self.gripper if index == GRIPPER_SERVO else self.wrist
            servo.command(ts, deg)
        for t_event, name in self.sgf.drain_machine_events():
            if name == "conveyor_index":
                self.belt_realignments.append((t_event, self.conveyor.grid_offset(self.data)))
                error = self._index_error_sd * self._index_rng.standard_normal()
                if self.scene.window is not None:  # rows enter the physics (scene.live_rows)
                    self.scene.window.on_index(self.data)
                self.conveyor.start(
                    self.data, t_event, self.machine.sgf.conveyor_index_s, error_m=error
                )
        sent = self.pgf.sent
        while self._done_index < len(sent) and sent[self._done_index].reply is not None:
            self._notify(LineEvent(sent[self._done_index], t, LineEventKind.DONE))
            self._done_index += 1
        for line in sent_now:  # a remote host's line is reported once the device took it
            self._notify(LineEvent(line, line.t_sent, LineEventKind.SENT))
        for listener in self.exchange_listeners:
            listener(self)

    def _switches(self) -> tuple[bool, ...]:
        """The limit switches as the firmware reads them now (with any switch fault)."""
        return self.faults.switches(self.scene.limit_switches(self.data))

    def _notify(self, event: LineEvent) -> None:
        for listener in self.line_listeners:
            listener(event)

    def _next_exchange_time(self, t: float, idle_until: float) -> float:
        """The next exchange; `idle_until` when nothing is in flight."""
        t_next = self.link.next_event_time(t, self.dt, switches_watched=True)
        jam = self.faults.next_jam_change(t)  # the jam starts or ends at an exchange
        if jam is not None and (t_next is None or jam < t_next):
            t_next = jam
        return idle_until if t_next is None else t_next

    # -- command blocks -----------------------------------------------------------------
    def _block(self, t_next: float) -> _Block:
        """Actuator commands for every physics step from now until the next exchange, each
        from the firmware's state at the step's start (the time its force acts from)."""
        n = int(np.clip(math.ceil((t_next - self.time) / self.dt - 1e-9), 1, _MAX_BLOCK_STEPS))
        # n + 1 times: the start of each step, and the end of the last (the field the
        # rotor is compared with after each step)
        times = (self.k + np.arange(n + 1)) * self.dt
        pulses = self.sgf.pulses_at(times)
        before = self.sgf.pulses_at(np.maximum(times - FIELD_SPEED_WINDOW_S, 0.0))
        span = np.minimum(times, FIELD_SPEED_WINDOW_S)[:, None]
        gears = self._gears
        speed = np.divide(
            (pulses - before) * self.unit_per_step * gears, span,
            out=np.zeros(pulses.shape), where=span > 0,
        )  # fmt: skip
        field = (self.q_power_on + self.slip_offset + pulses * self.unit_per_step) * gears
        times, pulses = times[:n], pulses[:n]
        ctrl = np.repeat(self.data.ctrl[None, :], n, axis=0)
        ctrl[:, self.scene.gripper_actuator] = self.gripper_opening_cmd(times)
        ctrl[:, self.scene.wrist_actuator] = np.radians(self.wrist.at(times) - WRIST_SERVO_ZERO_DEG)
        bonds = self.scene.bond_actuators
        if bonds.size:  # a bond carries load while the jaws pull on its pot (build._add_bond)
            touching = self.scene.pots_touching_jaws(self.data)
            ctrl[:, bonds] = np.isin(self.scene.bond_pots, touching)
        return _Block(
            ctrl,
            pulses,
            field.tolist(),
            self.drives.pullout_nm(speed[:n]).tolist(),
            (speed[:n] * self.drives.damping).tolist(),
            self.conveyor.armed(self.data),
        )

    # -- stepping ------------------------------------------------------------------------
    def step_until(
        self,
        t_end: float,
        monitor: Callable[[Twin, int], None] | None = None,
        monitor_every: int = 5,
        stop_when_done: bool = True,
    ) -> None:
        """Advance the whole machine to simulated time t_end, or until the PGF is done or
        faults when stop_when_done (else the physics runs on with the firmware idle)."""
        self._monitor, self._monitor_every = monitor, monitor_every
        # With nothing in flight the firmware has nothing to say until t_end, unless the
        # caller stops when the program is done (it then looks after every step, as ever)
        # or an external host may write at any time.
        self._idle_to_end = not stop_when_done and self.remote is None
        pgf = self.pgf
        self.loop.run_until(t_end, (lambda: pgf.done or pgf.fault) if stop_when_done else None)

    def _exchange_block(self, t: float, t_end: float) -> int:
        """The loop's exchange: the firmware's, then the commands of every step until the
        next one (at most `t_end`); how many steps they are."""
        self._exchange(t)
        idle_until = t_end if self._idle_to_end else t + self.dt
        block = self.block = self._block(min(self._next_exchange_time(t, idle_until), t_end))
        # While it homes the SGF reads its switches: a change of them ends the block
        # (the next exchange reads them; see FirmwareLink.next_event_time).
        self._switches_then = self._switches() if self.sgf.homing else None
        return block.ctrl.shape[0]

    def _before_step(self, t: float) -> None:
        """The step's commands: the block's row, the steppers' torque law, the conveyor."""
        block, i, d = self.block, self.loop.i, self.data
        ctrl = d.ctrl
        ctrl[:] = block.ctrl[i]
        self.drives.apply(ctrl, d.qpos, block.field[i], block.amplitude[i], block.feed[i])
        if block.conveyor:
            self.conveyor.apply(d, t)

    def _after_step(self, t: float) -> None:
        """The drives' meter, the field now, the slip check every few steps, the monitor; a
        stall the drivers reported or a switch change while homing ends the block."""
        block, i, loop = self.block, self.loop.i, self.loop
        self.motors.record(self.data)
        self._field_now = block.field[i + 1]  # the field now, beside the rotor now
        k = loop.k
        stalled = k % SLIP_CHECK_STEPS == 0 and self._slip(block, i)
        if self._monitor is not None and k % self._monitor_every == 0:
            self._monitor(self, i)
        if stalled:  # the SGF stopped: the rest of this block's commands are void
            loop.end_block()
        elif self._switches_then is not None and self._switches() != self._switches_then:
            loop.end_block()

    def _slip(self, block: _Block, i: int) -> bool:
        """Count the electrical cycles every motor lagging more than two full steps has
        slipped (its torque law has pulled it to the next stable position) and move its field
        by as many cycles (the same torque: the bookkeeping that keeps load angles within
        half a cycle); True when the drivers reported it to the SGF (stall detection), which
        stopped."""
        qpos = self.data.qpos
        # the common case in scalars: no motor is half an electrical cycle off
        for (gear, adr, _, half_cycle), f in zip(self._motor_terms, self._field_now, strict=True):
            if abs(f - gear * qpos[adr]) > half_cycle:
                break
        else:
            return False
        lag = self.commanded_joints() - self.scene.joint_positions(self.data)
        cycles = np.rint(lag / self.electrical_cycle)
        if not cycles.any():
            return False
        shift = cycles * self.electrical_cycle
        self.slip_offset -= shift
        lost = (cycles * 4 * self.microsteps_per_full_step).astype(np.int64)
        self.microsteps_lost += lost
        contacts = self.machine_contacts()
        detected = self._stall_flags(lost)
        for motor in np.flatnonzero(lost):
            self.lost_step_events.append(
                LostStepEvent(
                    self.time, int(motor), int(lost[motor]), contacts, bool(detected[motor])
                )
            )
        moved = shift * self._gears
        block.field[i + 1 :] = (np.asarray(block.field[i + 1 :]) - moved).tolist()
        self._field_now = block.field[i + 1]
        if not detected.any():
            return False
        self.sgf.stall(self.time, int(np.flatnonzero(detected)[0]))
        return True

    def _stall_flags(self, lost: np.ndarray) -> np.ndarray:
        """Which slipping motors their drivers report as stalled: with stall detection, a
        motor that is being stepped. StallGuard measures the back-EMF of a turning motor
        and is blind below a minimum step rate (TMC2209 datasheet: TCOOLTHRS), so a motor
        pushed off position while it holds still loses its steps unnoticed."""
        if not self.sgf.config.stall_detection:
            return np.zeros(3, dtype=bool)
        window = np.array([self.time - STALL_WINDOW_S, self.time])
        pulses = self.sgf.pulses_at(window)
        return (lost != 0) & (pulses[1] != pulses[0])

    def _check_valid(self) -> None:
        grown = self._warning_counts() - self._warnings0
        if grown.any():
            names = [mujoco.mjtWarning(i).name for i in np.flatnonzero(grown)]
            raise SimulationInvalid(f"MuJoCo warning at t={self.time:.3f} s: {', '.join(names)}")
        if not np.isfinite(self.data.qpos).all() or not np.isfinite(self.data.qacc).all():
            raise SimulationInvalid(
                f"simulation diverged (non-finite state) at t={self.time:.3f} s"
            )

    # -- observations used by trials and recordings -------------------------------------
    def gripper_opening_cmd(self, times: np.ndarray) -> np.ndarray:
        """Jaw opening (m) the gripper servo is commanded to at the given times: the servo's
        angle maps linearly onto the opening, 0 deg closed, SERVO_MAX_DEG (a hobby servo's
        whole turn) fully open."""
        opening = self.gripper.at(np.asarray(times, dtype=float)) * self._open_m_per_deg
        return np.clip(opening, 0.0, self._max_opening)

    def machine_contacts(self) -> tuple[str, ...]:
        """The contacts of the machine's geoms now, as 'machine geom/other geom' names."""
        m, d = self.model, self.data
        out = []
        for c in d.contact[: d.ncon]:
            g1, g2 = int(c.geom1), int(c.geom2)
            on1, on2 = self._machine_body[m.geom_bodyid[g1]], self._machine_body[m.geom_bodyid[g2]]
            if on1 or on2:
                mine, other = (g1, g2) if on1 else (g2, g1)
                out.append(f"{_geom_name(m, mine)}/{_geom_name(m, other)}")
        return tuple(sorted(set(out)))

    def commanded_joints(self) -> np.ndarray:
        """Where the motors' fields stand in the step being taken (joint units: rad, rad, m),
        lost steps taken off."""
        return np.asarray(self._field_now) / self._gears

    def max_motor_lag_full_steps(self) -> float:
        """The largest |field - rotor| of the motors, in full motor steps (a stepper slips
        past 2); in scalars: the judge asks every few steps."""
        qpos = self.data.qpos
        return max(
            abs(f - gear * qpos[adr]) / full_step
            for (gear, adr, full_step, _), f in zip(self._motor_terms, self._field_now, strict=True)
        )
