"""One physics step at a time: host -> bus -> controller -> the step's commands -> `mj_step`.

The loop of every job whose controller is not the five-bar's SGF stepped in blocks
(`twin.sim.Twin`): the delta's trays (`twin.delta_refill`) and its pot line
(`twin.delta_pots`), the serial arm's jobs (`twin.serial_arm`, `twin.serial_pots`). At each
physics step, at its start time t = k * dt:

1. the host program (`machine.host.HostProgram`) takes its replies and sends what is due;
2. the bus delivers the lines due to the controller, which answers them (its limit switches
   read from the raw pulses of the step before: `SimulatedEndstops`);
3. the controller's machine events (the conveyor's `M710`) go to `on_event(t_event, name)`;
4. the raw pulse counts at t (read from a block of the next steps' counts while the
   controller's motion stays the same), then its servo commands go to `on_servo(t,
   commands)`;
5. `before_step(t)`: the hooks that write the step's commands (the robot's drives, the
   effector's servos, the job's conveyor and plug physics), in their order;
6. `mujoco.mj_step`; then `guard(t)`, which may stop the run at once (a state MuJoCo reset:
   the step is not counted and nothing after it runs);
7. the step is counted (k + 1), then `after_step(t)`: the meters, the judges' watches and the
   observers (at (k + 1) * dt, `StepLoop.time`).

A hook may `stop(reason)` the run: it ends after that step. `run(end)` steps until `end(t)`
says so after a step (t: the step's start) or a hook stopped it; `run_program(limit_s,
settle_s)` until the host's program has ended (or failed) and settled, with a time-out, the
end every job's run shares. A hook may `settle_until(t)` to end the run at t (a drive's alarm:
the machine is let come to rest, then the run ends).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

__all__ = ["BLOCK_STEPS", "StepLoop"]

BLOCK_STEPS = 64
"""Steps of raw pulse counts asked of the controller at once (`StepLoop._pulses`)."""


class StepLoop:
    """A job's machine and physics stepped together (module docstring)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        host: Any,
        bus: Any,
        controller: Any,
        endstops: Any,
        machine_events: Callable[[], list] | None = None,
    ) -> None:
        self.model, self.data = model, data
        self.host, self.bus, self.controller, self.endstops = host, bus, controller, endstops
        self._events = machine_events if machine_events is not None else (lambda: [])
        self.dt = model.opt.timestep
        self.k = 0
        self.raw = np.zeros(len(endstops.initial), dtype=np.int64)  # the pulses at power-on
        self.on_event: list[Callable[[float, str], None]] = []
        self.on_servo: list[Callable[[float, list], None]] = []
        self.before_step: list[Callable[[float], None]] = []
        self.after_step: list[Callable[[float], None]] = []
        self.guard: Callable[[float], str | None] | None = None
        self.stopped: str | None = None
        self.last_t = 0.0
        self.t_end: float | None = None  # run_program ends the run after the step at t_end
        self._block: tuple[int, int, np.ndarray] | None = None  # first step, version, counts

    @property
    def time(self) -> float:
        """Simulated time now: k * dt."""
        return self.k * self.dt

    def stop(self, reason: str) -> None:
        """End the run after the step in progress (the first reason is kept)."""
        if self.stopped is None:
            self.stopped = reason

    def step(self) -> bool:
        """One physics step (module docstring); False when the guard stopped it."""
        model, data, controller, bus = self.model, self.data, self.controller, self.bus
        t = self.k * self.dt
        self.last_t = t
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
        for fn in self.before_step:
            fn(t)
        mujoco.mj_step(model, data)
        if self.guard is not None:
            reason = self.guard(t)
            if reason is not None:
                self.stop(reason)
                return False
        self.k += 1
        for fn in self.after_step:
            fn(t)
        return True

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
        """Step until the host's program has ended or failed and `settle_s` more have passed
        (or until a hook's `settle_until`), or a hook stopped the run; the time-out's message
        when a step starts after `limit_s` (s of simulated time), else None."""
        host = self.host
        while self.stopped is None:
            t = self.k * self.dt
            if not self.step():
                return None
            if self.t_end is None and (host.done or host.error is not None):
                self.t_end = t + settle_s
            if self.t_end is not None and t >= self.t_end:
                return None
            if t > limit_s:
                return f"{what} did not finish in {limit_s:g} s of simulated time"
        return None

    def run(self, end: Callable[[float], bool]) -> None:
        """Step until `end(t)` after a step (t: its start time) or a hook stopped the run."""
        while self.stopped is None:
            t = self.k * self.dt
            if not self.step():
                return
            if end(t):
                return
