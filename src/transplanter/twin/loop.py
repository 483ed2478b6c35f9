"""The one loop of every machine on every job: the controller's exchange, then a block of
physics steps, each host -> bus -> controller -> the step's commands -> `mj_step`.

At each exchange, at time t = k * dt, the machine's firmware side is advanced and says how many
physics steps may run before it has something to say again; the loop then steps that block,
one `mj_step` at a time. Two firmware sides exist:

- **host, bus and controller** (given `host`, `bus`, `controller`, `endstops`: the delta's
  controller, the serial arm's servo board): at an exchange
  1. the host program (`machine.host.HostProgram`) takes its replies and sends what is due;
  2. the bus delivers the lines due to the controller, which answers them (its limit switches
     read from the raw pulses of the step before: `SimulatedEndstops`);
  3. the controller's machine events (the conveyor's `M710`) go to `on_event(t_event, name)`;
  4. the raw pulse counts at t (read from a block of the next steps' counts while the
     controller's motion stays the same), then its servo commands go to `on_servo(t,
     commands)`;
  and the block runs to the next step at which any of them has something to do (`_next_due`):
  the host's timer (`Wait`), the bus's next delivery either way, the controller's next event
  (a line done, a queued one started), a servo command's time; one step while the controller
  homes (it reads its switches every step). Each step of the block gets its raw pulse counts
  (`raw`). Nothing happens between those times, so the machine is the one an exchange at every
  step gives, bit for bit (`per_step=True` keeps that, for a controller without
  `next_event_time` and for the test that shows it);
- **event driven** (`exchange=`: the five-bar's SGF, `twin.sim.Twin`): the exchange delivers
  what is due, computes the commands of every step until the next firmware event at once and
  returns their count (`exchange(t, t_limit) -> n`, n >= 1, never past `t_limit`).

Each step of a block (t: its start time, `i`: its index in the block):

5. `before_step(t)`: the hooks that write the step's commands (the robot's drives, the
   effector's servos, the job's conveyor and plug physics), in their order;
6. `mujoco.mj_step`; then `guard(t)`, which may stop the run at once (a state MuJoCo reset:
   the step is not counted and nothing after it runs);
7. the step is counted (k + 1), then `after_step(t)`: the meters, the judges' watches and the
   observers (at (k + 1) * dt, `StepLoop.time`). A hook may `end_block()`: the block's other
   commands are void (a stepper slipped and its driver stopped the SGF) and the next exchange
   comes at once.

After each block, `after_block()` (the five-bar's check of MuJoCo's warnings). A hook may
`stop(reason)` the run: it ends after that step. `run(end)` runs blocks until `end(t)` says so
after one (t: the last step's start) or a hook stopped it; `run_until(t_end, done)` until the
simulated time reaches `t_end` or `done()` after a block; `run_program(limit_s, settle_s)`
until the host's program has ended (or failed) and settled, with a time-out, the end that every
job with a host program shares (a block ends at that step). A hook may `settle_until(t)` to end
the run at t (a drive's alarm: the machine is let come to rest, then the run ends).
`run_steps(n)` steps n times with no firmware at all (a bench whose hooks drive the actuators
themselves: `scene.plug_bench`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

__all__ = ["BLOCK_STEPS", "MAX_BLOCK_STEPS", "StepLoop"]

BLOCK_STEPS = 64
"""Steps of raw pulse counts asked of a host's controller at once (`StepLoop._pulses`)."""
MAX_BLOCK_STEPS = 500
"""The longest block of steps between two exchanges of a host's controller (bounds how late an
exchange with nothing due comes: it changes nothing)."""


class StepLoop:
    """A machine and its physics stepped together (module docstring)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        host: Any = None,
        bus: Any = None,
        controller: Any = None,
        endstops: Any = None,
        machine_events: Callable[[], list] | None = None,
        exchange: Callable[[float, float], int] | None = None,
        per_step: bool = False,
    ) -> None:
        if exchange is not None and controller is not None:
            raise ValueError("give a host's controller or an exchange, not both")
        self.model, self.data = model, data
        self.host, self.bus, self.controller, self.endstops = host, bus, controller, endstops
        self._events = machine_events if machine_events is not None else (lambda: [])
        if exchange is not None:
            self.exchange = exchange
        elif controller is not None:
            timed = hasattr(controller, "next_event_time") and hasattr(controller, "homing")
            events = timed and not per_step
            self.exchange = self._exchange_on_events if events else self._exchange_each_step
        else:
            self.exchange = self._no_firmware
        self.dt = model.opt.timestep
        self.k = 0
        self.i = 0  # the step's index in its block
        self.raw = np.zeros(len(endstops.initial) if endstops is not None else 0, dtype=np.int64)
        self.on_event: list[Callable[[float, str], None]] = []
        self.on_servo: list[Callable[[float, list], None]] = []
        self.before_step: list[Callable[[float], None]] = []
        self.after_step: list[Callable[[float], None]] = []
        self.after_block: list[Callable[[], None]] = []
        self.guard: Callable[[float], str | None] | None = None
        self.stopped: str | None = None
        self.last_t = 0.0
        self.t_end: float | None = None  # run_program ends the run after the step at t_end
        self._end_block = False
        self._block: tuple[int, int, np.ndarray] | None = None  # first step, version, counts
        self._raw_each_step = False  # a block of several steps: `raw` read at each one
        self._servo_times: list[float] = []  # the drained servo commands' times still ahead
        self._program: tuple[float, float] | None = None  # run_program's (settle_s, limit_s)

    @property
    def time(self) -> float:
        """Simulated time now: k * dt."""
        return self.k * self.dt

    def stop(self, reason: str) -> None:
        """End the run after the step in progress (the first reason is kept)."""
        if self.stopped is None:
            self.stopped = reason

    def end_block(self) -> None:
        """End the block after the step in progress: the next exchange comes at once."""
        self._end_block = True

    # -- the firmware side -----------------------------------------------------------------
    def _exchange_each_step(self, t: float, t_limit: float) -> int:
        """The host's, the bus's and the controller's exchange (module docstring, 1-4): a block
        of one step (`per_step=True`, or a controller that does not say when it is due)."""
        controller, bus = self.controller, self.bus
        self.host.tick(t)
        for line in bus.device_receive(t):
            controller.receive(line, t)
        for reply in controller.poll(t, self.endstops.read(self.raw)):
            bus.device_send(reply, t)
        if self.on_event:
            for t_event, name in self._events():
                for fn in self.on_event:
                    fn(t_event, name)
        self.raw = self._pulses(self.k, t)
        commands = controller.drain_servo_commands()
        for fn in self.on_servo:
            fn(t, commands)
        if commands:
            self._servo_times = sorted([*self._servo_times, *(c[0] for c in commands)])
        return 1

    def _exchange_on_events(self, t: float, t_limit: float) -> int:
        """The host's, the bus's and the controller's exchange (module docstring, 1-4), then a
        block of steps to the next step at which one of them has something due."""
        self._exchange_each_step(t, t_limit)
        n = self._steps_to(self._next_due(t))
        if not math.isinf(t_limit):
            n = min(n, max(1, math.ceil((t_limit - t) / self.dt - 1e-9)))
        self._raw_each_step = n > 1
        return n

    def _next_due(self, t: float) -> float:
        """When the host, the bus or the controller next has something to do (after `t`,
        where the exchange has done what was due); `t`: at the next step (homing);
        inf: nothing in flight."""
        host, controller = self.host, self.controller
        if controller.homing:
            return t
        due = [math.inf]
        if not host.done and not host.waiting:
            due.append(host.resume_at)  # its timer (a Wait): the only thing it waits for
        for x in (self.bus.next_delivery_time(), controller.next_event_time()):
            if x is not None:
                due.append(x)
        times = self._servo_times
        while times and times[0] <= t:
            times.pop(0)
        if times:
            due.append(times[0])  # a servo command comes due: its board applies it then
        return min(due)

    def _steps_to(self, t_due: float) -> int:
        """Steps from now to the first step whose start is at or after `t_due` (every
        firmware side compares `time >= t_due` at a step's start), at least 1, at most
        MAX_BLOCK_STEPS."""
        k, dt = self.k, self.dt
        if not t_due < (k + MAX_BLOCK_STEPS) * dt:
            return MAX_BLOCK_STEPS
        k_due = max(k + 1, math.ceil(t_due / dt))
        while k_due - 1 > k and (k_due - 1) * dt >= t_due:
            k_due -= 1
        while k_due * dt < t_due:
            k_due += 1
        return min(k_due - k, MAX_BLOCK_STEPS)

    def _no_firmware(self, t: float, t_limit: float) -> int:
        """No firmware: one block to `t_limit` (one step when it is unbounded)."""
        if math.isinf(t_limit):
            return 1
        return max(1, math.ceil((t_limit - t) / self.dt - 1e-9))

    # -- stepping --------------------------------------------------------------------------
    def _run_block(self, n: int) -> bool:
        """Up to n physics steps (module docstring, 5-7); False when the guard stopped."""
        model, data, dt = self.model, self.data, self.dt
        before, after, guard = self.before_step, self.after_step, self.guard
        self._end_block = False
        raw_each_step, program = self._raw_each_step, self._program
        for i in range(n):
            t = self.k * dt
            self.last_t, self.i = t, i
            if i and raw_each_step:
                self.raw = self._pulses(self.k, t)
            for fn in before:
                fn(t)
            mujoco.mj_step(model, data)
            if guard is not None:
                reason = guard(t)
                if reason is not None:
                    self.stop(reason)
                    return False
            self.k += 1
            for fn in after:
                fn(t)
            if self._end_block or self.stopped is not None:
                break
            if program is not None and self._program_ends(t, *program):
                break
        return True

    def advance(self, t_limit: float = math.inf) -> bool:
        """One exchange and its block of steps (never past `t_limit`), then `after_block`;
        False when the guard stopped it."""
        t = self.k * self.dt
        self.last_t = t
        if not self._run_block(self.exchange(t, t_limit)):
            return False
        for fn in self.after_block:
            fn()
        return True

    def step(self) -> bool:
        """`advance()`: one exchange and its block of steps."""
        return self.advance()

    def _pulses(self, k: int, t: float) -> np.ndarray:
        """The raw pulse counts at step k (time t): from the block of the next BLOCK_STEPS
        steps' counts asked of the controller at once, while its `motion_version` stays the
        same (one `pulses_at` of 64 times instead of 64 of one: the same integers, a
        binary search per motor each); a controller without it is asked at every step."""
        version = getattr(self.controller, "motion_version", None)
        block = self._block
        if version is not None and block is not None and block[1] == version:
            i = k - block[0]
            if 0 <= i < len(block[2]):
                return block[2][i]
        if version is None:
            self._block = None
            return self.controller.pulses_at(t)[0]
        rows = self.controller.pulses_at(np.arange(k, k + BLOCK_STEPS, dtype=np.float64) * self.dt)
        self._block = (k, version, rows)
        return rows[0]

    def settle_until(self, t: float) -> None:
        """`run_program` ends the run after the step that starts at `t` (replacing the end
        the host's finish set)."""
        self.t_end = t

    def run_program(self, limit_s: float, settle_s: float = 0.0, what: str = "the program"
                    ) -> str | None:  # fmt: skip
        """Run blocks until the host's program has ended or failed and `settle_s` more have
        passed (or until a hook's `settle_until`), or a hook stopped the run; the time-out's
        message when a block's last step starts after `limit_s` (s of simulated time), else
        None."""
        self._program = (settle_s, limit_s)  # a block ends at the step the run does
        try:
            while self.stopped is None:
                if not self.advance():
                    return None
                if self._program_ends(self.last_t, settle_s, limit_s):
                    if self.t_end is not None and self.last_t >= self.t_end:
                        return None
                    return f"{what} did not finish in {limit_s:g} s of simulated time"
            return None
        finally:
            self._program = None

    def _program_ends(self, t: float, settle_s: float, limit_s: float) -> bool:
        """After the step that started at `t`: whether `run_program`'s run ends there (the
        host's program ended or failed `settle_s` before, a hook's `settle_until`, or the
        time-out at `limit_s`)."""
        host = self.host
        if self.t_end is None and (host.done or host.error is not None):
            self.t_end = t + settle_s
        return (self.t_end is not None and t >= self.t_end) or t > limit_s

    def run(self, end: Callable[[float], bool]) -> None:
        """Run blocks until `end(t)` after one (t: its last step's start) or a hook stopped
        the run."""
        while self.stopped is None:
            if not self.advance():
                return
            if end(self.last_t):
                return

    def run_until(self, t_end: float, done: Callable[[], bool] | None = None) -> None:
        """Run blocks until the simulated time reaches `t_end` (s), `done()` after a block, or
        a hook stopped the run."""
        while self.stopped is None and self.k * self.dt < t_end - 1e-12:
            if not self.advance(t_end):
                return
            if done is not None and done():
                return

    def run_steps(self, n: int) -> None:
        """n physics steps with no exchange (fewer if a hook stopped the run), then
        `after_block`."""
        if self._run_block(n):
            for fn in self.after_block:
                fn()
