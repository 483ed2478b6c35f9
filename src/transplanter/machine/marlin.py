"""Marlin's serial conventions in front of the SGF: what a host such as Printrun or
OctoPrint expects on the line.

``MarlinDevice`` sits between the wire and an :class:`~transplanter.machine.sgf.SGF`. It
reads lines as received (possibly corrupted), checks Marlin's framing itself and hands the
SGF only the bare commands of lines that passed, in order, so the SGF executes every line
exactly once. Its replies follow Marlin 2 (``GCodeQueue::get_serial_commands`` and
``gcode_line_error``):

- ``start`` and an ``echo:`` banner when the link opens (``greeting``);
- ``N<n> ... *<checksum>``: the line number must be the last one + 1 (``M110 N<n>`` sets the
  last one and is exempt; only the command word counts, not ``M110`` in a comment), the
  checksum (XOR of every byte before ``*``) must match and a numbered line must carry one;
  otherwise ``Error:<reason>, Last Line: <n>``, ``Resend: <n+1>`` and ``ok``, and nothing
  runs. Unlike Marlin, a line with ``*`` but no ``N`` is refused the same way (the tail of a
  line that noise split in two), so a single corrupted byte never reaches the SGF;
- unnumbered lines without ``*`` run as they are (hosts that do not frame);
- a line with nothing to run (empty, blanks, or a comment only: ``; note``, ``(note)``) is
  skipped without a reply when unnumbered, as Marlin's reader drops it before its queue
  (``process_line_done``); a numbered one whose framing passes takes its line number and is
  answered ``ok`` in its turn. Either way every other line's reply stays its own;
- ``ok`` per executed line, in order; ``M105`` answers ``ok T:0`` (hosts poll temperature);
- a refused command: ``echo:Unknown command: "<line>"`` for a command the dialect does not
  have, ``Error:<message> [error:<code>]`` for any other refusal (the grbl code of
  ``transplanter.errors`` in brackets), then ``ok``; nothing moves;
- ``M119`` as Marlin reports endstops (``Reporting endstop status`` and one line per switch);
- ``busy: processing`` every ``keepalive_s`` while a line runs (Marlin's host keepalive), so a
  host's reply timeout does not fire during a long move or homing;
- a line the SGF has no room for (its command queue and receive buffer are full) is not
  dropped: ``Error:receive buffer full, Last Line: <n>``, ``Resend`` and ``ok``, as for a line
  lost on the wire.

Pure Python: no MuJoCo, no serial port (``transplanter.twin.serve`` owns those).
"""

from __future__ import annotations

import math
import random
import re
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

from transplanter.errors import ErrorCode
from transplanter.machine.gcode import (
    MAX_LINE_CHARS,
    GcodeError,
    checksum,
    is_emergency_stop,
    parse_line,
)
from transplanter.machine.sgf import SGF

__all__ = [
    "MarlinDevice",
    "AcceptedLine",
    "LineNoise",
    "LineReader",
    "BANNER",
    "KEEPALIVE_S",
    "split_framing",
]

BANNER = "echo:transplanter twin SGF, Marlin-compatible dialect (docs/architecture.md)"
KEEPALIVE_S = 2.0
"""Marlin's DEFAULT_KEEPALIVE_INTERVAL (s)."""

_N_RE = re.compile(r"\s*[Nn]([+-]?\d+)")
# M110 as the line's command word (comments removed first), with its optional N<n>
_M110_RE = re.compile(r"\s*M0*110(?![0-9.])(?:\s*N\s*([+-]?\d+))?", re.IGNORECASE)
_PAREN_COMMENT_RE = re.compile(r"\([^)]*\)")
_SWITCH_NAMES = (
    "switch1 (arm 1 home)",
    "switch2 (arm 2 home)",
    "switch3 (Z up)",
    "switch4 (Z down)",
)


@dataclass
class AcceptedLine:
    """A line that passed the framing and went to the SGF (or was answered by this layer)."""

    rx_index: int
    """Which received line it was (0: the first line read from the wire)."""
    text: str
    """The command without framing, as the SGF got it."""
    line_number: int | None
    t_received: float
    reply: str | None = None
    """The SGF's final reply once it came (``ok`` or ``error:<code> (...)``)."""
    tx_index: int | None = None
    """Which line sent back to the host carried the final reply (0: the first)."""


def _m110(command: str) -> re.Match | None:
    """The match of ``M110 [N<n>]`` when it is the command's word, else None: a comment
    (``; ...``, ``( ... )``) or a later word naming M110 does not make a line M110."""
    return _M110_RE.match(_PAREN_COMMENT_RE.sub(" ", command.split(";", 1)[0]))


def _nothing_to_run(command: str) -> bool:
    """Whether a command without framing is empty, blanks or comments only: the line the SGF
    would take without a reply (``gcode.parse_line`` gives None)."""
    if command[:1] not in ("", ";", "("):
        return False  # begins with a word (commands come stripped)
    try:
        return parse_line(command) is None
    except GcodeError:
        return False  # an unclosed comment: the SGF refuses it with its error


def split_framing(line: str) -> tuple[int | None, str, str | None]:
    """(line number or None, the command without framing, the error or None) of a received
    line, checked as Marlin does except that ``*`` without ``N`` is refused too; the line
    number check against the last line is the caller's."""
    star = line.rfind("*")
    match = _N_RE.match(line)
    if match is None:
        if star >= 0:
            return None, line, "No Line Number with checksum"
        return None, line.strip(), None
    number = int(match.group(1))
    if star < 0:
        return number, "", "No Checksum with line number"
    digits = line[star + 1 :].strip()
    if not (digits.isascii() and digits.isdigit()) or int(digits) != checksum(line[:star]):
        return number, "", "checksum mismatch"
    return number, line[match.end() : star].strip(), None


class LineReader:
    """Bytes from the wire into lines (split at ``\\n``), holding at most ``limit`` bytes of
    the line being received, as Marlin's serial reader holds at most MAX_CMD_SIZE.

    A line longer than that keeps its first ``limit`` bytes and drops the rest up to its
    newline, so the work per byte is constant whatever arrives (16 MB without a newline used
    to take minutes, quadratically); the cut line comes out ``limit`` bytes long, with any
    carriage return in it made DEL, so it stays longer than ``gcode.MAX_LINE_CHARS`` after a
    host's ``\\r`` is stripped and the device refuses it whole (``Line too long``), never runs
    its first part."""

    def __init__(self, limit: int = MAX_LINE_CHARS + 1) -> None:
        if not (isinstance(limit, int) and limit > MAX_LINE_CHARS):
            raise ValueError(f"limit must be an integer > {MAX_LINE_CHARS}, got {limit!r}")
        self.limit = limit
        self.pending = bytearray()
        """The line received so far (at most ``limit`` bytes)."""
        self.overlong = 0
        """Lines cut to ``limit`` bytes so far."""
        self._cut = False  # the line being received is over the limit

    def feed(self, chunk: bytes) -> list[bytes]:
        """The lines ``chunk`` completes, without their newline."""
        lines: list[bytes] = []
        start = 0
        while True:
            end = chunk.find(b"\n", start)
            piece = chunk[start:] if end < 0 else chunk[start:end]
            room = self.limit - len(self.pending)
            if len(piece) > room:
                self._cut = True
                piece = piece[:room]
            self.pending += piece
            if end < 0:
                return lines
            line = bytes(self.pending)
            if self._cut:
                line = line.replace(b"\r", b"\x7f")
                self.overlong += 1
                self._cut = False
            lines.append(line)
            self.pending.clear()
            start = end + 1


class LineNoise:
    """Byte errors on the wire: each line, with probability ``rate``, gets one error: a
    flipped bit in one of its bytes or one byte dropped (equally likely). Seeded, so a run
    repeats. The XOR checksum catches every such single-byte error (not every double one)."""

    def __init__(self, rate: float, seed: int = 0):
        if not (math.isfinite(rate) and 0 <= rate <= 1):
            raise ValueError(f"the byte error rate is a probability 0..1, got {rate!r}")
        self.rate = float(rate)
        self.rng = random.Random(seed)
        self.corrupted = 0
        """Lines corrupted so far."""

    def __call__(self, line: str) -> str:
        if not line or self.rng.random() >= self.rate:
            return line
        self.corrupted += 1
        data = bytearray(line.encode("latin-1"))
        at = self.rng.randrange(len(data))
        if self.rng.random() < 0.5:
            data[at] ^= 1 << self.rng.randrange(8)
        else:
            del data[at]
        return data.decode("latin-1")


class MarlinDevice:
    """The device end of a Marlin-style serial link, in front of one SGF (module docstring).

    ``receive(line, now)`` takes each line read from the wire (without its newline);
    ``poll(now, endstops)`` advances the SGF and returns the lines to send back.
    """

    def __init__(self, sgf: SGF, keepalive_s: float = KEEPALIVE_S, noise: LineNoise | None = None):
        if not (math.isfinite(keepalive_s) and keepalive_s >= 0):
            raise ValueError(f"keepalive_s must be >= 0 (0: no keepalive), got {keepalive_s!r}")
        self.sgf = sgf
        self.noise = noise
        self.keepalive_s = float(keepalive_s)
        self.last_line_number = 0
        self.accepted: list[AcceptedLine] = []
        """Every line that passed the framing, in order."""
        self.resends = 0
        """Lines refused for their framing (each answered with ``Resend``)."""
        self.rx_count = 0
        """Lines read from the wire so far."""
        self.tx_count = 0
        """Lines emitted for the host so far (every one is sent, in order)."""
        self._waiting: deque[AcceptedLine] = deque()  # at the SGF, final reply not yet seen
        self._out: list[str] = []
        self._last_tx_t = -math.inf

    # -- host -> device --------------------------------------------------------------------
    @staticmethod
    def greeting() -> list[str]:
        """What Marlin prints when it boots, before any host speaks (hosts wait for ``start``
        or an ``ok``); the caller writes it to the port (it is not timed on the UART)."""
        return ["start", BANNER]

    def receive(self, line: str, now: float) -> None:
        """A line arrived from the host: check its framing, then queue its command.

        With ``noise``, the line is first corrupted as the wire would; a newline that noise
        made splits it, and each part is checked on its own (both belong to this line)."""
        rx_index = self.rx_count
        self.rx_count += 1
        if self.noise is not None:
            line = self.noise(line)
        for part in line.split("\n"):
            self._receive_one(part, rx_index, now)

    def _receive_one(self, line: str, rx_index: int, now: float) -> None:
        if not line.strip():
            return  # Marlin skips empty lines
        if is_emergency_stop(line):
            self._emergency_stop(line, rx_index, now)
            return
        if len(line) > MAX_LINE_CHARS:
            self._resend("Line too long")
            return
        try:
            line.encode("ascii")
        except UnicodeEncodeError:
            self._resend("checksum mismatch")  # a byte that noise pushed above 0x7F
            return
        number, command, error = split_framing(line)
        m110 = _m110(command) if error is None else None
        if error is None and number is not None and m110 is None:
            if number != self.last_line_number + 1:
                error = "Line Number is not Last Line Number+1"
        if error is not None:
            self._resend(error)
            return
        blank = _nothing_to_run(command)
        if blank and number is None:
            return  # Marlin skips it unanswered: no ok owed, the next reply is the next line's
        if not self.sgf.room_for(command):
            self._resend("receive buffer full")
            return
        if m110 is not None:
            new_last = m110.group(1) if m110.group(1) is not None else number
            if new_last is not None:
                self.last_line_number = int(new_last)
            # answered in order with the lines before it: the SGF runs it as a no-op
            command_for_sgf = "M400"
        else:
            if number is not None:
                self.last_line_number = number
            # a numbered line with nothing to run owes its ok, in its turn: a no-op too
            command_for_sgf = "M400" if blank else command
        entry = AcceptedLine(rx_index, command, number, now)
        self.accepted.append(entry)
        self._waiting.append(entry)
        self.sgf.receive(command_for_sgf, now)

    def _emergency_stop(self, line: str, rx_index: int, now: float) -> None:
        """M112, caught before the framing check and the queue (Marlin's EMERGENCY_PARSER):
        the SGF stops at once. A line number whose framing passes and is in sequence counts;
        a framing error delays nothing and asks for no resend."""
        number, _, error = split_framing(line)
        if error is None and number is not None and number == self.last_line_number + 1:
            self.last_line_number = number
        entry = AcceptedLine(rx_index, "M112", number, now)
        self.accepted.append(entry)
        self._waiting.append(entry)
        self.sgf.receive("M112", now)

    def _resend(self, reason: str) -> None:
        self.resends += 1
        last = self.last_line_number
        self._emit([f"Error:{reason}, Last Line: {last}", f"Resend: {last + 1}", "ok"])

    # -- device -> host --------------------------------------------------------------------
    def poll(self, now: float, endstops: Sequence[bool] | None = None) -> list[str]:
        """Advance the SGF to ``now``; the lines to send to the host now, in order."""
        for reply in self.sgf.poll(now, endstops):
            self._translate(reply)
        if (
            self.keepalive_s > 0
            and self.sgf.busy
            and now - max(self._last_tx_t, self._busy_since()) >= self.keepalive_s
        ):
            self._emit(["busy: processing"])
        out, self._out = self._out, []
        if out:
            self._last_tx_t = now
        return out

    def _busy_since(self) -> float:
        return self._waiting[0].t_received if self._waiting else math.inf

    def _translate(self, reply: str) -> None:
        is_final = reply == "ok" or reply.startswith("error:")
        if not is_final:
            self._emit(self._report(reply))
            return
        entry = self._waiting.popleft()
        entry.reply = reply
        code = ErrorCode.of_reply(reply)
        if reply == "ok":
            text = "ok T:0" if entry.text.upper().startswith("M105") else "ok"
            lines = [text]
        elif code is ErrorCode.UNSUPPORTED_COMMAND:
            lines = [f'echo:Unknown command: "{entry.text}"', "ok"]
        else:
            head, _, rest = reply.partition(" ")
            message = rest[1:-1] if rest.startswith("(") and rest.endswith(")") else rest
            lines = [f"Error:{message} [{head}]", "ok"]
        self._emit(lines)
        entry.tx_index = self.tx_count - 1  # the final ok is the last line emitted

    @staticmethod
    def _report(reply: str) -> list[str]:
        if reply.startswith("endstops: "):
            states = reply.removeprefix("endstops: ")
            if states == "unknown":
                return ["Reporting endstop status", "echo:endstops not read yet"]
            out = ["Reporting endstop status"]
            for item, name in zip(states.split(), _SWITCH_NAMES, strict=False):
                _, _, state = item.partition(":")
                out.append(f"{name}: {state}")
            return out
        return [reply]

    def _emit(self, lines: list[str]) -> list[str]:
        self._out.extend(lines)
        self.tx_count += len(lines)
        return lines
