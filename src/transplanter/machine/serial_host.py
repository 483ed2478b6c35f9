"""The PGF on a real serial line: streams the taught cycle to any Marlin-style SGF.

`SerialPGF` runs the PGF state machine (`machine.pgf.PGF`, Algorithm 2) on the wall clock
and talks to a port: the twin's `transplanter serve`, or a board running the paper's SGF.
It keeps the PGF's handshake (one line outstanding, the next after its ``ok``) and adds what
a serial line needs:

- a device that counts lines from elsewhere (it answers the first line with a line-number
  error) gets ``M110 N<n-1>`` before the line goes again (a fresh device needs none, so the
  timeline is the PGF's own);
- ``Resend: <n>`` (a line the device received damaged or out of sequence): the framing
  error and its ``ok`` are not the line's reply; the outstanding line goes again, as it was;
- ``Error:... [error:<code>]`` + ``ok`` (Marlin) become the PGF's ``error:<code> <message>``, and
  ``echo:Unknown command`` + ``ok`` its ``error:20``: one reply per line, as the PGF expects;
- ``busy: processing`` and other lines restart the PGF's reply timer (``PGFConfig``'s
  ``reply_timeout_s``); no reply in that time stops it with a bus-timeout fault.

Pure Python with pyserial; no MuJoCo.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from transplanter.errors import ErrorCode
from transplanter.machine.pgf import PGF

__all__ = ["SerialPGF", "SerialRun", "translate_reply"]

_RESEND_RE = re.compile(r"^(?:Resend|rs)[:\s]*N?:?\s*(-?\d+)", re.IGNORECASE)
_CODE_RE = re.compile(r"\s*\[error:(\d+)\]\s*$")
POLL_S = 0.02
"""How often the PGF is polled while no line arrives (s): its timer's resolution."""
CONNECT_TIMEOUT_S = 10.0
"""How long to wait for the device's first line of any kind (s)."""


def _line_number(text: str) -> int:
    match = re.match(r"\s*N(-?\d+)", text)
    return int(match.group(1)) if match else 1


def translate_reply(line: str) -> tuple[str, str | None]:
    """(kind, PGF reply) of one line from a Marlin-style device: kind is ``ok``,
    ``resend``, ``line_error`` (a framing error: a Resend follows), ``error`` (the line's
    command was refused: an ``ok`` follows) or ``info``."""
    text = line.strip()
    if text == "ok" or text.startswith("ok "):
        return "ok", "ok"
    if _RESEND_RE.match(text):
        return "resend", None
    if text.startswith("Error:") or text.startswith("error:"):
        body = text.split(":", 1)[1].strip()
        if "Last Line:" in body:
            return "line_error", None
        match = _CODE_RE.search(body)
        message = _CODE_RE.sub("", body) if match else body
        try:
            code = ErrorCode(int(match.group(1))) if match else ErrorCode.INVALID_TARGET
        except ValueError:  # a code this dialect does not have: keep it in the message
            code, message = ErrorCode.INVALID_TARGET, body
        return "error", code.reply(message)
    if text.startswith("echo:Unknown command"):
        return "error", ErrorCode.UNSUPPORTED_COMMAND.reply(text[5:])
    return "info", text


@dataclass
class SerialRun:
    """How a serial session went."""

    port: str
    done: bool
    fault: str | None
    lines_sent: int
    resends: int
    wall_time_s: float
    info: list[str] = field(default_factory=list)


class SerialPGF:
    """Streams ``pgf``'s program over ``port`` (a pyserial-like object with ``read``,
    ``write`` and ``in_waiting``)."""

    def __init__(
        self,
        pgf: PGF,
        port,
        name: str = "port",
        clock: Callable[[], float] = time.monotonic,
        connect_timeout_s: float = CONNECT_TIMEOUT_S,
    ) -> None:
        self.pgf, self.port, self.name = pgf, port, name
        self.clock = clock
        self.connect_timeout_s = connect_timeout_s
        self._buffer = b""
        self.resends = 0
        self.writes = 0
        self.info: list[str] = []

    def _read_lines(self, timeout_s: float) -> list[str]:
        self.port.timeout = timeout_s
        chunk = self.port.read(max(1, self.port.in_waiting))
        self._buffer += chunk
        *lines, self._buffer = self._buffer.split(b"\n")
        return [raw.rstrip(b"\r").decode("ascii", "replace") for raw in lines]

    def _write(self, line: str) -> None:
        self.port.write(f"{line}\n".encode("ascii"))
        self.writes += 1

    def run(self, progress: Callable[[int], None] | None = None) -> SerialRun:
        """Send the whole program; returns when the PGF is done or has faulted."""
        t0 = self.clock()
        pgf = self.pgf
        resend_pending = renumber = False
        swallow_ok = 0  # oks that answer no line of the PGF's (an Error's, an M110's)
        heard = False
        for line in pgf.poll(0.0, []):
            self._write(line)
        while not (pgf.done or pgf.fault):
            replies: list[str] = []
            for raw in self._read_lines(POLL_S):
                heard = True
                kind, reply = translate_reply(raw)
                if kind == "resend":
                    resend_pending = True
                    self.resends += 1
                    replies.append(raw)  # restarts the PGF's reply timer
                elif kind == "line_error":  # not the line's reply: a Resend follows
                    renumber = renumber or "Line Number" in raw
                    replies.append(f"info: {raw}")
                elif kind == "ok":
                    if resend_pending:
                        resend_pending = False
                        if pgf.current is not None:
                            if renumber:  # the device counts from elsewhere: set its count
                                self._write(f"M110 N{_line_number(pgf.current.text) - 1}")
                                swallow_ok += 1
                            self._write(pgf.current.text)
                        renumber = False
                    elif swallow_ok:
                        swallow_ok -= 1
                    else:
                        replies.append("ok")
                elif kind == "error":
                    replies.append(reply)
                    swallow_ok += 1
                else:
                    replies.append(reply)
                    self.info.append(raw)
            now = self.clock() - t0
            if not heard and now > self.connect_timeout_s:
                fault = (
                    f"no answer from {self.name} within {self.connect_timeout_s:g} s: is an SGF "
                    "connected there, at the same baud rate?"
                )
                return SerialRun(self.name, False, fault, len(pgf.sent), 0, now, self.info)
            for line in pgf.poll(now, replies):
                self._write(line)
            if progress is not None:
                progress(len(pgf.sent))
        return SerialRun(
            self.name, pgf.done, pgf.fault, len(pgf.sent), self.resends, self.clock() - t0,
            self.info,
        )  # fmt: skip
