"""The COM bus between PGF (host) and SGF (device): a UART model with transmission time.

``LineTransport`` is the interface the firmwares talk to; ``ComBus`` implements it in
process with a simulated clock, and a serial-port transport can implement it later.
A line of n characters plus its newline takes (n + 1) * 10 / baud seconds on the wire
(8N1: start bit, 8 data bits, stop bit), plus a fixed latency. Each direction is its own
wire (full duplex); lines in one direction queue behind each other.
"""

from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple, Protocol, runtime_checkable

TO_DEVICE = "to_device"
TO_HOST = "to_host"


@runtime_checkable
class LineTransport(Protocol):
    """Line-based, time-stamped link between the host (PGF) and the device (SGF)."""

    def host_send(self, line: str, now: float) -> None: ...

    def device_receive(self, now: float) -> list[str]: ...

    def device_send(self, line: str, now: float) -> None: ...

    def host_receive(self, now: float) -> list[str]: ...

    def next_delivery_time(self) -> float | None: ...


class TranscriptEntry(NamedTuple):
    t_sent: float
    t_delivered: float
    direction: str
    text: str


class ComBus:
    """In-process UART model: lines arrive once their last bit has been transmitted."""

    def __init__(self, baud_bps: float = 115200.0, latency_s: float = 0.0, bits_per_char: int = 10):
        if not (math.isfinite(baud_bps) and baud_bps > 0):
            raise ValueError(f"baud_bps must be > 0, got {baud_bps!r}")
        if not (math.isfinite(latency_s) and latency_s >= 0):
            raise ValueError(f"latency_s must be >= 0, got {latency_s!r}")
        if bits_per_char < 1:
            raise ValueError(f"bits_per_char must be >= 1, got {bits_per_char!r}")
        self.baud_bps = float(baud_bps)
        self.latency_s = float(latency_s)
        self.bits_per_char = int(bits_per_char)
        self.transcript: list[TranscriptEntry] = []
        self._queues: dict[str, deque[TranscriptEntry]] = {TO_DEVICE: deque(), TO_HOST: deque()}
        self._wire_free_at = {TO_DEVICE: -math.inf, TO_HOST: -math.inf}
        self._last_now = -math.inf

    def transmission_time_s(self, line: str) -> float:
        """Seconds on the wire for ``line`` plus its newline."""
        return (len(line) + 1) * self.bits_per_char / self.baud_bps

    def _advance(self, now: float) -> None:
        if not math.isfinite(now):
            raise ValueError(f"time must be finite, got {now!r}")
        if now < self._last_now:
            raise ValueError(f"time went backwards: {now} s after {self._last_now} s")
        self._last_now = now

    def _send(self, direction: str, line: str, now: float) -> None:
        if not isinstance(line, str):
            raise TypeError(f"a bus line is a str, got {type(line).__name__}")
        if "\n" in line or "\r" in line:
            raise ValueError(f"send one line at a time without line breaks: {line!r}")
        if not line.isascii():
            raise ValueError(f"the bus carries ASCII only: {line!r}")
        self._advance(now)
        start = max(now, self._wire_free_at[direction])
        end = start + self.transmission_time_s(line)
        self._wire_free_at[direction] = end
        entry = TranscriptEntry(now, end + self.latency_s, direction, line)
        self._queues[direction].append(entry)
        self.transcript.append(entry)

    def _receive(self, direction: str, now: float) -> list[str]:
        self._advance(now)
        queue = self._queues[direction]
        lines = []
        while queue and queue[0].t_delivered <= now:
            lines.append(queue.popleft().text)
        return lines

    def host_send(self, line: str, now: float) -> None:
        """PGF -> SGF."""
        self._send(TO_DEVICE, line, now)

    def device_receive(self, now: float) -> list[str]:
        """Lines from the host fully received by ``now``, oldest first."""
        return self._receive(TO_DEVICE, now)

    def device_send(self, line: str, now: float) -> None:
        """SGF -> PGF."""
        self._send(TO_HOST, line, now)

    def host_receive(self, now: float) -> list[str]:
        """Lines from the device fully received by ``now``, oldest first."""
        return self._receive(TO_HOST, now)

    def next_delivery_time(self) -> float | None:
        """When the next queued line (either direction) arrives; None if nothing is in flight."""
        heads = [queue[0].t_delivered for queue in self._queues.values() if queue]
        return min(heads) if heads else None
