"""The twin on a serial line: the SGF and the physics behind a pseudo-terminal or a port.

`transplanter serve` puts the whole machine (SGF, physics, judge, recording) behind a
POSIX pty (its path is printed: connect any host to it) or a real serial port (pyserial),
speaking Marlin's conventions (`machine.marlin.MarlinDevice`). An external host takes the
PGF's place: `RemoteHost` is the PGF's stand-in inside the twin. Its lines go onto the
twin's simulated UART at the simulated time they are read, and the replies come back to the
host when the UART delivers them, so the timing on the wire is the same as in `trial`.

Time: by default the physics waits, frozen, whenever the machine has nothing to do and a
reply has reached the host (as fast as the handshake allows): a host that answers each
``ok`` at once sees exactly the trial's timeline, whatever the wall clock does. With
``realtime`` the physics is paced to the wall clock and runs on while the host thinks.

Seedlings are judged as in `trial` when the host sends the scenario's taught program (what
`transplanter pgf` or the paper's PGF sends): each line the SGF takes is matched against the
program's next line (command and words, framing aside). Lines that are not the program's
next line (a host's `M105` polls, `M114`, other G-code) run as they are and are judged as
host lines. One session per run: it ends when the host closes the port (end-of-file on a pty,
a failed read or write on a real port), at once, even with a move under way, or, with
``until_done``, once the taught program's last line has been answered; ``ServeStats.ended``
says which, in one line.
"""

from __future__ import annotations

import math
import os
import select
import time
import tty
from dataclasses import dataclass, field
from typing import Any

from transplanter.machine.faults import FaultKind, kind_of_reply
from transplanter.machine.gcode import GcodeError, parse_line
from transplanter.machine.marlin import KEEPALIVE_S, LineNoise, LineReader, MarlinDevice
from transplanter.machine.pgf import LinePhase, SentLine, build_program

__all__ = [
    "PtyEndpoint",
    "SerialEndpoint",
    "ProgramFollower",
    "RemoteHost",
    "ServeStats",
]

_READ_CHUNK = 4096
# Refusals that mean the machine stopped (not a host's bad line): reported as the fault.
_MACHINE_FAULTS = frozenset(
    {
        FaultKind.MOTOR_STALLED,
        FaultKind.SWITCH_STUCK_CLOSED,
        FaultKind.SWITCH_NOT_FOUND,
        FaultKind.EMERGENCY_STOP,
    }
)
HOST_POLL_S = 0.01
"""While the machine is busy the port is read at least this often (simulated s), so that a
host's M112 reaches the device within 10 ms of simulated time (else only at the next
firmware event, up to a whole move later)."""


class PtyEndpoint:
    """A pseudo-terminal: the host opens ``path``; lines are read from the master side.

    The slave side is set raw (no echo, no line editing) before any host opens it. This
    process keeps its own slave descriptor open until the host's first bytes arrive (until
    then nobody holds the port and the master would read end-of-file), then closes it, so
    the host closing the port is seen as end-of-file.
    """

    def __init__(self) -> None:
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        os.set_blocking(self.master, False)
        self.reader = LineReader()
        """Holds the line being received, at most one over-long line's bound."""
        self.closed = False

    def read_lines(self, timeout_s: float) -> list[bytes]:
        """Complete lines received within ``timeout_s`` (0: what is there now); sets
        ``closed`` when the host has hung up."""
        if self.closed:
            return []
        ready, _, _ = select.select([self.master], [], [], max(timeout_s, 0.0))
        if not ready:
            return []
        try:
            chunk = os.read(self.master, _READ_CHUNK)
        except BlockingIOError:
            return []
        except OSError:  # EIO: no process holds the slave side any more
            chunk = b""
        if not chunk:
            self.closed = True
            return []
        if self._slave is not None:
            os.close(self._slave)
            self._slave = None
        return self.reader.feed(chunk)

    def write_lines(self, lines: list[str]) -> None:
        data = "".join(f"{line}\n" for line in lines).encode("ascii")
        while data and not self.closed:
            try:
                written = os.write(self.master, data)
            except BlockingIOError:
                select.select([], [self.master], [], 0.1)
                continue
            except OSError:
                self.closed = True
                return
            data = data[written:]

    def close(self) -> None:
        if self._slave is not None:
            os.close(self._slave)
            self._slave = None
        os.close(self.master)


class SerialEndpoint:
    """A real serial port through pyserial (a USB-UART to the host). A read or write that
    fails (the adapter unplugged, the device gone: pyserial's SerialException, an OSError)
    closes the session, as end-of-file does on a pty."""

    def __init__(self, port: str, baud: int) -> None:
        import serial

        self._errors = (serial.SerialException, OSError)
        self.serial = serial.Serial(port, baudrate=baud, timeout=0)
        self.path = port
        self.reader = LineReader()
        """Holds the line being received, at most one over-long line's bound."""
        self.closed = False

    def read_lines(self, timeout_s: float) -> list[bytes]:
        if self.closed:
            return []
        try:
            self.serial.timeout = max(timeout_s, 0.0)
            chunk = self.serial.read(min(max(1, self.serial.in_waiting), _READ_CHUNK))
        except self._errors:
            self.closed = True
            return []
        return self.reader.feed(chunk)

    def write_lines(self, lines: list[str]) -> None:
        if self.closed:
            return
        try:
            self.serial.write("".join(f"{line}\n" for line in lines).encode("ascii"))
        except self._errors:
            self.closed = True

    def close(self) -> None:
        try:
            self.serial.close()
        except self._errors:
            pass


class ProgramFollower:
    """Which taught-program line each line the SGF takes is: (seedling, phase)."""

    def __init__(self, program) -> None:
        self.program = program
        self.cursor = 0
        self.unmatched = 0
        """Lines taken that were not the program's next line."""

    @property
    def finished(self) -> bool:
        return self.cursor >= len(self.program)

    def follow(self, command_text: str) -> tuple[int | None, LinePhase]:
        if not self.finished and self._matches(command_text, self.program[self.cursor]):
            line = self.program[self.cursor]
            self.cursor += 1
            return line.seedling, line.phase
        self.unmatched += 1
        return None, LinePhase.HOST

    @staticmethod
    def _matches(text: str, expected) -> bool:
        try:
            parsed = parse_line(text)
        except GcodeError:
            return False
        if parsed is None or parsed.command != expected.command:
            return False
        if set(parsed.words) != set(expected.words):
            return False
        return all(
            math.isclose(parsed.words[k], float(v), rel_tol=1e-12, abs_tol=1e-9)
            for k, v in expected.words.items()
        )


@dataclass
class ServeStats:
    """What went over the line in a session."""

    device: str
    lines_received: int = 0
    lines_taken: int = 0
    resends: int = 0
    corrupted_by_noise: int = 0
    host_lines: int = 0
    """Lines taken that were not the taught program's next line."""
    program_lines_done: int = 0
    program_lines: int = 0
    final_position_mm: list[float] = field(default_factory=list)
    ended: str = ""
    """Why the session ended: the host closed the port (when, and how many lines it left
    unanswered), or the taught program was done (``until_done``)."""
    executed: list[str] = field(default_factory=list)
    """The command of every line the SGF took, in order, framing removed."""

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


class RemoteHost:
    """The PGF's stand-in inside the twin for a host on the other end of ``endpoint``.

    The twin calls ``poll(now, replies)`` at every firmware exchange, as it would the PGF:
    the replies the UART has delivered to the host by ``now`` are written to the port, and
    the lines the host has written are returned, to go onto the UART at ``now``. ``sent``
    lists the lines the device took (one per executed line, framing errors excluded) with
    their seedling and phase, their send time and the time their reply reached the host:
    what the judge follows.
    """

    def __init__(
        self,
        endpoint,
        machine,
        realtime: bool = False,
        until_done: bool = False,
        keepalive_s: float = KEEPALIVE_S,
        noise: LineNoise | None = None,
        idle_wait_s: float = 0.25,
    ) -> None:
        self.endpoint = endpoint
        self.follower = ProgramFollower(build_program(machine.eeprom, machine.pgf))
        self.realtime, self.until_done = realtime, until_done
        self.keepalive_s, self.noise = keepalive_s, noise
        self.idle_wait_s = idle_wait_s
        self.sent: list[SentLine] = []
        self.abandoned: list[int] = []
        self.fault: str | None = None
        self._host_lines: list[str] = []  # every line the host sent, as sent
        self._host_send_t: list[float] = []
        self._reply_t: list[float] = []  # when each device line reached the host
        self._synced = 0  # device.accepted entries turned into SentLines
        self._open: list[int] = []  # indices into sent still waiting for their reply
        self._t0_wall: float | None = None
        self._t_poll = 0.0  # when the port was last read
        self.device: MarlinDevice | None = None
        self.twin = None
        self.ended: str | None = None
        """Why the session ended, one line (set when the host hangs up)."""

    # -- the twin's side -------------------------------------------------------------------
    def attach(self, twin) -> tuple[RemoteHost, MarlinDevice]:
        """Called by the Twin: the stand-in for its PGF and the device in front of its SGF."""
        self.twin = twin
        self.device = MarlinDevice(twin.sgf, keepalive_s=self.keepalive_s, noise=self.noise)
        self.endpoint.write_lines(MarlinDevice.greeting())
        return self, self.device

    @property
    def done(self) -> bool:
        """The session is over: the host closed the port (whatever the machine is doing:
        nobody is there to hear it), or with ``until_done`` the program's last line was
        answered."""
        if self.until_done and self.follower.finished and not self._open:
            return True
        return self.endpoint.closed

    def _machine_busy(self) -> bool:
        twin = self.twin
        return twin.sgf.busy or twin.bus.next_delivery_time() is not None

    def poll(self, now: float, replies: list[str]) -> list[str]:
        self._t_poll = now
        if replies:
            self.endpoint.write_lines(replies)
            self._reply_t.extend([now] * len(replies))
        self._sync()
        if self.endpoint.closed:
            self._hung_up(now)
            return []
        if self.realtime:
            lines = self._read_paced(now)
        elif self._machine_busy():
            lines = self.endpoint.read_lines(0.0)
        else:  # nothing to do until the host speaks: simulated time waits
            lines = []
            while not lines and not self.endpoint.closed and not self.done:
                lines = self.endpoint.read_lines(self.idle_wait_s)
        if self.endpoint.closed:
            self._hung_up(now)
        out = [raw.rstrip(b"\r").decode("latin-1") for raw in lines]
        out = [_wire_safe(line) for line in out]
        self._host_lines.extend(out)
        self._host_send_t.extend([now] * len(out))
        return out

    def _hung_up(self, now: float) -> None:
        if self.ended is not None:
            return
        waiting = len(self._open) + (len(self._host_lines) - self.device.rx_count)
        busy = f"; {waiting} line{'' if waiting == 1 else 's'} not answered" if waiting else ""
        self.ended = f"the host closed the port at t = {now:.3f} s simulated{busy}"

    def _read_paced(self, now: float) -> list[bytes]:
        if self._t0_wall is None:
            self._t0_wall = time.monotonic() - now
        ahead = now - (time.monotonic() - self._t0_wall)
        lines = self.endpoint.read_lines(max(ahead, 0.0))
        ahead = now - (time.monotonic() - self._t0_wall)
        if ahead > 0:
            time.sleep(ahead)
        return lines

    def _sync(self) -> None:
        """SentLines for the lines the device took; replies once they reached the host."""
        accepted = self.device.accepted
        while self._synced < len(accepted):
            entry = accepted[self._synced]
            self._synced += 1
            seedling, phase = self.follower.follow(entry.text)
            text = self._host_lines[entry.rx_index]
            self.sent.append(SentLine(seedling, phase, text, self._host_send_t[entry.rx_index]))
            self._open.append(len(self.sent) - 1)
        while self._open:
            index = self._open[0]
            entry = accepted[index]
            if entry.tx_index is None or entry.tx_index >= len(self._reply_t):
                break
            self._open.pop(0)
            line = self.sent[index]
            self.sent[index] = SentLine(
                line.seedling, line.phase, line.text, line.t_sent,
                self._reply_t[entry.tx_index], entry.reply,
            )  # fmt: skip

    def next_event_time(self) -> float | None:
        """While the machine is busy, the next read of the port (``HOST_POLL_S``); no reply
        timeout here: the host on the other end keeps its own."""
        if self.endpoint.closed or self.twin is None or not self._machine_busy():
            return None
        return self._t_poll + HOST_POLL_S

    @property
    def machine_fault(self) -> str | None:
        """The first fault that stopped the machine (a stall, a homing failure, a hard
        limit) as the SGF answered it; the host decides what comes next."""
        fault = self._machine_fault()
        return None if fault is None else fault[1]

    @property
    def fault_kind(self) -> FaultKind | None:
        fault = self._machine_fault()
        return None if fault is None else fault[0]

    def _machine_fault(self) -> tuple[FaultKind, str] | None:
        for line in self.sent:
            if line.reply is not None and line.reply.startswith("error"):
                kind = kind_of_reply(line.reply)
                if kind in _MACHINE_FAULTS:
                    return kind, f"the SGF answered {line.text!r}: {line.reply}"
        return None

    def _end_otherwise(self) -> str:
        if self.until_done and self.follower.finished and not self._open:
            return "the taught program's last line was answered (until done)"
        return "the twin stopped (interrupted, or its simulation went invalid)"

    def stats(self) -> ServeStats:
        device = self.device
        position = self.twin.sgf.position_xyz * 1000.0
        return ServeStats(
            device=self.endpoint.path,
            lines_received=device.rx_count,
            lines_taken=len(device.accepted),
            resends=device.resends,
            corrupted_by_noise=self.noise.corrupted if self.noise is not None else 0,
            host_lines=self.follower.unmatched,
            program_lines_done=self.follower.cursor,
            program_lines=len(self.follower.program),
            final_position_mm=[round(float(v), 6) for v in position],
            ended=self.ended or self._end_otherwise(),
            executed=[entry.text for entry in device.accepted],
        )


def _wire_safe(line: str) -> str:
    """The UART model carries ASCII lines: a byte above 0x7F or a stray carriage return
    (a host's or the line's fault) is carried as DEL, which fails any checksum."""
    if line.isascii() and "\r" not in line:
        return line
    return "".join(c if c.isascii() and c != "\r" else "\x7f" for c in line)


def format_stats(stats: ServeStats) -> str:
    """The session's line counts, one line each."""
    x, y, z = stats.final_position_mm or (math.nan,) * 3
    rows = [
        ("serial device", stats.device),
        ("lines received", f"{stats.lines_received} ({stats.resends} answered with Resend)"),
        ("lines executed", f"{stats.lines_taken}"),
        ("taught program", f"{stats.program_lines_done} of {stats.program_lines} lines"),
        ("other host lines", f"{stats.host_lines}"),
        ("final position", f"X{x:.3f} Y{y:.3f} Z{z:.3f} mm"),
    ]
    if stats.ended:
        rows.append(("session ended", stats.ended))
    if stats.corrupted_by_noise:
        rows.insert(2, ("byte errors injected", f"in {stats.corrupted_by_noise} lines"))
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)
