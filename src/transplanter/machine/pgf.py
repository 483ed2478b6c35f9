"""Position generation firmware (PGF): the paper's Algorithm 2 as a state machine.

The PGF reads the taught points from the EEPROM image and sends one G-code line at a time,
waiting for the SGF's ``ok`` (the paper's handshake) before the next. An ``error:`` reply
stops it (``fault``). Coordinates go out in mm with 3 decimals; the ``S`` word of ``G1`` is
the paper's speed word in mm/s; ``G4 P`` is in ms; ``M280 S`` in degrees.

Per seedling i (pickup c = i mod M_pp) the lines and their phases are::

    G1 X<approach> Y<approach> Z<z_low> S<s_high>      approach
    M280 P<wrist> S<elbow_c>                           elbow
    M280 P<gripper> S<open>                            open
    G4 P<open_dwell>                                   open_wait
    G1 X<grip> Y<grip> Z<z_low> S<s_low>               grip
    M280 P<gripper> S<close>                           close
    G4 P<close_dwell>                                  close_wait
    G1 X<grip> Y<grip> Z<z_up> S<s_low>                lift
    G1 X<approach> Y<approach> Z<z_up> S<s_high>       retract
    M280 P<wrist> S<drop_elbow>                        drop_elbow
    G1 X<drop> Y<drop> Z<z_up> S<s_high>               to_drop
    M280 P<gripper> S<open>                            release
    G4 P<release_dwell>                                release_wait
    M710                                               index (after the row's last pickup)

With ``PGFConfig.spline_transfer`` (``motion.planner = "bspline5"`` on the five-bar) the
retract line is ``M720 X<approach> Y<approach> Z<z_up>`` (a via point) and the to_drop line
``G0 X<drop> Y<drop> Z<z_up>``: the SGF moves from the lifted grip point through the retract
point to the drop point on one quintic B-spline, the wrist turning where it passes the
retract point; every other line is the same.

The program is framed by ``G28`` (home), ``G90`` (absolute), the wrist to M_dep and a move
to the drop point (the cycle's initial position, paper section 1.2) at the start, and
``M400`` (finish) at the end.

Stall recovery (``PGFConfig.stall_recovery``, off on the paper's machine): an ``error:67``
(a motor stalled, the SGF stopped) does not stop the PGF. It waits for the arm to settle
(``G4``), sends ``G28`` and a move back to the drop point (phases ``stall_settle``,
``stall_rehome``, ``stall_to_start``), then goes on from where the
seedling can be saved: before the gripper closed, the seedling's cycle again from its
approach; with the gripper closed (the pot may be in the jaws), from ``drop_elbow`` (carry
it to the tube and release); otherwise the refused line again. A seedling that stalls
more than ``stall_retries`` times is given up (``abandoned``): after the re-home the PGF
goes on with its conveyor index, if any, and the next seedling. A stall outside any
seedling's cycle beyond the retries, or one more stall of a seedling already given up (the
machine cannot even re-home: a jam), stops the PGF with a fault.

Reply timeout (``PGFConfig.reply_timeout_s``): every line the PGF sends or receives restarts
a timer; when it runs out with a line outstanding (its reply was lost on the wire, or the
SGF is dead) the PGF stops with the fault ``bus timeout: no reply to line <n> ...``.
``next_event_time`` tells the caller when that is due. ``fault_kind`` names why the PGF
stopped (``machine.faults.FaultKind``): from the code of the refused line's reply, or
``bus_timeout``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from enum import StrEnum

from transplanter.errors import ErrorCode
from transplanter.machine.eeprom import EepromImage
from transplanter.machine.faults import FaultKind, kind_of_reply
from transplanter.machine.gcode import SERVO_INDICES, SERVO_MAX_DEG, format_line, valid_servo_angle
from transplanter.units import M_PER_MM, S_PER_MS


@dataclass(frozen=True)
class PGFConfig:
    """Servo wiring and timing of the pick-and-place cycle, and how many seedlings to plant."""

    gripper_servo: int = 0
    wrist_servo: int = 1
    gripper_open_deg: float = 155.0
    gripper_close_deg: float = 60.0
    open_dwell_s: float = 0.20
    close_dwell_s: float = 0.25
    release_dwell_s: float = 0.20
    seedlings: int = 40
    index_conveyor: bool = True
    line_numbers: bool = True
    """Marlin ``N<n> ... *<checksum>`` framing on every line."""
    rehome_every_cycles: int = 0
    """Re-home (G28, back to the drop point) before every N-th cycle after the first N; 0:
    never, as the paper's open-loop machine. The lines belong to that seedling's cycle."""
    stall_recovery: bool = False
    """On an ``error:67`` stall reply re-home and retry (module docstring); False: a stall
    stops the PGF like any refused line."""
    stall_retries: int = 3
    """Stalls one seedling's cycle may recover from; one more and the seedling is given up."""
    stall_settle_s: float = 0.3
    """Dwell before the re-home after a stall: the arm, knocked off position, comes to rest
    against the holding motors first (a re-home into a swinging arm stalls again)."""
    reply_timeout_s: float = 30.0
    """The PGF stops with a bus timeout when nothing comes back from the SGF for this long
    while a line is outstanding; longer than the longest line (a worst-case homing, the
    longest move, dwell or conveyor index: checked by ``preflight.check_machine``)."""
    spline_transfer: bool = False
    """``motion.planner = "bspline5"`` on an arm with via transfers (the five-bar): the
    retract point goes out as a via point (``M720 X Y Z``, phase ``retract``) and the move to
    the drop point as ``G0`` without a speed word (``to_drop``), so the SGF runs them as one
    quintic B-spline from the lifted grip point through the retract point to the drop point,
    the wrist's ``drop_elbow`` acting where it passes the retract point. False: every move a
    ``G1`` line, the paper's program."""

    def __post_init__(self):
        for name in ("gripper_servo", "wrist_servo"):
            if getattr(self, name) not in SERVO_INDICES:
                raise ValueError(f"{name} must be one of {SERVO_INDICES}")
        if self.gripper_servo == self.wrist_servo:
            raise ValueError("gripper_servo and wrist_servo must be different servos")
        for name in ("gripper_open_deg", "gripper_close_deg"):
            value = getattr(self, name)
            if not valid_servo_angle(value):
                raise ValueError(
                    f"{name} = {value} is outside the servo range 0-{SERVO_MAX_DEG:g} deg"
                )
        if not (math.isfinite(self.reply_timeout_s) and self.reply_timeout_s > 0):
            raise ValueError(f"reply_timeout_s = {self.reply_timeout_s} s must be > 0")
        for name in ("open_dwell_s", "close_dwell_s", "release_dwell_s", "stall_settle_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} = {value} s must be >= 0")
        if isinstance(self.seedlings, bool) or not isinstance(self.seedlings, int):
            raise ValueError(f"seedlings must be an int, got {self.seedlings!r}")
        if self.seedlings < 1:
            raise ValueError(f"seedlings = {self.seedlings}: plant at least one")
        if isinstance(self.rehome_every_cycles, bool) or not (
            isinstance(self.rehome_every_cycles, int) and self.rehome_every_cycles >= 0
        ):
            raise ValueError(
                f"rehome_every_cycles must be a whole number >= 0, got {self.rehome_every_cycles!r}"
            )
        if isinstance(self.stall_retries, bool) or not (
            isinstance(self.stall_retries, int) and self.stall_retries >= 1
        ):
            raise ValueError(
                f"stall_retries must be a whole number >= 1, got {self.stall_retries!r}"
            )


class LinePhase(StrEnum):
    """What a program line does in the cycle (the phases of the module docstring).

    A StrEnum: each member equals its lower-case name as a str (``LinePhase.CLOSE ==
    "close"``) and formats as it.
    """

    HOME = "home"
    ABSOLUTE = "absolute"
    START_ELBOW = "start_elbow"
    TO_START = "to_start"
    APPROACH = "approach"
    ELBOW = "elbow"
    OPEN = "open"
    OPEN_WAIT = "open_wait"
    GRIP = "grip"
    CLOSE = "close"
    CLOSE_WAIT = "close_wait"
    LIFT = "lift"
    RETRACT = "retract"
    DROP_ELBOW = "drop_elbow"
    TO_DROP = "to_drop"
    RELEASE = "release"
    RELEASE_WAIT = "release_wait"
    INDEX = "index"
    REHOME = "rehome"  # recovery: G28 inside a cycle (PGFConfig.rehome_every_cycles)
    REHOME_TO_START = "rehome_to_start"  # back to the drop point after it
    STALL_SETTLE = "stall_settle"  # recovery: a dwell after a stall (PGFConfig.stall_recovery)
    STALL_REHOME = "stall_rehome"  # recovery: G28 after a stall (PGFConfig.stall_recovery)
    STALL_TO_START = "stall_to_start"  # back to the drop point after it
    FINISH = "finish"
    HOST = "host"  # a line from an external host that is not the taught program's next line


@dataclass(frozen=True)
class ProgramLine:
    """One line of the PGF's program, before it is sent."""

    seedling: int | None
    phase: LinePhase
    text: str
    command: str = ""
    words: dict = dataclasses.field(default_factory=dict)


# Where a seedling's cycle resumes after a stall in each phase (module docstring).
_RETRY_FROM_APPROACH = frozenset(
    {
        LinePhase.REHOME, LinePhase.REHOME_TO_START, LinePhase.APPROACH, LinePhase.ELBOW,
        LinePhase.OPEN, LinePhase.OPEN_WAIT, LinePhase.GRIP,
    }
)  # fmt: skip
_RESUME_AT_DROP = frozenset(
    {
        LinePhase.CLOSE, LinePhase.CLOSE_WAIT, LinePhase.LIFT, LinePhase.RETRACT,
        LinePhase.DROP_ELBOW, LinePhase.TO_DROP,
    }
)  # fmt: skip


@dataclass(frozen=True)
class SentLine:
    """A line the PGF sent, with the SGF's reply once it came."""

    seedling: int | None
    phase: LinePhase
    text: str
    t_sent: float
    t_reply: float | None = None
    reply: str | None = None


class LineEventKind(StrEnum):
    SENT = "sent"  # the PGF put the line on the bus
    DONE = "done"  # its reply reached the PGF


@dataclass
class LineEvent:
    """A PGF line was sent or its reply arrived: what trials and the pot line's judge watch
    (`twin.judge.Judge.on_line`)."""

    line: SentLine
    t: float
    kind: LineEventKind


def _mm(value_m: float) -> float:
    return value_m / M_PER_MM


def _ms(value_s: float) -> float:
    return value_s / S_PER_MS


def build_program(eeprom: EepromImage, config: PGFConfig) -> tuple[ProgramLine, ...]:
    """Every line the PGF will send, in order (Algorithm 2 unrolled)."""
    open_deg, close_deg = config.gripper_open_deg, config.gripper_close_deg
    gripper, wrist = config.gripper_servo, config.wrist_servo
    z_low, z_up = _mm(eeprom.z_low_m), _mm(eeprom.z_up_m)
    s_low, s_high = _mm(eeprom.s_low_m_s), _mm(eeprom.s_high_m_s)
    drop_x, drop_y = (_mm(v) for v in eeprom.drop_xy_m)
    # The drop point is the cycle's initial position (paper 1.2): go there once after homing.
    lines: list[tuple[int | None, LinePhase, str, dict]] = [
        (None, LinePhase.HOME, "G28", {}),
        (None, LinePhase.ABSOLUTE, "G90", {}),
        (None, LinePhase.START_ELBOW, "M280", {"P": wrist, "S": eeprom.drop_wrist_deg}),
        (None, LinePhase.TO_START, "G1", {"X": drop_x, "Y": drop_y, "Z": z_up, "S": s_high}),
    ]

    for seedling in range(config.seedlings):
        pickup_index = seedling % eeprom.m_pp
        pickup = eeprom.pickups[pickup_index]
        ax, ay = (_mm(v) for v in pickup.approach_xy_m)
        gx, gy = (_mm(v) for v in pickup.grip_xy_m)
        if config.spline_transfer:  # one spline through the retract point (docstring)
            retract = (LinePhase.RETRACT, "M720", {"X": ax, "Y": ay, "Z": z_up})
            to_drop = (LinePhase.TO_DROP, "G0", {"X": drop_x, "Y": drop_y, "Z": z_up})
        else:
            retract = (LinePhase.RETRACT, "G1", {"X": ax, "Y": ay, "Z": z_up, "S": s_high})
            to_drop = (LinePhase.TO_DROP, "G1", {"X": drop_x, "Y": drop_y, "Z": z_up, "S": s_high})
        every = config.rehome_every_cycles
        rehome = every and seedling and seedling % every == 0
        cycle = [
            (LinePhase.REHOME, "G28", {}),
            (LinePhase.REHOME_TO_START, "G1", {"X": drop_x, "Y": drop_y, "Z": z_up, "S": s_high}),
        ] if rehome else []  # fmt: skip
        cycle += [
            (LinePhase.APPROACH, "G1", {"X": ax, "Y": ay, "Z": z_low, "S": s_high}),
            (LinePhase.ELBOW, "M280", {"P": wrist, "S": pickup.wrist_deg}),
            (LinePhase.OPEN, "M280", {"P": gripper, "S": open_deg}),
            (LinePhase.OPEN_WAIT, "G4", {"P": _ms(config.open_dwell_s)}),
            (LinePhase.GRIP, "G1", {"X": gx, "Y": gy, "Z": z_low, "S": s_low}),
            (LinePhase.CLOSE, "M280", {"P": gripper, "S": close_deg}),
            (LinePhase.CLOSE_WAIT, "G4", {"P": _ms(config.close_dwell_s)}),
            (LinePhase.LIFT, "G1", {"X": gx, "Y": gy, "Z": z_up, "S": s_low}),
            retract,
            (LinePhase.DROP_ELBOW, "M280", {"P": wrist, "S": eeprom.drop_wrist_deg}),
            to_drop,
            (LinePhase.RELEASE, "M280", {"P": gripper, "S": open_deg}),
            (LinePhase.RELEASE_WAIT, "G4", {"P": _ms(config.release_dwell_s)}),
        ]
        more_follow = seedling < config.seedlings - 1
        if config.index_conveyor and pickup_index == eeprom.m_pp - 1 and more_follow:
            cycle.append((LinePhase.INDEX, "M710", {}))
        lines.extend((seedling, phase, command, words) for phase, command, words in cycle)
    lines.append((None, LinePhase.FINISH, "M400", {}))

    program = []
    for number, (seedling, phase, command, words) in enumerate(lines, start=1):
        text = format_line(command, words, line_number=number if config.line_numbers else None)
        program.append(ProgramLine(seedling, phase, text, command, words))
    return tuple(program)


class PGF:
    """Sends the program one line at a time, each after the previous line's ``ok``."""

    def __init__(self, eeprom: EepromImage, config: PGFConfig | None = None):
        self.eeprom = eeprom
        self.config = config if config is not None else PGFConfig()
        self.program = build_program(eeprom, self.config)
        self.sent: list[SentLine] = []
        self.info: list[tuple[float, str]] = []
        """Replies that are neither ``ok`` nor ``error:`` (position reports, echoes)."""
        self.stalls: list[tuple[float, SentLine]] = []
        """(t, the line the stall reply answered) of every stall recovered from."""
        self.abandoned: list[int] = []
        """Seedlings given up after ``stall_retries`` recoveries (their cycle was skipped)."""
        self._fault: str | None = None
        self._fault_kind: FaultKind | None = None
        self._deadline = math.inf  # the reply timeout of the outstanding line
        self._outstanding = False
        self._cursor = 0  # next program line
        self._detour: list[ProgramLine] = []  # recovery lines to send before it
        self._outstanding_index: int | None = None  # program index of the outstanding line
        self._resume_index = 0
        self._stalls_per_seedling: dict[int | None, int] = {}

    @property
    def fault(self) -> str | None:
        """Why the PGF stopped, or None."""
        return self._fault

    @property
    def fault_kind(self) -> FaultKind | None:
        """What stopped the PGF (``FaultKind``), or None."""
        return self._fault_kind

    def _stop(self, kind: FaultKind, message: str) -> None:
        self._fault, self._fault_kind = message, kind

    def next_event_time(self) -> float | None:
        """When the outstanding line's reply times out; None with no line outstanding."""
        if self._fault is not None or not self._outstanding:
            return None
        return self._deadline

    @property
    def current(self) -> SentLine | None:
        """The line waiting for its reply, or None."""
        return self.sent[-1] if self._outstanding else None

    @property
    def done(self) -> bool:
        """Every line sent and acknowledged."""
        return (
            self._fault is None
            and not self._outstanding
            and not self._detour
            and self._cursor >= len(self.program)
        )

    def _close_current(self, now: float, reply: str) -> None:
        self.sent[-1] = dataclasses.replace(self.sent[-1], t_reply=now, reply=reply)
        self._outstanding = False

    def _recover(self, now: float, reply: str) -> bool:
        """Plan the way back after a stall reply to the outstanding line; False: give up."""
        line = self.sent[-1]
        count = self._stalls_per_seedling.get(line.seedling, 0) + 1
        self._stalls_per_seedling[line.seedling] = count
        give_up = count > self.config.stall_retries
        if give_up and (line.seedling is None or line.seedling in self.abandoned):
            return False
        self.stalls.append((now, line))
        index = self._outstanding_index
        if give_up:  # this seedling keeps stalling: re-home and go on with the next one
            self.abandoned.append(line.seedling)
            self._resume_index = self._after_seedling(line.seedling)
        elif index is not None:  # a program line: where to go on from; a detour: as before
            self._resume_index = self._resume_point(index)
        self._cursor = self._resume_index
        if line.phase == LinePhase.HOME:
            self._detour = []
            return True
        drop_x, drop_y = (_mm(v) for v in self.eeprom.drop_xy_m)
        words = {
            "X": drop_x,
            "Y": drop_y,
            "Z": _mm(self.eeprom.z_up_m),
            "S": _mm(self.eeprom.s_high_m_s),
        }
        settle = {"P": _ms(self.config.stall_settle_s)}
        self._detour = [
            ProgramLine(
                line.seedling, LinePhase.STALL_SETTLE, format_line("G4", settle), "G4", settle
            ),
            ProgramLine(line.seedling, LinePhase.STALL_REHOME, format_line("G28", {}), "G28", {}),
            ProgramLine(
                line.seedling, LinePhase.STALL_TO_START, format_line("G1", words), "G1", words
            ),
        ]
        return True

    def _after_seedling(self, seedling: int) -> int:
        """Program index to go on from when a seedling is given up: its conveyor index if
        it has one (the belt must still move on), else the line after its cycle."""
        lines = [i for i, p in enumerate(self.program) if p.seedling == seedling]
        if self.program[lines[-1]].phase == LinePhase.INDEX:
            return lines[-1]
        return lines[-1] + 1

    def _resume_point(self, index: int) -> int:
        """Program index to go on from after a stall in program line ``index``."""
        line = self.program[index]
        if line.phase in _RETRY_FROM_APPROACH:
            wanted = LinePhase.APPROACH
        elif line.phase in _RESUME_AT_DROP:
            wanted = LinePhase.DROP_ELBOW
        else:
            return index
        return next(
            i
            for i, p in enumerate(self.program)
            if p.seedling == line.seedling and p.phase == wanted
        )

    def poll(self, now: float, replies: list[str]) -> list[str]:
        """Take the SGF's replies received by ``now``; return the lines to transmit now."""
        if replies:  # anything from the SGF shows the link is alive
            self._deadline = now + self.config.reply_timeout_s
        for raw in replies:
            reply = raw.strip()
            if self._fault is not None:
                self.info.append((now, reply))
                continue
            if reply == "ok" or reply.startswith("ok "):
                if not self._outstanding:
                    self._stop(FaultKind.PROTOCOL, f"unexpected {reply!r} with no line outstanding")
                    continue
                self._close_current(now, reply)
            elif reply.lower().startswith("error"):
                if self._outstanding:
                    line = self.sent[-1]
                    self._close_current(now, reply)
                    stalled = ErrorCode.of_reply(reply) is ErrorCode.MOTOR_STALLED
                    if not (stalled and self.config.stall_recovery and self._recover(now, reply)):
                        message = f"SGF refused {line.text!r} ({line.phase}): {reply}"
                        self._stop(kind_of_reply(reply), message)
                else:
                    self._stop(
                        FaultKind.PROTOCOL, f"SGF reported {reply!r} with no line outstanding"
                    )
            else:
                self.info.append((now, reply))
        if self._fault is None and self._outstanding and now >= self._deadline:
            line = self.sent[-1]
            self._stop(
                FaultKind.BUS_TIMEOUT,
                f"bus timeout: no reply to line {len(self.sent)} {line.text!r} ({line.phase}) "
                f"within {self.config.reply_timeout_s:g} s; check the serial cable and that "
                "the SGF is powered and running",
            )
        if self._fault is not None or self._outstanding or self.done:
            return []
        if self._detour:
            line, self._outstanding_index = self._detour.pop(0), None
        else:
            line, self._outstanding_index = self.program[self._cursor], self._cursor
            self._cursor += 1
        text = line.text
        if self.config.line_numbers:  # numbered as sent: a detour shifts the later numbers
            text = format_line(line.command, line.words, line_number=len(self.sent) + 1)
        self.sent.append(SentLine(line.seedling, line.phase, text, t_sent=now))
        self._outstanding = True
        self._deadline = now + self.config.reply_timeout_s
        return [text]
