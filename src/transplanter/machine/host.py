"""A host program on the bus: the machine's PC, PLC or microcontroller program that is not the
five-bar's PGF (which reads its EEPROM image: `machine.pgf`), as the delta's and the serial
arm's jobs run it.

A program is an iterable (a list, or a generator that is sent what its items ask for) of
G-code lines and host items:

- a line (`str`): sent over the bus; the host waits for its reply (`ok` or `error:N`) before
  it goes on, one line outstanding as on the machine; an `error` reply ends the program
  (`HostProgram.error`);
- `Wait(seconds)`: the host's own timer: it goes on that long after now;
- `WaitSince(mark, seconds)`: until that long after the time of a `Mark` (a PLC's timer
  started by an earlier step; at once if that time has passed);
- `Mark(name)`: the time now kept as `HostProgram.marks[name]` (a cell's start and end);
- `Call(fn)`: `fn(t)` is called now (the host reads a sensor, the bench sets a stand in
  place) and its result is sent back into a generator program.

Pure: the firmware side imports no MuJoCo (tests/test_firmware_purity.py).
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterable
from dataclasses import dataclass
from typing import Any

from transplanter.machine.bus import ComBus

__all__ = ["Call", "HostProgram", "Mark", "Wait", "WaitSince"]


@dataclass(frozen=True)
class Wait:
    """The host waits this long (s) before its next item."""

    seconds: float


@dataclass(frozen=True)
class WaitSince:
    """The host waits until `seconds` after the time of its `Mark(mark)` (at once if past)."""

    mark: str
    seconds: float


@dataclass(frozen=True)
class Mark:
    """The time now, kept as the host's `marks[name]`."""

    name: str


@dataclass(frozen=True)
class Call:
    """The host does something now: `fn(t)`, its result sent back into the program."""

    fn: Callable[[float], Any]


class HostProgram:
    """Runs a host program over the bus, one line at a time, waiting for each reply
    (module docstring). `tick(t)` at every physics step: it takes the replies due, then
    goes through the items due at `t`."""

    def __init__(self, program: Iterable | Generator, bus: ComBus) -> None:
        self._generator = program if isinstance(program, Generator) else None
        self._items = iter(program) if self._generator is None else None
        self.bus = bus
        self.waiting, self.resume_at, self.done = False, 0.0, False
        self.error: str | None = None
        self.marks: dict[str, float] = {}
        self._send: Any = None

    def _next(self) -> Any:
        if self._generator is not None:
            item = self._generator.send(self._send)
            self._send = None
            return item
        return next(self._items)

    def tick(self, t: float) -> None:
        for reply in self.bus.host_receive(t):
            if reply.startswith("error"):
                self.error = reply
            if reply.startswith(("ok", "error")):
                self.waiting = False
        if self.error is not None:
            self.done = True
            return
        while not self.done and not self.waiting and t >= self.resume_at:
            try:
                item = self._next()
            except StopIteration:
                self.done = True
                return
            if isinstance(item, str):
                self.bus.host_send(item, t)
                self.waiting = True
            elif isinstance(item, Wait):
                self.resume_at = t + item.seconds
            elif isinstance(item, WaitSince):
                self.resume_at = max(t, self.marks[item.mark] + item.seconds)
            elif isinstance(item, Mark):
                self.marks[item.name] = t
            elif isinstance(item, Call):
                self._send = item.fn(t)
            else:
                raise TypeError(f"a host program item must be a line or a host item: {item!r}")
