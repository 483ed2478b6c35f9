"""PGF -> bus -> SGF on a simulated clock, without physics.

``FirmwareLink`` is one exchange of traffic between the three at a time t, and when the
next one is due; the physics twin and ``run_firmware`` both drive it. ``run_firmware``
jumps from event to event (a bus delivery, the end of the SGF's current line) and steps
``dt_homing_s`` only while the SGF homes, reading the limit switches from
``SimulatedEndstops``, which places each switch at the SGF's home position and computes the
motors' joint positions from their raw pulses since power-on. ``DirectLink`` is the SGF
answering one line at a time straight from its host, without the bus (the planner's and the
HMI's way of driving it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from transplanter.machine.bus import LineTransport
from transplanter.machine.faults import FaultConfig
from transplanter.machine.pgf import PGF, SentLine
from transplanter.machine.sgf import SGF, SGFConfig

DT_HOMING_S = 1e-3
"""How often the limit switches are read while the SGF homes, without physics (s)."""


class SimulatedEndstops:
    """Limit switches computed from raw pulses: a switch is closed at or past its trip point.

    One homing switch per axis (the five-bar's 1, 2, 3) trips where the SGF's homing expects it
    (the axis's home position, approached in the homing direction); then each lower hard
    limit of the kinematics (the five-bar's switch 4, Z down) trips at or below its axis's
    window start, or ``z_down_trip_m`` where given. ``faults`` (a
    ``machine.faults.FaultConfig``) makes a switch read stuck closed or dead.
    """

    def __init__(
        self,
        sgf_config: SGFConfig,
        initial_joint_positions: Sequence[float],
        z_down_trip_m: float | None = None,
        faults: FaultConfig | None = None,
    ):
        self.config = sgf_config
        self.faults = faults
        kinematics = sgf_config.kinematics
        n = kinematics.n_axes
        self.initial = np.asarray(initial_joint_positions, dtype=np.float64)
        if self.initial.shape != (n,) or not np.isfinite(self.initial).all():
            raise ValueError(
                f"initial_joint_positions must be {n} finite joint positions (rad or m), one "
                "per axis"
            )
        self.unit_per_step = np.array([d.unit_per_step for d in sgf_config.drives])
        self.trip = np.asarray(sgf_config.home_joint_positions, dtype=np.float64)
        self.dirs = np.asarray(sgf_config.homing.dirs, dtype=np.float64)
        self.hard_limits = [
            (axis, kinematics.axes[axis].window[0]) for axis, _ in kinematics.lower_hard_limits
        ]
        if z_down_trip_m is not None and self.hard_limits:
            self.hard_limits[0] = (self.hard_limits[0][0], float(z_down_trip_m))
        self._trip: list[int] | None = None  # trip_pulses(), once read() needs it
        self._dirs: list[int] = []
        beyond = (self.initial - self.trip) * self.dirs > 0
        if beyond.any():
            raise ValueError(
                f"motor {int(np.flatnonzero(beyond)[0]) + 1} starts beyond its limit switch"
            )

    @property
    def z_down_trip_m(self) -> float:
        """Where the first lower hard limit (the five-bar's switch 4, Z down) trips."""
        return self.hard_limits[0][1]

    def joint_positions(self, raw_pulses) -> np.ndarray:
        """(..., n_axes) joint positions for (..., n_axes) raw pulse counts."""
        return self.initial + np.asarray(raw_pulses) * self.unit_per_step

    def trip_pulses(self) -> np.ndarray:
        """Fewest raw pulses (signed, in the homing direction) that close the homing switches."""
        exact = (self.trip - self.initial) / self.unit_per_step
        return (self.dirs * np.ceil(np.abs(exact) - 1e-9)).astype(np.int64)

    def read(self, raw_pulses) -> tuple[bool, ...]:
        """Switch states (the homing switches, then the hard limits) at raw pulse counts."""
        if self._trip is None:  # fixed by the config: worked out once (read every step)
            self._trip = self.trip_pulses().tolist()
            self._dirs = self.dirs.astype(np.int64).tolist()
        raw = np.asarray(raw_pulses, dtype=np.int64)
        closed = [(r - t) * d >= 0 for r, t, d in zip(raw.tolist(), self._trip, self._dirs,
                                                      strict=True)]  # fmt: skip
        if self.hard_limits:
            joints = self.joint_positions(raw)
            closed += [bool(joints[axis] <= trip) for axis, trip in self.hard_limits]
        states = tuple(closed)
        return states if self.faults is None else self.faults.switches(states)


class NoAnswer(RuntimeError):
    """The SGF did not answer a line: nothing left to wait for, or not by the deadline."""


class DirectLink:
    """An SGF answering one line at a time on a simulated clock, without the bus's timing.

    ``send`` delivers a line at ``t`` and advances the clock until the SGF has answered it
    (``ok`` or ``error:N``): from event to event, and at most ``dt_homing_s`` at a time while
    it homes, reading the limit switches of ``endstops`` at every step. ``pulses`` is the raw
    pulse count of the 3 motors at ``t``.
    """

    def __init__(self, sgf: SGF, endstops: SimulatedEndstops, dt_homing_s: float = DT_HOMING_S):
        self.sgf = sgf
        self.endstops = endstops
        self.dt_homing_s = dt_homing_s
        self.t = 0.0
        self._pulses: np.ndarray | None = None  # raw pulses at t, once computed

    @property
    def pulses(self) -> np.ndarray:
        """Raw pulse counts of the 3 motors at ``t``."""
        if self._pulses is None:
            self._pulses = self.sgf.pulses_at(np.array([self.t]))[0]
        return self._pulses

    def send(self, line: str, until_s: float = math.inf) -> list[str]:
        """The SGF's replies to ``line``, the last one its ``ok`` or ``error:N``; NoAnswer if
        it has nothing left to wait for, or would answer only after ``until_s``."""
        sgf = self.sgf
        sgf.receive(line, self.t)  # receive() adds no motion: the pulses at t are still these
        replies: list[str] = []
        while True:
            replies.extend(sgf.poll(self.t, self.endstops.read(self.pulses)))
            self._pulses = None  # the poll may have started or ended a segment at t
            if replies and (replies[-1] == "ok" or replies[-1].startswith("error:")):
                if not sgf.busy:
                    break
            t_next = sgf.next_event_time()
            if sgf.homing:
                t_homing = self.t + self.dt_homing_s
                t_next = t_homing if t_next is None else min(t_next, t_homing)
            if t_next is None or t_next > until_s:
                raise NoAnswer(f"the SGF did not answer {line!r} (t = {self.t:.3f} s)")
            self.t = max(self.t, t_next)
        sgf.forget_before(self.t)  # the clock only moves on: constant memory per line
        return replies


class FirmwareLink:
    """The PGF and the SGF talking over a bus, advanced one exchange at a time.

    ``log``, if given, gets ``(t, 'pgf> line' | 'sgf< line' | 'sgf> reply' | 'pgf< reply')``
    for every line that moves.
    """

    def __init__(
        self,
        pgf: PGF,
        bus: LineTransport,
        sgf: SGF,
        log: list[tuple[float, str]] | None = None,
        device=None,
    ):
        self.pgf, self.bus, self.sgf = pgf, bus, sgf
        self.log = log
        # what receives the host's lines and answers them: the SGF itself, or a dialect layer
        # in front of it with the same receive/poll (machine.marlin.MarlinDevice)
        self.device = sgf if device is None else device

    def _note(self, t: float, text: str) -> None:
        if self.log is not None:
            self.log.append((t, text))

    def exchange(self, t: float, endstops: Sequence[bool] | None = None) -> list[SentLine]:
        """At time t: bus -> SGF, SGF poll with the switches read at t (None: not read),
        replies -> bus, bus -> PGF, PGF poll, its line -> bus. Returns the lines the PGF
        sent at t."""
        pgf, bus, device = self.pgf, self.bus, self.device
        for line in bus.device_receive(t):
            self._note(t, f"sgf< {line}")
            device.receive(line, t)
        for reply in device.poll(t, endstops):
            self._note(t, f"sgf> {reply}")
            bus.device_send(reply, t)
        replies = bus.host_receive(t)
        for reply in replies:
            self._note(t, f"pgf< {reply}")
        n_sent = len(pgf.sent)
        for line in pgf.poll(t, replies):
            self._note(t, f"pgf> {line}")
            bus.host_send(line, t)
        return pgf.sent[n_sent:]

    def next_event_time(
        self, t: float, dt_homing_s: float, switches_watched: bool = False
    ) -> float | None:
        """When the next exchange is due: the next bus delivery, SGF event or the PGF's reply
        timeout, at the latest t + dt_homing_s while the SGF homes (it must read its
        switches); None when nothing is in flight. A caller that exchanges as soon as a
        switch changes (`switches_watched`) is told the homing's own next poll instead."""
        host_deadline = self.pgf.next_event_time()  # its reply timeout (None: none running)
        candidates = [
            x
            for x in (self.bus.next_delivery_time(), self.sgf.next_event_time(), host_deadline)
            if x is not None
        ]
        if self.sgf.homing:
            poll = self.sgf.homing_poll_time(t, dt_homing_s) if switches_watched else None
            candidates.append(t + dt_homing_s if poll is None else poll)
        return min(candidates) if candidates else None


@dataclass
class RigResult:
    """What ``run_firmware`` did: the time-stamped traffic and how it ended."""

    events: list[tuple[float, str]]
    """(t, 'pgf> line' | 'sgf< line' | 'sgf> reply' | 'pgf< reply')."""
    end_time_s: float
    done: bool
    fault: str | None


def run_firmware(
    pgf: PGF,
    bus: LineTransport,
    sgf: SGF,
    endstops: SimulatedEndstops | None = None,
    dt_homing_s: float = DT_HOMING_S,
    until_s: float = 1e4,
) -> RigResult:
    """Run the firmwares until the PGF is done or faults; RuntimeError on a stall or timeout."""
    if not (math.isfinite(dt_homing_s) and dt_homing_s > 0):
        raise ValueError(f"dt_homing_s must be > 0, got {dt_homing_s!r}")
    events: list[tuple[float, str]] = []
    link = FirmwareLink(pgf, bus, sgf, log=events)
    t = 0.0
    while True:
        switches = endstops.read(sgf.pulses_at(t)[0]) if endstops is not None else None
        link.exchange(t, switches)
        if pgf.done or pgf.fault is not None:
            return RigResult(events, t, pgf.done, pgf.fault)
        t_next = link.next_event_time(t, dt_homing_s)
        if t_next is None:
            raise RuntimeError(f"firmware stalled at t={t:.6f} s: nothing in flight, PGF not done")
        if t_next <= t:
            raise RuntimeError(f"firmware made no progress at t={t:.6f} s")
        if t_next > until_s:
            raise RuntimeError(f"firmware still running at until_s={until_s} s")
        t = t_next
