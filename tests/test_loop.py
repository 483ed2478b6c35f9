"""transplanter.twin.loop: one physics step at a time, in the order the jobs rely on: host,
bus, controller, machine events, servo commands, the step's commands, mj_step, the guard,
the count and the watches."""

from __future__ import annotations

import mujoco
import numpy as np

from transplanter.machine.bus import ComBus
from transplanter.machine.host import HostProgram
from transplanter.twin.loop import StepLoop

XML = """<mujoco><option timestep="0.002"/><worldbody><body>
<joint name="x" type="slide" axis="1 0 0"/><geom size="0.01" mass="1"/></body></worldbody>
<actuator><motor joint="x"/></actuator></mujoco>"""


class _Endstops:
    initial = np.zeros(2)

    def read(self, raw):
        return (False, False)


class _Controller:
    """Acks every line; each M3 line queues a servo command and a machine event."""

    def __init__(self, log):
        self.log, self.queued, self.servo, self.events = log, [], [], []

    def receive(self, line, t):
        self.queued.append(line)

    def poll(self, t, switches):
        out = []
        while self.queued:
            line = self.queued.pop(0)
            if line == "M3":
                self.servo.append((t, 0, 90.0))
                self.events.append((t, "conveyor_index"))
            out.append("ok")
        return out

    def pulses_at(self, times):
        return np.array([[int(1000 * t), 0] for t in np.atleast_1d(times)])

    def drain_servo_commands(self):
        out, self.servo = self.servo, []
        return out

    def drain_machine_events(self):
        out, self.events = self.events, []
        return out


def _loop():
    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    bus = ComBus()
    log = []
    controller = _Controller(log)
    host = HostProgram(["M3", "G4 P1"], bus)
    loop = StepLoop(model, data, host, bus, controller, _Endstops(),
                    controller.drain_machine_events)  # fmt: skip
    return loop, log, data


def test_the_hooks_run_in_order_and_the_count_before_the_watches():
    loop, log, data = _loop()
    loop.on_event.append(lambda t, name: log.append(("event", name)))
    loop.on_servo.append(lambda t, cmds: cmds and log.append(("servo", cmds[0][2])))
    loop.before_step.append(lambda t: data.ctrl.__setitem__(0, 1.0))
    loop.after_step.append(lambda t: log.append(("after", round(t, 6), loop.k)))
    loop.run(lambda t: loop.host.done)
    events = [e for e in log if e[0] != "after"]
    assert events == [("event", "conveyor_index"), ("servo", 90.0)]
    afters = [e for e in log if e[0] == "after"]
    assert afters[0] == ("after", 0.0, 1)  # t: the step's start; k counted already
    assert loop.k == len(afters) and loop.time == loop.k * loop.dt
    assert data.qvel[0] > 0  # the commands of every step reached the physics
    assert loop.raw.tolist() == [int(1000 * loop.last_t), 0]


def test_the_guard_stops_at_once_without_counting_the_step():
    loop, log, data = _loop()
    loop.guard = lambda t: "reset" if t >= 0.01 else None
    loop.after_step.append(lambda t: log.append(t))
    loop.run(lambda t: False)
    assert loop.stopped == "reset" and loop.k == 5  # steps at 0 .. 0.008 counted
    assert loop.last_t == 0.01 and len(log) == 5


def test_a_hook_stops_the_run_after_its_step():
    loop, log, data = _loop()
    loop.after_step.append(lambda t: loop.stop("enough") if loop.k == 3 else None)
    loop.run(lambda t: False)
    assert (loop.stopped, loop.k) == ("enough", 3)


class _VersionedController(_Controller):
    """Its motion changes (a new version) when a line arrives; counts pulses_at's calls."""

    def __init__(self, log):
        super().__init__(log)
        self.motion_version, self.asked = 0, []

    def receive(self, line, t):
        super().receive(line, t)
        self.motion_version += 1

    def pulses_at(self, times):
        times = np.atleast_1d(times)
        self.asked.append(times.size)
        return np.array([[int(1000 * t) + 7 * self.motion_version, 0] for t in times])


def test_the_pulses_are_read_from_a_block_while_the_motion_stays_the_same():
    """A controller with `motion_version` is asked for the next BLOCK_STEPS steps' counts at
    once and asked again when its motion changes: every step sees what a per-step ask gives."""
    from transplanter.twin.loop import BLOCK_STEPS

    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    bus = ComBus()
    controller = _VersionedController([])
    host = HostProgram(["M3", "G4 P1"], bus)
    loop = StepLoop(model, data, host, bus, controller, _Endstops())
    seen = []
    loop.before_step.append(lambda t: seen.append((loop.k, controller.motion_version,
                                                   int(loop.raw[0]))))  # fmt: skip
    loop.run(lambda t: loop.k >= 3 * BLOCK_STEPS)
    for k, version, raw in seen:  # what the controller answers for that step's time
        assert raw == int(1000 * (k * loop.dt)) + 7 * version
    versions = {v for _, v, _ in seen}
    assert versions == {0, 1, 2}  # the two lines changed it: asked anew each time
    assert all(n == BLOCK_STEPS for n in controller.asked)
    assert len(controller.asked) < len(seen) / 10  # a block, not a step, per ask
