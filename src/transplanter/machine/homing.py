"""Homing (G28) of an arm's axes, like grbl's limits.c: seek, pull off, locate, pull off.

The axes of ``HomingConfig.first_cycle`` first (Z on the five-bar, grbl's default cycle order
HOMING_CYCLE_0 = Z), then the others at once; or every axis at once. Each axis: seek its limit
switch at ``rate_hz`` until the switch reads closed, pull off ``pulloff_steps``, then locate it
again slowly at ``locate_rate_hz`` (the switch must read open first). The fast seek trips late (the
motor lags its command, the switch is read once per poll); the slow locate cuts that error
about tenfold. At the locate trip the SGF sets the logical counter to the switch position;
then the final pull-off. Homing fails, stopping every motor where it is, with a message
naming the switch and the likely cause (``Homing.failure_code`` is the reply's code):

- ``HOMING_SWITCH_NOT_FOUND`` (error:69, grbl's ALARM:9): the seek travelled
  ``max_steps`` without the switch closing (a dead or unplugged switch, or the axis
  blocked before it), or a switch that closed in the seek never closed again in the slow
  locate (an intermittent switch);
- ``HOMING_SWITCH_STUCK`` (error:68, grbl's ALARM:8): the switch still reads closed after the
  pull-off (a switch stuck closed or shorted wiring; also named when it was already closed
  as homing began), checked until the locate has travelled its ``locate_scalar``
  pull-offs.

The SGF reads the switches at each poll and hands them to :meth:`Homing.update`; the raw
pulses of every motor at any time come from :meth:`Homing.pulses`, in closed form.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from transplanter.errors import ErrorCode
from transplanter.machine.axes import Axis

__all__ = ["Homing", "HomingConfig"]

_FLOOR_EPS = 1e-9  # keeps floor(k / rate * rate) at k despite rounding

PULLOFF_JOINT = (math.radians(3.6), 0.001)
"""Default pull-off of a rotary axis (rad) and of a slide (m)."""
MAX_SEEK_JOINT = (math.pi, 0.200)
"""Default longest seek of a rotary axis (rad) and of a slide (m)."""


@dataclass(frozen=True)
class HomingConfig:
    """How G28 homes each axis (one value per axis, in motor order; SI and steps)."""

    rate_hz: tuple[float, ...] = (1600.0, 1600.0, 8000.0)
    """Step rate of each axis while it seeks its switch and pulls off."""
    locate_rate_hz: tuple[float, ...] | None = None
    """Step rate of the slow second approach (locate); None: rate_hz / 10."""
    dirs: tuple[int, ...] = (+1, -1, +1)
    """Direction (+1/-1 in step counts) in which each axis seeks its switch."""
    first_cycle: tuple[int, ...] | None = (2,)
    """Axes homed alone first, the rest after them together (grbl's HOMING_CYCLE_0 = Z: jaws
    that stopped among the pots rise clear before the arms swing); None: all at once."""
    pulloff_steps: tuple[int, ...] | None = None
    """Steps each axis backs off its switch after it trips; None: 3.6 deg of a rotary joint
    and 1 mm of a slide in its drive's steps (96, 96, 400 with the five-bar's drives)."""
    max_steps: tuple[int, ...] | None = None
    """Longest seek before homing fails; None: half a rotary joint's revolution and 200 mm of
    a slide in its drive's steps (4800, 4800, 80000 with the five-bar's drives)."""
    debounce_s: float = 0.25
    """Dwell after a switch trips before the pull-off (grbl's $26 homing debounce, 250 ms by
    default): the axis stops at the trip and comes to rest before it reverses."""
    locate_scalar: float = 5.0
    """The locate fails after this many pull-off distances (grbl's HOMING_AXIS_LOCATE_SCALAR)."""

    def resolved(self, axes: Sequence[Axis]) -> HomingConfig:
        """This config with every None filled in from the axes' drives, checked: ValueError
        naming the first bad setting."""
        per_unit = [axis.drive.steps_per_unit for axis in axes]
        filled = {}
        if self.pulloff_steps is None:
            joint = [PULLOFF_JOINT[axis.linear] for axis in axes]
            filled["pulloff_steps"] = tuple(
                max(1, round(u * q)) for u, q in zip(per_unit, joint, strict=True)
            )
        if self.max_steps is None:
            joint = [MAX_SEEK_JOINT[axis.linear] for axis in axes]
            filled["max_steps"] = tuple(
                max(1, round(u * q)) for u, q in zip(per_unit, joint, strict=True)
            )
        if self.locate_rate_hz is None:
            filled["locate_rate_hz"] = tuple(float(r) / 10.0 for r in self.rate_hz)
        config = replace(self, **filled)
        config.check(len(axes))
        return config

    def check(self, n_axes: int) -> None:
        """ValueError naming the first bad setting for an arm of ``n_axes`` axes."""
        for name in ("rate_hz", "locate_rate_hz", "dirs", "pulloff_steps", "max_steps"):
            if len(getattr(self, name)) != n_axes:
                raise ValueError(f"homing {name} needs one value per axis ({n_axes})")
        for name in ("rate_hz", "locate_rate_hz"):
            rates = getattr(self, name)
            if not all(math.isfinite(r) and r > 0 for r in rates):
                raise ValueError(f"homing {name} must be > 0, got {rates}")
        if any(d not in (-1, 1) for d in self.dirs):
            raise ValueError(f"homing dirs must be +1 or -1, got {self.dirs}")
        if any(int(p) != p or p < 1 for p in self.pulloff_steps):
            raise ValueError(
                "homing pulloff_steps must be integers >= 1 (the locate starts "
                "from a switch that the pull-off has opened)"
            )
        if not (math.isfinite(self.debounce_s) and self.debounce_s >= 0):
            raise ValueError(f"homing debounce_s must be >= 0, got {self.debounce_s}")
        if not (math.isfinite(self.locate_scalar) and self.locate_scalar > 1):
            raise ValueError(f"homing locate_scalar must be > 1, got {self.locate_scalar}")
        if any(int(p) != p or p < 1 for p in self.max_steps):
            raise ValueError("homing max_steps must be integers >= 1")
        if self.first_cycle is not None and not all(
            isinstance(a, int) and 0 <= a < n_axes for a in self.first_cycle
        ):
            raise ValueError(
                f"homing first_cycle must name axes 0..{n_axes - 1}, got {self.first_cycle}"
            )

    @property
    def cycles(self) -> list[list[int]]:
        """The homing cycles of ``len(rate_hz)`` axes in order (each a list of axes)."""
        every = list(range(len(self.rate_hz)))
        if self.first_cycle is None:
            return [every]
        rest = [a for a in every if a not in self.first_cycle]
        return [list(self.first_cycle)] + ([rest] if rest else [])


class Homing:
    """Raw pulses of every axis's motor during G28, in closed form (grbl's limits.c).

    Each motor runs a list of legs ``(t_start, raw_start, direction, rate_hz, max_steps)``;
    a leg lasts until the next one starts. Phases per motor: 0 seek, 1 pull-off then locate,
    2 final pull-off (or stopped after a failure).
    """

    def __init__(self, config: HomingConfig, axes: Sequence[Axis], t0: float, raw0: np.ndarray):
        """Start homing ``axes`` at ``t0`` from raw pulse counts ``raw0`` with a resolved
        ``config`` (:meth:`HomingConfig.resolved`)."""
        n = self.n = len(axes)
        self.axes = tuple(axes)
        self.seek_rate = np.asarray(config.rate_hz, dtype=np.float64)
        self.locate_rate = np.asarray(config.locate_rate_hz, dtype=np.float64)
        self.dirs = np.asarray(config.dirs, dtype=np.int64)
        self.max_steps = np.asarray(config.max_steps, dtype=np.int64)
        self.pulloff = np.asarray(config.pulloff_steps, dtype=np.int64)
        self.locate_max_steps = np.ceil(config.locate_scalar * self.pulloff).astype(np.int64)
        self.debounce_s = float(config.debounce_s)
        self.legs = [
            [
                (
                    t0,
                    int(raw0[m]),
                    int(self.dirs[m]),
                    float(self.seek_rate[m]),
                    int(self.max_steps[m]),
                )
            ]
            for m in range(n)
        ]
        self.phase = np.zeros(n, dtype=np.int64)
        # Phase -1: waiting (holding still) for the first cycle's motors to finish.
        self.first_cycle = config.cycles[0]
        for m in range(n):
            if m not in self.first_cycle:
                self.legs[m] = [(t0, int(raw0[m]), 1, 0.0, 0)]
                self.phase[m] = -1
        self.t_locate = np.full(n, np.inf)
        self.cleared = np.zeros(n, dtype=bool)  # switch read open since the locate began
        self.t_end = np.full(n, np.inf)
        self.trip_raw = np.zeros(n, dtype=np.int64)
        self.seek_steps = np.zeros(n, dtype=np.int64)  # steps each seek travelled to its trip
        self.failed = False
        self.failure_code: ErrorCode | None = None
        self._changed = True  # the last update changed the plan: poll again next step
        self._travel = [
            (math.degrees(d.unit_per_step), "deg")
            if not d.linear
            else (d.unit_per_step * 1e3, "mm")
            for d in (axis.drive for axis in axes)
        ]

    def _motor(self, motor: int, t: np.ndarray) -> np.ndarray:
        t_start, raw_start, direction, rate, count = (
            np.array(column) for column in zip(*self.legs[motor], strict=True)
        )
        leg = np.maximum(np.searchsorted(t_start, t, side="right") - 1, 0)
        n = np.floor((t - t_start[leg]) * rate[leg] + _FLOOR_EPS)
        n = np.clip(n, 0, count[leg]).astype(np.int64)
        return raw_start[leg] + direction[leg] * n

    def pulses(self, t: np.ndarray) -> np.ndarray:
        """Raw pulse counts of the motors at times t, shape (len(t), n_axes)."""
        return np.stack([self._motor(m, t) for m in range(self.n)], axis=1)

    def _raw(self, motor: int, t: float) -> int:
        return int(self._motor(motor, np.array([t]))[0])

    def _exhausted(self, motor: int, t: float) -> bool:
        t_start, raw_start, direction, _, count = self.legs[motor][-1]
        return t >= t_start and self._raw(motor, t) == raw_start + direction * count

    def _pull_off(self, motor: int, t: float) -> int:
        """Stop the motor at its switch's trip at t and back off after the debounce; the raw
        count at the trip."""
        raw = self._raw(motor, t)
        steps = int(self.pulloff[motor])
        if self.debounce_s > 0:
            self.legs[motor].append((t, raw, 1, 0.0, 0))
        self.legs[motor].append(
            (t + self.debounce_s, raw, -int(self.dirs[motor]), float(self.seek_rate[motor]), steps)
        )
        return raw

    def update(self, now: float, endstops: Sequence[bool] | None) -> str | None:
        """Act on the switches read at ``now``; a failure message if homing failed."""
        before = (self.phase.copy(), self.cleared.copy(), [len(leg) for leg in self.legs])
        try:
            return self._update(now, endstops)
        finally:
            self._changed = not (
                np.array_equal(before[0], self.phase)
                and np.array_equal(before[1], self.cleared)
                and before[2] == [len(leg) for leg in self.legs]
            )

    def next_poll_time(self, now: float, dt: float) -> float:
        """When the switches must be read again if they read as they did at ``now`` (a
        caller that sees every change of them polls then, or at the change): the next
        step after any change of state, every step within two steps of a time-based
        condition (the slow locate begins, a leg runs out of steps), otherwise a step
        before it; inf once every switch is found."""
        if self.done_seeking:
            return math.inf
        if self._changed:
            return now + dt
        events = [math.inf]
        for motor in range(self.n):
            if self.phase[motor] not in (0, 1):
                continue
            t_start, _, _, rate, count = self.legs[motor][-1]
            if rate > 0:
                events.append(t_start + count / rate)  # `_exhausted` from then on
            if self.phase[motor] == 1 and now < self.t_locate[motor]:
                events.append(float(self.t_locate[motor]))
        t_event = min(events)
        return now + dt if t_event - now <= 2 * dt else t_event - dt

    def _update(self, now: float, endstops: Sequence[bool] | None) -> str | None:
        waiting = np.flatnonzero(self.phase == -1)
        if waiting.size and np.all(self.phase[self.first_cycle] == 2):
            t_start = float(np.max(self.t_end[self.first_cycle]))
            for motor in waiting:  # the next cycle seeks once the first has pulled off
                m = int(motor)
                raw = int(self.legs[m][-1][1])
                self.legs[m].append(
                    (
                        t_start,
                        raw,
                        int(self.dirs[m]),
                        float(self.seek_rate[m]),
                        int(self.max_steps[m]),
                    )
                )
                self.phase[m] = 0
        for motor in range(self.n):
            closed = endstops is not None and bool(endstops[motor])
            direction = int(self.dirs[motor])
            if self.phase[motor] == 0:
                if closed:
                    seek_start = self.legs[motor][-1][1]
                    raw = self._pull_off(motor, now)
                    self.seek_steps[motor] = abs(raw - seek_start)
                    self.t_locate[motor] = (
                        now + self.debounce_s + self.pulloff[motor] / self.seek_rate[motor]
                    )
                    self.legs[motor].append(
                        (
                            float(self.t_locate[motor]),
                            raw - direction * int(self.pulloff[motor]),
                            direction,
                            float(self.locate_rate[motor]),
                            int(self.locate_max_steps[motor]),
                        )
                    )
                    self.phase[motor] = 1
                elif self._exhausted(motor, now):
                    steps = int(self.max_steps[motor])
                    return self._fail(
                        now,
                        ErrorCode.HOMING_SWITCH_NOT_FOUND,
                        f"{self._switch(motor)} not found: motor {motor + 1} travelled {steps} "
                        f"steps ({self._distance(motor, steps)}) towards it and it never "
                        "closed; the switch is dead or unplugged (M119 shows it open even "
                        "when pressed), or the axis is blocked before it; check the switch, "
                        "its wiring, the axis and the homing direction (HomingConfig.dirs)",
                    )
            elif self.phase[motor] == 1 and now >= self.t_locate[motor]:
                if endstops is not None and not closed:
                    self.cleared[motor] = True
                elif closed and self.cleared[motor]:
                    self.trip_raw[motor] = self._pull_off(motor, now)
                    self.t_end[motor] = (
                        now + self.debounce_s + self.pulloff[motor] / self.seek_rate[motor]
                    )
                    self.phase[motor] = 2
                    continue
                if self._exhausted(motor, now):
                    steps = int(self.locate_max_steps[motor])
                    if self.cleared[motor]:
                        return self._fail(
                            now,
                            ErrorCode.HOMING_SWITCH_NOT_FOUND,
                            f"{self._switch(motor)} closed in the seek but not again within "
                            f"{steps} steps ({self._distance(motor, steps)}) of the slow "
                            "locate: an intermittent switch (a loose wire, a bouncing "
                            "contact); check the switch and its wiring",
                        )
                    pulloff = int(self.pulloff[motor])
                    already = (
                        " (it was already closed when homing began)"
                        if self.seek_steps[motor] == 0
                        else ""
                    )
                    return self._fail(
                        now,
                        ErrorCode.HOMING_SWITCH_STUCK,
                        f"{self._switch(motor)} still closed after the {pulloff}-step pull-off"
                        f"{already}: the switch is stuck closed or its wiring is shorted (M119 "
                        "shows it TRIGGERED), or the axis stands beyond it (steps lost since "
                        "the last homing); check the switch and its wiring, or move the axis off "
                        "the switch and home again",
                    )
        return None

    def _switch(self, motor: int) -> str:
        return f"limit switch {motor + 1} ({self.axes[motor].switch_name})"

    def _distance(self, motor: int, steps: int) -> str:
        per_step, unit = self._travel[motor]
        return f"{steps * per_step:.1f} {unit}"

    def _fail(self, now: float, code: ErrorCode, message: str) -> str:
        """Stop the motors still seeking or locating where they are."""
        self.failed = True
        self.failure_code = code
        for motor in np.flatnonzero(self.phase < 2):
            self.legs[motor].append((now, self._raw(int(motor), now), 1, 0.0, 0))
            self.t_end[motor] = now
            self.phase[motor] = 2
        return message

    @property
    def done_seeking(self) -> bool:
        """Every motor has found its switch (or homing failed): only pull-offs remain."""
        return bool(np.all(self.phase == 2))

    @property
    def t_done(self) -> float:
        """When the last motor ends its final pull-off (inf while still seeking)."""
        return float(np.max(self.t_end))
