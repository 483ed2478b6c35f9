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


def _bare():
    model = mujoco.MjModel.from_xml_string(XML)
    return model, mujoco.MjData(model)


def test_an_event_driven_exchange_steps_the_blocks_it_asks_for_never_past_the_limit():
    """The five-bar's SGF side: the exchange says how many steps run until its next event;
    `run_until` hands it the end time and stops there exactly."""
    model, data = _bare()
    asked = []

    def exchange(t, t_limit):
        n = min(7, round((t_limit - t) / 0.002))
        asked.append((round(t, 6), n))
        return n

    loop = StepLoop(model, data, exchange=exchange)
    index = []
    loop.after_step.append(lambda t: index.append(loop.i))
    blocks = []
    loop.after_block.append(lambda: blocks.append(loop.k))
    loop.run_until(0.04)  # 20 steps: blocks of 7, 7, 6
    assert loop.k == 20 and blocks == [7, 14, 20]
    assert asked == [(0.0, 7), (0.014, 7), (0.028, 6)]
    assert index == list(range(7)) * 2 + list(range(6))  # the step's index in its block


def test_end_block_cuts_a_block_short_and_the_next_exchange_comes_at_once():
    """A stepper that slips stops the SGF: the block's other commands are void."""
    model, data = _bare()
    starts = []

    def exchange(t, t_limit):
        starts.append(round(t, 6))
        return 10

    loop = StepLoop(model, data, exchange=exchange)
    loop.after_step.append(lambda t: loop.end_block() if loop.k == 4 else None)
    loop.run(lambda t: loop.k >= 24)
    assert starts == [0.0, 0.008, 0.028]  # 4 steps, then 10, then 10
    assert loop.k == 24 and loop.stopped is None


def test_run_steps_with_no_firmware_drives_the_bench_hooks_until_a_hook_stops():
    """A bench (`scene.plug_bench`): its hooks write the actuators; `run_steps` steps n times
    or until a hook stops it, and `after_block` runs once."""
    model, data = _bare()
    loop = StepLoop(model, data)
    loop.before_step.append(lambda t: data.ctrl.__setitem__(0, 2.0))  # 2 N on 1 kg
    loop.after_step.append(lambda t: loop.stop("moved 1 mm") if data.qpos[0] > 1e-3 else None)
    ends = []
    loop.after_block.append(lambda: ends.append(loop.k))
    loop.run_steps(1000)
    # x = a t^2 / 2 passes 1 mm at t = sqrt(1e-3) = 31.6 ms: the 16th step of 2 ms
    assert loop.stopped == "moved 1 mm" and loop.k == 16 and ends == [16]
    assert abs(data.time - loop.k * loop.dt) < 1e-12
    loop2 = StepLoop(*_bare())
    loop2.run_steps(25)
    assert loop2.k == 25 and loop2.stopped is None


def test_a_per_step_controller_and_an_exchange_are_refused_together():
    import pytest

    model, data = _bare()
    bus = ComBus()
    with pytest.raises(ValueError, match="not both"):
        StepLoop(model, data, HostProgram(["M3"], bus), bus, _Controller([]), _Endstops(),
                 exchange=lambda t, t_limit: 1)  # fmt: skip


def test_mj_step_is_called_in_one_place_in_the_package():
    """Issue 50: one loop steps every machine on every job; benchmarks' bare replays aside,
    nothing in the package calls `mujoco.mj_step` but `twin/loop.py`."""
    import ast
    from pathlib import Path

    import transplanter

    root = Path(transplanter.__file__).parent
    sites = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Call):
                f = node.func
                name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
                if name in ("mj_step", "mj_step1", "mj_step2", "rollout"):
                    sites.append((path.relative_to(root).as_posix(), node.lineno))
    assert [p for p, _ in sites] == ["twin/loop.py"], sites


class _TimedController(_Controller):
    """A controller with a timeline: `G4 P<ms>` is done (its `ok`) that long after it starts,
    one line at a time; `M280 S<deg>` queues a servo command 30 ms ahead; `G28` homes for
    5 ms. It reports its next event (`next_event_time`) and whether it homes; it logs every
    poll that changed something, with the step's time."""

    def __init__(self, log):
        super().__init__(log)
        self.busy_until, self.homes_until, self.polls = None, None, 0

    def poll(self, t, switches):
        self.polls += 1
        out = []
        if self.busy_until is not None and t >= self.busy_until:
            self.busy_until = None
            out.append("ok")
        if self.homes_until is not None and t >= self.homes_until:
            self.homes_until = None
            out.append("ok")
        while self.queued and self.busy_until is None and self.homes_until is None:
            line = self.queued.pop(0)
            if line.startswith("G4"):
                self.busy_until = t + float(line.split("P")[1]) / 1000
            elif line == "G28":
                self.homes_until = t + 0.005
            else:
                if line.startswith("M280"):
                    self.servo.append((t + 0.03, 0, float(line.split("S")[1])))
                out.append("ok")
        if out:
            self.log.append((round(t, 9), tuple(out)))
        return out

    @property
    def homing(self):
        return self.homes_until is not None

    def next_event_time(self):
        ends = [x for x in (self.busy_until, self.homes_until) if x is not None]
        return min(ends) if ends else None


def _timed_run(per_step: bool):
    from transplanter.machine.host import Call, Wait

    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    bus = ComBus(baud_bps=9600)
    log = []
    controller = _TimedController(log)
    calls = []
    program = ["G28", "G4 P17", Wait(0.0231), Call(lambda t: calls.append(round(t, 9))),
               "M280 S40", "G4 P3", "M280 S10", Wait(0.1), "G4 P40"]  # fmt: skip
    host = HostProgram(program, bus)
    loop = StepLoop(model, data, host, bus, controller, _Endstops(), per_step=per_step)
    pending, applied, raws = [], [], []

    def servo(t, commands):  # a servo board: applies each command once its time has come
        pending.extend(commands)
        while pending and pending[0][0] <= t:
            applied.append((round(t, 9), pending.pop(0)[2]))

    loop.on_servo.append(servo)
    loop.before_step.append(lambda t: raws.append(int(loop.raw[0])))
    loop.before_step.append(lambda t: data.ctrl.__setitem__(0, np.sin(40 * t)))
    timed_out = loop.run_program(limit_s=5.0, settle_s=0.05)
    return {
        "timed_out": timed_out, "k": loop.k, "log": log, "calls": calls, "applied": applied,
        "raws": raws, "qpos": data.qpos.tolist(), "qvel": data.qvel.tolist(),
        "polls": controller.polls,
    }  # fmt: skip


def test_the_exchanges_come_at_the_steps_something_is_due_and_change_nothing():
    """A controller that says when its next event is due is exchanged with only at the steps
    at which the host's timer, the bus, the controller or a servo command has something due
    (every step while it homes): the same replies at the same steps, the same servo
    commands applied at the same steps, the same raw counts at every step and the same
    physics, bit for bit, as an exchange at every step."""
    each, events = _timed_run(per_step=True), _timed_run(per_step=False)
    assert each["timed_out"] is None
    assert each["polls"] == each["k"]  # per step: one exchange a step
    assert events["polls"] < each["polls"] / 5
    for key in ("k", "log", "calls", "applied", "raws", "qpos", "qvel"):
        assert events[key] == each[key], key
    # the timeline it held: homing 5 ms, G4 P17 from its line's arrival, the host's 23.1 ms
    # wait, the servo commands 30 ms after their lines, the run settled 50 ms after the end
    assert [v for _, v in events["applied"]] == [40.0, 10.0]
    assert len(events["log"]) == 6 and events["calls"][0] > 0.0231 + 0.017  # one ok a line


def test_a_long_block_ends_at_the_step_the_program_run_ends():
    """`run_program` ends a run at the step it would end with an exchange at every step, so
    a block with nothing due does not run past the settle time or the time-out."""
    each, events = _timed_run(per_step=True), _timed_run(per_step=False)
    assert events["k"] == each["k"]
    model = mujoco.MjModel.from_xml_string(XML)
    bus = ComBus()
    controller = _TimedController([])
    loop = StepLoop(model, mujoco.MjData(model), HostProgram(["G4 P10000"], bus), bus,
                    controller, _Endstops())  # fmt: skip
    message = loop.run_program(limit_s=0.1)
    assert message == "the program did not finish in 0.1 s of simulated time"
    assert loop.last_t > 0.1 and loop.last_t - loop.dt <= 0.1 + 1e-12  # the first step after
