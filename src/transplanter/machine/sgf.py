"""Signal generation firmware (SGF): G-code lines in, step pulses and handshakes out.

Lines are parsed on arrival and executed one at a time in arrival order (FIFO); each gets
its reply when it is done, so replies come back in line order:

- ``G0``/``G1``: planned from the current logical step counters with
  ``motion.plan_line`` before any step (every interpolated point checked); ``ok`` when the
  last step has been issued. Speed: ``S`` mm/s, or ``F`` mm/min, else the last one given,
  else ``default_speed_m_s``. ``G0`` moves like ``G1``, but with ``motion.planner =
  "bspline5"``: a ``G0`` with horizontal travel is then a pick-and-place transfer along the
  time-optimal quintic B-spline (``machine.spline_motion``: lift, arc, top, arc, descent,
  timed by the arm's joint limits; its speed word is ignored), refused with ``error:33``
  naming the limit when no timing meets it. On an arm with via transfers (the five-bar's
  ``transfer_path = "via"``) the spline instead passes the via points of the ``M720 X Y Z``
  lines received since the last move (``machine.planner_via``; none: straight from where
  the arm is to the target in joint space), timed by the arm's per-joint limits; an ``M280``
  between an ``M720`` and its ``G0`` acts when the spline passes that via point; a ``G1``,
  ``G4``, ``M710`` or ``M400`` before the ``G0`` is refused (``error:21``) and the via points
  dropped.
- ``G4 P<ms>``: ``ok`` after the dwell. A dwell over ``gcode.MAX_DWELL_MS`` or a move
  planned to take over ``MAX_MOVE_S`` (an hour each) is refused with ``error:63``.
  ``M280``: servo command recorded, ``ok`` at once.
  ``M710``: conveyor index recorded, ``ok`` after ``conveyor_index_s``. ``M400``: ``ok``
  (the FIFO has already finished everything before it). ``M114``/``M119``: a report line,
  then ``ok``. ``M105``: ``ok``.
- Receive buffer (Marlin's model): parsed lines wait in a command queue of
  ``command_queue_lines`` (BUFSIZE = 4) behind the running one. While it is full, arriving
  lines wait unparsed in a receive buffer of ``rx_buffer_bytes`` and enter the queue in
  order as slots free (Marlin stops reading serial: flow control by the ok handshake). A
  line that fits in neither is dropped and answered ``error:66`` at once, out of line
  order (a real UART loses the bytes; with N framing the next line is then out of
  sequence). A host that waits for ``ok`` before each line (the PGF) never fills them.
  A line over ``gcode.MAX_LINE_CHARS`` (256) characters gets ``error:11`` (line overflow).
- ``G28``: two-pass homing of every axis like grbl's (:class:`~transplanter.machine.homing.Homing`):
  seek, pull off, slow locate, pull off; ``ok`` once done, ``error:69`` if a switch never closes,
  ``error:68`` if one stays closed after the pull-off (each naming the switch and the likely
  cause), every motor stopped where it is. Moves before homing are refused (error 9, like
  grbl's alarm lock).
- A lower hard-limit switch of the kinematics (the five-bar's switch 4, Z down): a move that
  would lower its coordinate while it reads closed is refused with ``error:70`` (a stuck or
  shorted switch, or the axis lost steps downwards).

The arm is the config's :class:`~transplanter.machine.kinematics.Kinematics`, whatever its
kind: every interpolated point goes through its IK and reach check, and its axes (any number)
are the motors.
- Stall (``stall()``, a driver's stall output such as Trinamic StallGuard's DIAG pin, wired
  only when ``stall_detection``): every motor stops where it is, the running line and
  every queued or buffered line are answered ``error:67``, and the position is unknown
  (moves get ``error:9``) until a ``G28``. A stall while idle is reported to the next line
  (unless it is a ``G28``). Prusa's crash detection and Klipper's sensorless homing use the
  same driver signal; what the host does next is the host's business (the PGF re-homes).

Two counters per motor: raw pulses since power-on (never reset; they drive the simulated
motors through ``pulses_at``) and logical steps, which homing sets.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from transplanter.errors import ErrorCode
from transplanter.machine.gcode import (
    MAX_LINE_CHARS,
    GcodeError,
    GcodeLine,
    format_number,
    is_emergency_stop,
    parse_line,
)
from transplanter.machine.homing import Homing, HomingConfig
from transplanter.machine.kinematics import Kinematics, UnreachableError
from transplanter.machine.kinematics.fivebar import FiveBarKinematics
from transplanter.machine.motion import MAX_STEPS_PER_MOVE, MotionConfig, PlannedMove, plan_line
from transplanter.machine.steppers import StepperDrive
from transplanter.units import M_PER_MM, MM_PER_MIN_TO_M_S, S_PER_MS, show

MAX_MOVE_S = 3600.0
"""Longest a G0/G1 move may take (s): one hour, the machine time ``transplanter plan`` gives
any line (``planner.MAX_LINE_S``) and the longest dwell (``gcode.MAX_DWELL_MS``). A move whose
planned duration is longer (a feed such as ``F0.0000001``) is refused with error 63 naming its
F or S, this bound and the slowest speed that would do. grbl raises any feed below its
MINIMUM_FEED_RATE (1 mm/min) to it and Marlin one below its minimum feedrate, so neither ever
plans an endless move; at 1 mm/min the paper machine's longest move (about 300 mm) would still
take five hours, so the twin bounds the move's duration rather than its feed."""

_MOTION_COMMANDS = frozenset({"G0", "G1", "M280", "M710", "M720"})
"""What an emergency stop refuses until a G28: moves, the servos and the conveyor."""

_AFTER_VIAS_REFUSED = frozenset({"G1", "G4", "M710", "M400"})
SLOWED_MEANS = (
    "Not a fault: the machine's own limit, already in the cycle (in the paper scenario, its Z "
    "screw at its driver's rate: the paper's machine as built); to model a faster machine, "
    "change that limit"
)
"""What a speed warning means, after it (docs/results.md)."""
"""What may not run while M720 via points wait for their G0 transfer (they would run at the
wrong place): refused, the via points dropped."""


@dataclass(frozen=True)
class SGFConfig:
    """The machine the SGF drives (its kinematics, with the axes' drives), how it moves and
    homes, and its timing and buffers (SI units). Each setting is held here once."""

    kinematics: Kinematics = field(default_factory=FiveBarKinematics)
    """The arm: its axes (drives, homing switch positions, windows), IK, FK and limits."""
    motion: MotionConfig = field(default_factory=MotionConfig)
    homing: HomingConfig = field(default_factory=HomingConfig)
    """How G28 homes each axis; the defaults left None are filled in from the drives."""
    default_speed_m_s: float = 0.05
    """Speed of G0/G1 moves until a move gives S or F (modal afterwards)."""
    conveyor_index_s: float = 0.6
    require_checksum: bool = False
    """Refuse lines without Marlin ``N<n> ... *<checksum>`` framing."""
    command_queue_lines: int = 4
    """Parsed lines waiting behind the running one (Marlin's BUFSIZE = 4)."""
    stall_detection: bool = False
    """The drivers' stall output is wired to the SGF (see ``SGF.stall``); the paper's
    open-loop machine has none."""
    rx_buffer_bytes: int = 512
    """Serial receive buffer: lines that arrive while the command queue is full wait here,
    unparsed (Marlin stops reading serial while its queue is full; its RX_BUFFER_SIZE may be
    set up to 2048); a line that does not
    fit is dropped with error:66 (see the module docstring)."""

    def __post_init__(self):
        if not isinstance(self.kinematics, Kinematics):
            raise ValueError(f"SGFConfig.kinematics must be a Kinematics, got {self.kinematics!r}")
        if not isinstance(self.homing, HomingConfig):
            raise ValueError(f"SGFConfig.homing must be a HomingConfig, got {self.homing!r}")
        object.__setattr__(self, "homing", self.homing.resolved(self.kinematics.axes))
        if self.motion.planner == "bspline5":
            from transplanter.machine.spline_motion import spline_limits

            spline_limits(self.kinematics, self.motion)  # refuses an arm without joint limits
        self._check_steps_per_move()
        if not (math.isfinite(self.default_speed_m_s) and self.default_speed_m_s > 0):
            raise ValueError(
                f"SGFConfig.default_speed_m_s must be > 0, got {self.default_speed_m_s}"
            )
        if not (isinstance(self.command_queue_lines, int) and self.command_queue_lines >= 1):
            raise ValueError(
                f"SGFConfig.command_queue_lines must be an integer >= 1, "
                f"got {self.command_queue_lines!r}"
            )
        if not (
            isinstance(self.rx_buffer_bytes, int) and self.rx_buffer_bytes >= MAX_LINE_CHARS + 1
        ):
            raise ValueError(
                f"SGFConfig.rx_buffer_bytes must be an integer >= {MAX_LINE_CHARS + 1} (one "
                f"longest line and its newline), got {self.rx_buffer_bytes!r}"
            )
        if not (math.isfinite(self.conveyor_index_s) and self.conveyor_index_s >= 0):
            raise ValueError(
                f"SGFConfig.conveyor_index_s must be >= 0, got {self.conveyor_index_s}"
            )

    def _check_steps_per_move(self) -> None:
        """Refuse drives whose longest possible move (each axis across its whole window)
        needs more step pulses than a move may emit (motion.MAX_STEPS_PER_MOVE): the SGF
        could not hold such a move's step events."""
        axes = self.kinematics.axes
        spans = [hi - lo for lo, hi in (axis.window for axis in axes)]
        needed = [a.drive.steps_per_unit * span for a, span in zip(axes, spans, strict=True)]
        if sum(needed) <= MAX_STEPS_PER_MOVE:
            return
        worst = int(np.argmax(needed))
        drive = axes[worst].drive
        unit = "m of Z travel" if drive.linear else "rad of its motor window"
        raise ValueError(
            f"drive {drive.name!r} with steps_per_rev={drive.steps_per_rev} and "
            f"microsteps={drive.microsteps} needs {needed[worst]:.4g} step pulses across "
            f"{spans[worst]:.4g} {unit}; the {len(axes)} drives need {sum(needed):.4g} for a "
            f"move across the whole workspace, more than the {MAX_STEPS_PER_MOVE} step "
            "pulses one move may emit: lower steps_per_rev or microsteps"
        )

    @property
    def drives(self) -> tuple[StepperDrive, ...]:
        """The axes' drives, in motor order."""
        return self.kinematics.drives

    @property
    def n_axes(self) -> int:
        return self.kinematics.n_axes

    @property
    def home_joint_positions(self) -> tuple[float, ...]:
        """Joint positions (rad or m) at which the homing switches trip."""
        return tuple(float(q) for q in self.kinematics.home_joints)

    @property
    def homed_steps(self) -> np.ndarray:
        """Logical step counters after G28: the switch positions less the final pull-off."""
        return self.home_steps - np.asarray(self.homing.dirs) * np.asarray(
            self.homing.pulloff_steps
        )

    @property
    def home_steps(self) -> np.ndarray:
        """Logical step counters homing sets when each switch trips (nearest step)."""
        return self.kinematics.home_steps


@dataclass
class _Job:
    line: GcodeLine | GcodeError
    arrival: float
    t_start: float = math.nan
    t_done: float = math.nan
    replies: list[str] = field(default_factory=list)
    homing: Homing | None = None
    move: PlannedMove | None = None
    target_xyz: np.ndarray | None = None


class SGF:
    """The SGF state machine on a simulated clock (see the module docstring)."""

    def __init__(self, config: SGFConfig | None = None):
        self.config = config if config is not None else SGFConfig()
        self._queue: deque[_Job] = deque()
        self._rx: deque[tuple[str, float]] = deque()  # (line, arrival) waiting for a slot
        self._rx_bytes = 0
        self.rx_dropped = 0
        """Lines dropped because the command queue and the receive buffer were full."""
        self._current: _Job | None = None
        self._t_free = -math.inf
        self._now = -math.inf
        self._replies: list[str] = []
        self._servo_commands: list[tuple[float, int, float]] = []
        self._machine_events: list[tuple[float, str]] = []
        self._last_line_number = 0
        self._absolute = True
        self._speed_m_s = self.config.default_speed_m_s
        self._endstops: tuple[bool, ...] | None = None
        self.homed = False
        n = self.config.n_axes
        self._raw = np.zeros(n, dtype=np.int64)  # raw pulses once the last segment ended
        self._logical = np.zeros(n, dtype=np.int64)
        self._position = np.full(3, np.nan)
        # motion history for pulses_at: segment start times and evaluators
        self._segment_starts: list[float] = []
        self._segments: list = []
        self._segments_added = 0  # motion_version
        self._pending_stall: str | None = None  # a stall reply for the next line
        # bspline5 via transfers (M720): the via points (m) waiting for their G0, and the
        # servo commands (via index, servo, deg) that act when the spline passes that via
        self._vias: list[np.ndarray] = []
        self._via_servos: list[tuple[int, int, float]] = []
        self._via_nodes: list[int] = []
        self.killed_at: float | None = None
        """When an M112 stopped the machine; None once a G28 has homed it again."""
        self.stalls: list[tuple[float, int]] = []
        """(t, motor) of every stall that stopped the SGF."""
        # moves that cruised slower than their F asked: (asked m/s, why) -> [count, slowest]
        self._slowed: dict[tuple[float, str], list] = {}
        self.homing_trip_raw: np.ndarray | None = None
        """Raw pulse counts at which each switch was read closed by the last homing's locate."""

    # -- state -----------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        return self._current is not None or bool(self._queue)

    @property
    def motion_version(self) -> int | None:
        """A number that changes whenever `pulses_at` may answer a time differently than
        before (a move, a dwell's hold, a stall or a stop added to the motion history); None
        while a G28 runs (its legs change as the switches trip). A caller may keep
        `pulses_at`'s answers for a block of future times while it stays the same
        (`twin.loop.StepLoop`)."""
        return None if self.homing else self._segments_added

    @property
    def homing(self) -> bool:
        """True while a G28 is running (the simulator must poll every physics step, or
        at `homing_poll_time` and whenever a switch changes)."""
        return self._current is not None and self._current.homing is not None

    def speed_warnings(self) -> list[str]:
        """The moves that cruised slower than their F asked (the firmware obeys its limits
        without a word, as grbl does; a trial reports them): one line per speed and reason,
        with what it means (`SLOWED_MEANS`): a limit of the machine as configured, which the
        cycle already pays, never a fault."""
        return [
            f"{count} move{'s' if count > 1 else ''} asked for {asked / M_PER_MM:g} mm/s "
            f"cruised at {slowest / M_PER_MM:.1f} mm/s or less: {why}. {SLOWED_MEANS}"
            for (asked, why), (count, slowest) in sorted(self._slowed.items())
        ]

    def homing_poll_time(self, now: float, dt: float) -> float | None:
        """While homing, when the switches must be read next if none changes (at most one
        step of dt after any change of the homing's state); None when not homing."""
        if not self.homing:
            return None
        return self._current.homing.next_poll_time(now, dt)

    @property
    def position_xyz(self) -> np.ndarray:
        """Logical (x, y, z) in m after the last completed move; NaN before homing."""
        return self._position.copy()

    @property
    def logical_steps(self) -> np.ndarray:
        return self._logical.copy()

    @property
    def raw_pulses(self) -> np.ndarray:
        """Raw pulse counts once everything issued so far has been stepped."""
        return self._raw.copy()

    # -- input -----------------------------------------------------------------------
    def room_for(self, line: str) -> bool:
        """Whether ``receive`` would keep ``line`` (a free command-queue slot, or room in the
        receive buffer) rather than drop it with ``error:66``."""
        if len(self._queue) < self.config.command_queue_lines and not self._rx:
            return True
        return len(line) + 1 <= self.config.rx_buffer_bytes - self._rx_bytes

    def receive(self, line: str, now: float) -> None:
        """A line has arrived: parse it now (for line numbering), execute it in turn.

        With the command queue full it waits in the receive buffer and is parsed when a slot
        frees; with that full too it is dropped and answered ``error:66`` at once.
        """
        self._check_time(now)
        if not isinstance(line, str):
            raise TypeError(f"a received line is a str, got {type(line).__name__}")
        if is_emergency_stop(line):
            self._emergency_stop(line, now)
            return
        if len(self._queue) < self.config.command_queue_lines and not self._rx:
            self._enqueue(line, now)
            return
        if self.room_for(line):
            self._rx.append((line, now))
            self._rx_bytes += len(line) + 1  # and its newline
            return
        self.rx_dropped += 1
        self._replies.append(
            ErrorCode.RX_BUFFER_OVERFLOW.reply(
                f"receive buffer full ({self.config.command_queue_lines} queued lines, "
                f"{self._rx_bytes} of {self.config.rx_buffer_bytes} bytes waiting): a line of "
                f"{len(line)} characters was dropped; wait for ok before sending more"
            )
        )

    def _refill(self) -> None:
        """Move lines from the receive buffer into free command-queue slots, in order."""
        while self._rx and len(self._queue) < self.config.command_queue_lines:
            line, arrival = self._rx.popleft()
            self._rx_bytes -= len(line) + 1
            self._enqueue(line, arrival)

    def _enqueue(self, line: str, now: float) -> None:
        try:
            parsed = parse_line(
                line,
                expected_line_number=self._last_line_number + 1,
                require_checksum=self.config.require_checksum,
            )
        except GcodeError as error:
            parsed = error
        if parsed is None:
            return
        if parsed.line_number is not None:
            # a line whose checksum passed advances N, whatever its command's fate (Marlin)
            self._last_line_number = parsed.line_number
        self._queue.append(_Job(parsed, now))

    def _check_time(self, now: float) -> None:
        if not math.isfinite(now) or now < self._now:
            raise ValueError(f"time must be finite and non-decreasing: {now} after {self._now}")
        self._now = now

    # -- time ------------------------------------------------------------------------
    def poll(self, now: float, endstops: Sequence[bool] | None = None) -> list[str]:
        """Advance to ``now`` (switch states read at ``now``); return the replies due."""
        self._check_time(now)
        if endstops is not None:
            self._endstops = tuple(bool(e) for e in endstops)
        self._advance(now, endstops)
        replies, self._replies = self._replies, []
        return replies

    def _advance(self, now: float, endstops: Sequence[bool] | None, homing: bool = True) -> None:
        """Finish every line done by ``now`` and start the next ones; with ``homing`` False,
        stop at a running homing (its switches are not read)."""
        while True:
            if self._current is None:
                if not self._queue:
                    break
                job = self._queue.popleft()
                self._refill()
                self._start(job, max(job.arrival, self._t_free))
                self._current = job
            job = self._current
            if job.homing is not None:
                if not homing:
                    break
                self._update_homing(job, now, endstops)
            if math.isfinite(job.t_done) and job.t_done <= now:
                self._finish(job)
                continue
            break

    def next_event_time(self) -> float | None:
        """When the running line completes (None if idle or still seeking switches)."""
        if self._current is not None:
            return self._current.t_done if math.isfinite(self._current.t_done) else None
        if self._queue:
            return max(self._queue[0].arrival, self._t_free)
        return None

    def pulses_at(self, times) -> np.ndarray:
        """Raw pulse counts of the motors at each time, shape (n, n_axes) int64."""
        times = np.atleast_1d(np.asarray(times, dtype=np.float64))
        out = np.zeros((times.size, self.config.n_axes), dtype=np.int64)
        if not self._segments:
            return out
        index = np.searchsorted(np.asarray(self._segment_starts), times, side="right") - 1
        for segment in np.unique(index):
            if segment < 0:
                continue
            mask = index == segment
            out[mask] = self._segments[segment](times[mask])
        return out

    def forget_before(self, t: float) -> int:
        """Drop the motion history that ``pulses_at`` no longer needs for times >= ``t``.

        Keeps the last segment that starts at or before ``t`` and everything after it, so
        ``pulses_at`` answers as before for every time >= ``t`` (earlier times are no longer
        valid). A caller whose clock only moves forward (the planner, the simulator) calls
        this to keep memory constant per move. Returns how many segments were dropped.
        """
        starts = self._segment_starts
        keep_from = int(np.searchsorted(np.asarray(starts), t, side="right")) - 1
        if keep_from <= 0:
            return 0
        del self._segment_starts[:keep_from]
        del self._segments[:keep_from]
        return keep_from

    def stall(self, now: float, motor: int) -> None:
        """A driver reports that ``motor`` (0 .. n_axes - 1) stalled at ``now``: stop everything
        (ignored while the position is unknown and no homing runs: already stopped).

        The motors hold the pulse counts they had at ``now``; the running line ends with
        ``error:67`` and so does every line waiting in the queue or the receive buffer (each
        line still gets exactly one reply, in order); the position is unknown until ``G28``.
        """
        self._check_time(now)
        if motor not in range(self.config.n_axes):
            raise ValueError(f"motor must be 0 .. {self.config.n_axes - 1}, got {motor!r}")
        if not (self.homed or self.homing):
            return  # already stopped, or never homed: nothing runs that a stall could stop
        self.stalls.append((now, motor))
        self._clear_vias()
        held = self.pulses_at(now)[0]
        self._add_segment(now, lambda t: np.broadcast_to(held, (np.size(t), held.size)).copy())
        self._raw = held.copy()
        self.homed = False
        self._position[:] = np.nan
        message = ErrorCode.MOTOR_STALLED.reply(
            f"motor {motor + 1} stalled at t={now:.3f} s: motion stopped, position lost; "
            "home with G28"
        )
        self._machine_events.append((now, "stalled"))
        job = self._current
        if job is None:
            self._pending_stall = message
        else:
            job.move, job.homing, job.t_done = None, None, now
            job.replies = [message]
            self._finish(job)
        for _ in self._queue:
            self._replies.append(message)
        for _ in self._rx:
            self._replies.append(message)
        self._queue.clear()
        self._rx.clear()
        self._rx_bytes = 0

    def _emergency_stop(self, line: str, now: float) -> None:
        """M112 has arrived (``receive``): stop now, ahead of every queued line."""
        if not self.homing:  # lines done by now are answered first, as they were done
            self._advance(now, None, homing=False)
        try:  # a framed M112 whose framing passes counts its line number (Marlin)
            parsed = parse_line(
                line,
                expected_line_number=self._last_line_number + 1,
                require_checksum=self.config.require_checksum,
            )
            if parsed is not None and parsed.line_number is not None:
                self._last_line_number = parsed.line_number
        except GcodeError:
            pass  # a stop is never refused for its framing
        job = self._current
        running = [] if job is None else [job]
        if job is not None:
            job.move, job.homing, job.t_done = None, None, now
            job.replies = [
                ErrorCode.EMERGENCY_STOP.reply(
                    f"{job.line.command} stopped by the emergency stop (M112) at t={now:.3f} s"
                    if isinstance(job.line, GcodeLine)
                    else f"not run: emergency stop (M112) at t={now:.3f} s"
                )
            ]
        replies = self._stop_everything(now, running)
        if job is not None:
            self._finish(job)
        self._replies.extend(replies)

    def _stop_everything(self, now: float, running: list | None = None) -> list[str]:
        """Marlin's kill(): every motor holds where it is at ``now``, every queued or buffered
        line is flushed, the position is kept as far as the steps tell (the drivers never
        lost one) but the machine is not homed and motion is refused until a G28. Returns the
        replies of the flushed lines and then the stop's own, in line order (the running
        line, ``running``, is the caller's to answer first)."""
        held = self.pulses_at(now)[0]
        if self.homed and not self.homing:  # the steps since the last segment ended
            self._logical = self._logical + (held - self._raw)
            self._position = self.config.kinematics.point_of_steps(self._logical)
        else:
            self._position[:] = np.nan
        self._add_segment(now, lambda t: np.broadcast_to(held, (np.size(t), held.size)).copy())
        self._raw = held.copy()
        self.homed = False
        self.killed_at = now
        self._pending_stall = None
        self._clear_vias()
        self._machine_events.append((now, "emergency_stop"))
        flushed = len(self._queue) + len(self._rx)
        replies = [
            ErrorCode.EMERGENCY_STOP.reply(f"not run: emergency stop (M112) at t={now:.3f} s")
        ] * flushed
        self._queue.clear()
        self._rx.clear()
        self._rx_bytes = 0
        stopped = "a line" if running else "nothing"
        replies.append(
            ErrorCode.EMERGENCY_STOP.reply(
                f"Printer halted. kill() called! Emergency stop (M112) at t={now:.3f} s: "
                f"every motor stopped where it was ({stopped} running), {flushed} queued "
                f"line{'' if flushed == 1 else 's'} flushed; motion refused until G28"
            )
        )
        return replies

    def drain_servo_commands(self) -> list[tuple[float, int, float]]:
        """(t, servo index, angle deg) commanded since the last drain."""
        out, self._servo_commands = self._servo_commands, []
        return out

    def drain_machine_events(self) -> list[tuple[float, str]]:
        """(t, name) events since the last drain: 'conveyor_index', 'homed', 'homing_failed',
        'stalled'."""
        out, self._machine_events = self._machine_events, []
        return out

    # -- execution -------------------------------------------------------------------
    def _add_segment(self, t0: float, evaluator) -> None:
        self._segment_starts.append(t0)
        self._segments.append(evaluator)
        self._segments_added += 1

    def _start(self, job: _Job, t0: float) -> None:
        job.t_start = t0
        job.t_done = t0
        line = job.line
        if isinstance(line, GcodeError):
            job.replies = [line.reply]
            return
        command, words = line.command, line.words
        if command == "M112":  # not caught on arrival (a comment before it): a stop in its turn
            *flushed, own = self._stop_everything(t0)
            job.replies = [own, *flushed]  # its own reply, then the lines after it
            return
        if self.killed_at is not None and command in _MOTION_COMMANDS:
            job.replies = [
                ErrorCode.EMERGENCY_STOP.reply(
                    f"{command} refused: the machine was halted by M112 at "
                    f"t={self.killed_at:.3f} s; home with G28 first"
                )
            ]
            return
        if self._pending_stall is not None:
            message, self._pending_stall = self._pending_stall, None
            if command != "G28":
                job.replies = [message]
                return
        try:
            if self._vias and command in _AFTER_VIAS_REFUSED:
                count = len(self._vias)
                self._clear_vias()
                raise GcodeError(
                    ErrorCode.MODAL_GROUP_VIOLATION,
                    f"{command} after {count} M720 via point{'s' if count > 1 else ''}: via "
                    "points are passed by the next G0 transfer; send that G0 first (the via "
                    "points are dropped)",
                )
            if command == "G28":
                self._clear_vias()
            if command in ("G0", "G1"):
                self._start_move(job, command, words)
            elif command == "G4":
                job.t_done = t0 + words["P"] * S_PER_MS
            elif command == "G28":
                job.homing = Homing(self.config.homing, self.config.kinematics.axes, t0, self._raw)
                self._add_segment(t0, job.homing.pulses)
                job.t_done = math.nan
                job.replies = ["ok"]
                return
            elif command == "G90":
                self._absolute = True
            elif command == "G91":
                self._absolute = False
            elif command == "M280":
                if self._vias:  # acts where the transfer passes the last via point
                    via = len(self._vias) - 1
                    self._via_servos.append((via, int(words["P"]), float(words["S"])))
                else:
                    self._servo_commands.append((t0, int(words["P"]), float(words["S"])))
            elif command == "M720":
                self._add_via(words)
            elif command == "M710":
                self._machine_events.append((t0, "conveyor_index"))
                job.t_done = t0 + self.config.conveyor_index_s
            elif command == "M114":
                job.replies.append(self._position_report())
            elif command == "M119":
                job.replies.append(self._endstop_report())
            # M400, M105: nothing to do, the FIFO already finished what came before
        except GcodeError as error:
            job.t_done = t0
            job.replies = [error.reply]
            self._clear_vias()  # a refused line drops the via points waiting for a G0
            return
        job.replies.append("ok")

    def _start_move(self, job: _Job, command: str, words: dict[str, float]) -> None:
        if not self.homed:
            raise GcodeError(ErrorCode.SYSTEM_LOCKED, "position unknown: home first with G28")
        kinematics = self.config.kinematics
        target = self._position.copy()
        for axis, letter in enumerate(kinematics.coordinates):
            if letter in words:
                value = words[letter] * M_PER_MM
                target[axis] = value if self._absolute else target[axis] + value
        speed_m_s = self._speed_m_s  # modal: committed only once the move is accepted
        if "S" in words:
            speed_m_s = words["S"] * M_PER_MM
        elif "F" in words:
            speed_m_s = words["F"] * MM_PER_MIN_TO_M_S
        refusal = kinematics.limit_target(target)
        if refusal is not None:
            raise GcodeError(ErrorCode.INVALID_TARGET, refusal.text())
        switches = self._endstops or ()
        for axis, switch in kinematics.lower_hard_limits:
            if target[axis] < self._position[axis] and len(switches) > switch and switches[switch]:
                raise GcodeError(ErrorCode.LIMIT_SWITCH_CLOSED, self._hard_limit(axis, switch))
        config = self.config
        try:
            move = None
            if command == "G0" and (self._vias or self.spline_transfer(self._position, target)):
                move = self._plan_transfer(target)  # None: every via point is where it is
            if move is None:
                move = plan_line(
                    self._logical, self._position, target, speed_m_s, kinematics, config.motion
                )
        except GcodeError:
            raise
        except UnreachableError as error:
            shown = ", ".join(show(v / M_PER_MM) for v in target)
            raise GcodeError(
                ErrorCode.INVALID_TARGET,
                f"target position not reachable: {error.reason} "
                f"(move to ({shown}) mm, interpolated point {error.index})",
            ) from None
        except ValueError as error:
            raise GcodeError(ErrorCode.INVALID_TARGET, f"move refused: {error}") from None
        if not move.duration_s <= MAX_MOVE_S:
            raise GcodeError(
                ErrorCode.VALUE_OUT_OF_RANGE, self._too_slow(command, words, speed_m_s, move)
            )
        self._speed_m_s = speed_m_s
        if move.speed_limit:
            seen = self._slowed.setdefault((speed_m_s, move.speed_limit), [0, math.inf])
            seen[0] += 1
            seen[1] = min(seen[1], move.cruise_speed_m_s)
        job.move = move
        job.target_xyz = target
        job.t_done = job.t_start + move.duration_s
        if self._via_servos:  # each at the time the spline passes its via point
            node_times = [0.0]
            if move.spline_plan is not None:
                node_times += [float(t) for t in np.cumsum(move.spline_plan.intervals_s)]
            for via, servo, deg in self._via_servos:
                node = self._via_nodes[via + 1] if move.spline_plan is not None else 0
                self._servo_commands.append((job.t_start + node_times[node], servo, deg))
        self._clear_vias()
        t0, t_done = job.t_start, job.t_done
        raw0 = self._raw.copy()
        start_steps = move.start_steps.copy()

        def evaluate(t: np.ndarray) -> np.ndarray:
            # (t0 + duration) - t0 can round below duration: at the ack every step is out.
            rel = np.where(t >= t_done, move.duration_s, t - t0)
            return raw0 + (move.steps_at(rel) - start_steps)

        self._add_segment(t0, evaluate)

    def _clear_vias(self) -> None:
        self._vias = []
        self._via_servos = []

    def _add_via(self, words: dict[str, float]) -> None:
        """``M720 X Y Z``: a via point of the next ``G0`` transfer (``motion.planner =
        "bspline5"`` on an arm with via transfers, homed); coordinates as a move's target
        (absolute or relative to the last via point, the words left out kept)."""
        from transplanter.machine.spline_motion import via_transfers

        kinematics = self.config.kinematics
        if self.config.motion.planner != "bspline5" or not via_transfers(kinematics):
            raise GcodeError(
                ErrorCode.UNSUPPORTED_COMMAND,
                "M720 (a via point of a spline transfer) needs motion.planner = 'bspline5' on "
                f"an arm with via transfers (the five-bar); this is {kinematics.kind!r} with "
                f"planner {self.config.motion.planner!r}",
            )
        if not self.homed:
            raise GcodeError(ErrorCode.SYSTEM_LOCKED, "position unknown: home first with G28")
        base = self._vias[-1] if self._vias else self._position
        via = base.copy()
        for axis, letter in enumerate(kinematics.coordinates):
            if letter in words:
                value = words[letter] * M_PER_MM
                via[axis] = value if self._absolute else via[axis] + value
        refusal = kinematics.limit_target(via)
        if refusal is not None:
            raise GcodeError(ErrorCode.INVALID_TARGET, f"M720 via point: {refusal.text()}")
        self._vias.append(via)

    def spline_transfer(self, start, target) -> bool:
        """Whether a G0 from ``start`` to ``target`` (m) is a spline transfer: under
        ``motion.planner = "bspline5"``, unless it has no horizontal travel (a pick path turns
        towards its target), which moves as a line."""
        if self.config.motion.planner != "bspline5":
            return False
        return bool(np.hypot(*(np.asarray(target)[:2] - np.asarray(start)[:2])) >= 1e-6)

    def _transfer_points(self, target: np.ndarray) -> np.ndarray:
        """The distinct points of a via transfer: where the arm is, the via points, the
        target, each within 1 um of the one before merged into the later one (the start
        kept exact); ``_via_nodes[i]`` is the node point i became (0 the start)."""
        kept, nodes = [self._position], [0]
        for p in [*self._vias, target]:
            if np.linalg.norm(p - kept[-1]) >= 1e-6:
                kept.append(p)
            elif len(kept) > 1:
                kept[-1] = p
            nodes.append(len(kept) - 1)
        self._via_nodes = nodes
        return np.vstack(kept)

    def _plan_transfer(self, target: np.ndarray) -> PlannedMove | None:
        # imported here: scipy's optimiser is only loaded by a machine that runs splines
        from transplanter.machine.planner_bspline import MoveRefused
        from transplanter.machine.spline_motion import (
            plan_spline_move,
            plan_via_transfer,
            via_transfers,
        )

        kinematics, motion = self.config.kinematics, self.config.motion
        try:
            if via_transfers(kinematics):
                points = self._transfer_points(target)
                if len(points) < 2:
                    return None
                return plan_via_transfer(self._logical, points, kinematics, motion)
            return plan_spline_move(self._logical, self._position, target, kinematics, motion)
        except MoveRefused as error:
            shown = ", ".join(show(v / M_PER_MM) for v in target)
            raise GcodeError(
                ErrorCode.INVALID_TARGET,
                f"G0 transfer to ({shown}) mm refused before it starts ({error.limit}): {error}",
            ) from None

    def _too_slow(
        self, command: str, words: dict[str, float], speed_m_s: float, move: PlannedMove
    ) -> str:
        """Why a move longer than MAX_MOVE_S is refused: its speed word, the bound and the
        slowest speed of that word that would do (2 digits, rounded up, 1 % to spare)."""
        if "S" in words:
            letter, per_unit, unit = "S", M_PER_MM, "mm/s"
            head = f"{command} S{format_number(words['S'])}"
        else:
            letter, per_unit, unit = "F", MM_PER_MIN_TO_M_S, "mm/min"
            head = f"{command} F{format_number(words['F'])}" if "F" in words else command
        asked = speed_m_s / per_unit
        needed = asked * move.duration_s / MAX_MOVE_S * 1.01
        hint = f"give a {letter} word"
        if math.isfinite(needed) and needed > 0:
            step = 10.0 ** (math.floor(math.log10(needed)) - 1)
            hint = f"give {letter}{format_number(math.ceil(needed / step) * step)} or more"
        length_mm = float(np.linalg.norm(move.end_xyz - move.start_xyz)) / M_PER_MM
        modal = "" if letter in words else " (the modal speed)"
        return (
            f"{head}: at {asked:.3g} {unit}{modal} this {length_mm:.1f} mm move would take "
            f"{move.duration_s:.3g} s, longer than the {MAX_MOVE_S:g} s a move may take; {hint}"
        )

    def _update_homing(self, job: _Job, now: float, endstops: Sequence[bool] | None) -> None:
        homing = job.homing
        if homing.done_seeking:
            return
        failure = homing.update(now, endstops)
        if failure is not None:
            job.replies = [homing.failure_code.reply(f"homing failed: {failure}")]
            self.homed = False
            self._position[:] = np.nan
            self._machine_events.append((now, "homing_failed"))
        if homing.done_seeking:
            job.t_done = homing.t_done

    def _finish(self, job: _Job) -> None:
        t = job.t_done
        if job.homing is not None:
            homing = job.homing
            self._raw = homing.pulses(np.array([t]))[0]
            if not homing.failed:
                self.homing_trip_raw = homing.trip_raw.copy()
                self._logical = self.config.homed_steps
                self._position = self.config.kinematics.point_of_steps(self._logical)
                self.homed = True
                self.killed_at = None
                self._machine_events.append((t, "homed"))
        elif job.move is not None:
            self._raw = self._raw + (job.move.end_steps - job.move.start_steps)
            self._logical = job.move.end_steps.copy()
            self._position = job.target_xyz.copy()
        self._replies.extend(job.replies)
        self._t_free = t
        self._current = None

    def _hard_limit(self, axis: int, switch: int) -> str:
        letter = self.config.kinematics.coordinates[axis]
        trip = self.config.kinematics.axes[axis].window[0]
        return (
            f"limit switch {switch + 1} ({letter} down) reads closed at {letter} "
            f"{self._position[axis] / M_PER_MM:.3f} mm, above its trip point at "
            f"{trip / M_PER_MM:.3f} mm: the switch is stuck closed or its wiring is shorted "
            f"(M119 shows it TRIGGERED), or {letter} lost steps downwards; {letter} will not "
            "move down. Check the switch and its wiring, then home with G28"
        )

    def _position_report(self) -> str:
        coords = (f"{v / M_PER_MM:.3f}".replace("-0.000", "0.000") for v in self._position)
        letters = self.config.kinematics.coordinates
        shown = [f"{c}:{v}" for c, v in zip(letters, coords, strict=True)]
        shown += [f"{chr(ord('A') + m)}:{int(s)}" for m, s in enumerate(self._logical)]
        return " ".join(shown)

    def _endstop_report(self) -> str:
        if self._endstops is None:
            return "endstops: unknown"
        states = " ".join(
            f"{i + 1}:{'TRIGGERED' if s else 'open'}" for i, s in enumerate(self._endstops)
        )
        return f"endstops: {states}"
