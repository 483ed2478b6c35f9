"""Injected faults (scenario ``[faults]``) and the kinds of fault that stop a run.

``FaultConfig`` holds what a scenario injects, all off by default: a limit switch stuck
closed or dead, a mechanical jam on one motor (applied by the physics twin as a friction
brake on the motor's joint, ``transplanter.twin.sim``), and an SGF reply lost on the wire
(``LostReplyTransport``, in front of any ``LineTransport``). The switch faults are applied
where the switches are read (``FaultConfig.switches``): the twin's model sensors and the
physics-free ``rig.SimulatedEndstops``.

``FaultKind`` names what stopped a run, derived from what happened, never from the
injected fault: the code of the SGF's ``error:`` reply (``kind_of_reply``) or the PGF's own
reply timeout. Pure Python: no MuJoCo.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

from transplanter.errors import ErrorCode

__all__ = [
    "FaultConfig",
    "FaultKind",
    "LostReplyTransport",
    "SWITCH_NAMES",
    "kind_of_reply",
]

SWITCH_NAMES = ("arm 1 home", "arm 2 home", "Z up", "Z down")
"""What each limit switch 1-4 is for (switches 1-3 are the homing switches)."""

MOTOR_NAMES = ("arm 1", "arm 2", "Z")


class FaultKind(StrEnum):
    """Why a run stopped (``TrialResult.fault_kind``); each equals its lower-case name."""

    SWITCH_STUCK_CLOSED = "switch_stuck_closed"  # error:68 homing, error:70 a hard limit
    SWITCH_NOT_FOUND = "switch_not_found"  # error:69: homing never saw a switch close
    MOTOR_STALLED = "motor_stalled"  # error:67: a driver reported a stall, not recovered
    BUS_TIMEOUT = "bus_timeout"  # the PGF got no reply within bus.reply_timeout_s
    LINE_REFUSED = "line_refused"  # any other error: reply (an unreachable target, ...)
    PROTOCOL = "protocol"  # a reply the host did not expect (an ok with no line outstanding)
    EMERGENCY_STOP = "emergency_stop"  # error:71: the host sent M112


_KIND_OF_CODE = {
    ErrorCode.HOMING_SWITCH_STUCK: FaultKind.SWITCH_STUCK_CLOSED,
    ErrorCode.LIMIT_SWITCH_CLOSED: FaultKind.SWITCH_STUCK_CLOSED,
    ErrorCode.HOMING_SWITCH_NOT_FOUND: FaultKind.SWITCH_NOT_FOUND,
    ErrorCode.MOTOR_STALLED: FaultKind.MOTOR_STALLED,
    ErrorCode.EMERGENCY_STOP: FaultKind.EMERGENCY_STOP,
}


def kind_of_reply(reply: str) -> FaultKind:
    """The fault kind of an ``error:<code> ...`` reply that refused a line."""
    return _KIND_OF_CODE.get(ErrorCode.of_reply(reply), FaultKind.LINE_REFUSED)


@dataclass(frozen=True)
class FaultConfig:
    """Faults to inject (scenario ``[faults]``); the defaults inject none."""

    switch_stuck_closed: int = 0
    """Limit switch 1-4 that always reads closed (stuck lever, shorted wiring); 0: none."""
    switch_dead: int = 0
    """Homing switch 1-3 that never closes (unplugged, broken wire); 0: none."""
    jam_motor: int = 0
    """Motor 1-3 (arm 1, arm 2, Z) whose joint jams; 0: none."""
    jam_at_s: float = 0.0
    """When the jam starts (simulated s)."""
    jam_duration_s: float = 0.0
    """How long it lasts (s)."""
    jam_torque_nm: float = 0.0
    """The jam's resisting torque at the motor shaft (N m): a friction brake on the joint,
    passed to it through the drive (belt ratio; Z: the lead screw). The motor has its
    holding torque to overcome it (Z: times the screw efficiency), less at speed."""
    lost_reply_line: int = 0
    """The SGF's reply to the n-th line it receives is lost on the wire; 0: none."""

    def __post_init__(self) -> None:
        for name, hi in (
            ("switch_stuck_closed", 4), ("switch_dead", 3), ("jam_motor", 3),
            ("lost_reply_line", None),
        ):  # fmt: skip
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f"faults.{name} must be a whole number >= 0, got {value!r}")
            if hi is not None and value > hi:
                raise ValueError(f"faults.{name} must be 0-{hi}, got {value}")
        for name in ("jam_at_s", "jam_duration_s", "jam_torque_nm"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"faults.{name} must be >= 0, got {value!r}")
        if self.switch_stuck_closed and self.switch_stuck_closed == self.switch_dead:
            raise ValueError(
                f"limit switch {self.switch_dead} cannot be both stuck closed and dead: "
                "set faults.switch_stuck_closed or faults.switch_dead to 0"
            )
        if self.jam_motor and not (self.jam_torque_nm > 0 and self.jam_duration_s > 0):
            raise ValueError(
                f"faults.jam_motor = {self.jam_motor} needs faults.jam_torque_nm > 0 and "
                "faults.jam_duration_s > 0 (or set jam_motor to 0: no jam)"
            )

    @property
    def jam_end_s(self) -> float:
        return self.jam_at_s + self.jam_duration_s

    def jam_active(self, t: float) -> bool:
        """Whether the jam holds at time ``t`` (s)."""
        return bool(self.jam_motor) and self.jam_at_s <= t + 1e-12 < self.jam_end_s

    def next_jam_change(self, t: float) -> float | None:
        """When the jam next starts or ends after ``t``; None when it never changes again."""
        if not self.jam_motor:
            return None
        for edge in (self.jam_at_s, self.jam_end_s):
            if t + 1e-12 < edge:
                return edge
        return None

    def switches(self, states: Sequence[bool]) -> tuple[bool, ...]:
        """Limit switch states 1-4 as the firmware reads them with the switch faults."""
        out = [bool(s) for s in states]
        if self.switch_stuck_closed:
            out[self.switch_stuck_closed - 1] = True
        if self.switch_dead:
            out[self.switch_dead - 1] = False
        return tuple(out)


class LostReplyTransport:
    """A ``LineTransport`` that loses the device's reply to the ``line``-th line it received.

    The SGF answers every line with exactly one final reply (``ok`` or ``error:``), in line
    order, so the n-th final reply it sends answers the n-th line; report lines (``M114``,
    ``M119``) still pass. Everything else goes to ``inner``; ``lost`` holds ``(t, reply)``
    of the reply that was lost.
    """

    def __init__(self, inner, line: int):
        if isinstance(line, bool) or not isinstance(line, int) or line < 1:
            raise ValueError(f"line must be a whole number >= 1, got {line!r}")
        self.inner, self.line = inner, line
        self.final_replies = 0
        self.lost: list[tuple[float, str]] = []

    def host_send(self, line: str, now: float) -> None:
        self.inner.host_send(line, now)

    def device_receive(self, now: float) -> list[str]:
        return self.inner.device_receive(now)

    def device_send(self, line: str, now: float) -> None:
        if line == "ok" or line.startswith(("ok ", "error:")):
            self.final_replies += 1
            if self.final_replies == self.line:
                self.lost.append((now, line))
                return
        self.inner.device_send(line, now)

    def host_receive(self, now: float) -> list[str]:
        return self.inner.host_receive(now)

    def next_delivery_time(self) -> float | None:
        return self.inner.next_delivery_time()

    def __getattr__(self, name: str):
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)  # the inner bus's transcript, baud rate, ...
