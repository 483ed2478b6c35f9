import math
from pathlib import Path

import numpy as np
import pytest

from transplanter.machine.gcode import format_line
from transplanter.machine.homing import HomingConfig
from transplanter.machine.kinematics.fivebar import FiveBarKinematics, fk, ik
from transplanter.machine.rig import SimulatedEndstops
from transplanter.machine.sgf import SGF, SGFConfig

START = (math.radians(150.0), math.radians(30.0), 0.120)


def home(sgf: SGF, endstops: SimulatedEndstops, t: float = 0.0, dt: float = 1e-3) -> float:
    """Send G28 and poll every dt with simulated switches until its ok; return the time."""
    sgf.receive("G28", t)
    for _ in range(100_000):
        replies = sgf.poll(t, endstops.read(sgf.pulses_at(t)[0]))
        if replies:
            assert replies == ["ok"]
            return t
        t_event = sgf.next_event_time()  # known once every switch has tripped
        t = min(t + dt, t_event if t_event is not None else math.inf)
    raise AssertionError("homing did not finish")


def run_line(sgf: SGF, line: str, t: float) -> tuple[list[str], float]:
    """Send a line at t, jump to its completion, return (replies, completion time)."""
    sgf.receive(line, t)
    replies = sgf.poll(t)
    for _ in range(1000):  # a line completes at its next event; a few events at most
        if replies:
            return replies, t
        t = sgf.next_event_time()
        assert t is not None
        replies = sgf.poll(t)
    raise AssertionError(f"{line!r} never answered")


@pytest.fixture()
def homed():
    config = SGFConfig()
    sgf = SGF(config)
    endstops = SimulatedEndstops(config, START)
    t = home(sgf, endstops)
    return sgf, endstops, t


def test_homing_sets_logical_counters_and_keeps_raw_pulses(homed):
    sgf, endstops, t = homed
    config = sgf.config
    # the slow locate read each switch closed within a step of reaching it (1 ms polling)
    overshoot = sgf.homing_trip_raw - endstops.trip_pulses()
    assert np.all(overshoot * np.array(config.homing.dirs) >= 0)
    assert np.all(np.abs(overshoot) <= np.ceil(np.array(config.homing.locate_rate_hz) * 1e-3))
    pulloff = np.array(config.homing.dirs) * np.array(config.homing.pulloff_steps)
    assert np.array_equal(sgf.logical_steps, config.home_steps - pulloff)
    assert np.array_equal(sgf.raw_pulses, sgf.homing_trip_raw - pulloff)
    assert np.array_equal(sgf.pulses_at(t + 5.0)[0], sgf.raw_pulses)
    # homing moved motor 1 up, motor 2 down, Z up
    assert sgf.homing_trip_raw[0] > 0 > sgf.homing_trip_raw[1] and sgf.homing_trip_raw[2] > 0
    assert sgf.homed and not sgf.busy
    x, y, z = sgf.position_xyz
    assert abs(x) < 1e-9 and 0.076 < y < 0.082 and z == pytest.approx(0.159)  # pulled off
    events = sgf.drain_machine_events()
    assert [name for _, name in events] == ["homed"] and events[0][0] == t


def test_homing_seeks_pulls_off_locates_and_pulls_off_again():
    config = SGFConfig()
    sgf = SGF(config)
    endstops = SimulatedEndstops(config, START)
    t_done = home(sgf, endstops)
    times = np.linspace(0.0, t_done, 4001)
    pulses = sgf.pulses_at(times)
    assert np.array_equal(pulses[0], [0, 0, 0])
    steps = np.diff(pulses, axis=0)
    assert np.all(np.abs(steps) <= np.ceil(np.array(config.homing.rate_hz) * times[1]))
    for motor, direction in enumerate(config.homing.dirs):
        moving = steps[:, motor][steps[:, motor] != 0] * direction
        legs = np.sign(moving[np.r_[True, np.diff(np.sign(moving)) != 0]])
        assert legs.tolist() == [1, -1, 1, -1], motor  # seek, pull-off, locate, pull-off


def test_homing_fails_without_switch():
    config = SGFConfig(homing=HomingConfig(max_steps=(200, 200, 400)))
    sgf = SGF(config)
    sgf.receive("G28", 0.0)
    t = 0.0
    replies = []
    while not replies and t < 2.0:
        replies = sgf.poll(t, (False, False, False, False))
        t += 1e-3
    assert replies == [
        "error:69 homing failed: limit switch 3 (Z up) not found: motor 3 travelled 400 steps "
        "(1.0 mm) towards it and it never closed; the switch is dead or unplugged (M119 shows "
        "it open even when pressed), or the axis is blocked before it; check the switch, its "
        "wiring, the axis and the homing direction (HomingConfig.dirs)"
    ]
    assert not sgf.homed
    assert [n for _, n in sgf.drain_machine_events()] == ["homing_failed"]


def _home_on_grid(sgf: SGF, read, watched: bool, dt: float = 1e-3):
    """G28 on a grid of physics steps, the switches read by `read(pulses)` at every step.
    Polled at every step, or (`watched`) only when a switch changes and when the SGF asks
    (homing_poll_time, next_event_time), as the twin does. Returns the reply, its step and
    the number of polls."""
    k, polls = 0, 1
    sgf.receive("G28", 0.0)
    switches = read(sgf.pulses_at(0.0)[0])
    replies = sgf.poll(0.0, switches)
    while not replies:
        due = [x for x in (sgf.homing_poll_time(k * dt, dt), sgf.next_event_time()) if x]
        target = min(due) if watched else (k + 1) * dt
        while True:
            k += 1
            now = read(sgf.pulses_at(k * dt)[0])
            if now != switches or k * dt >= target - 1e-12:
                break
        switches = now
        replies = sgf.poll(k * dt, switches)
        polls += 1
    return replies, k, polls


@pytest.mark.parametrize("switches_work", [True, False])
def test_homing_polled_at_its_own_times_and_switch_changes_is_homing_polled_every_step(
    switches_work,
):
    """The twin reads the switches at every physics step but exchanges with the SGF only
    when one changes or when the homing asks (a locate begins, a leg runs out): the same
    homing, to the step, with a fraction of the polls; also when a switch never closes."""
    dead = SGFConfig(homing=HomingConfig(max_steps=(200, 200, 400)))
    config = SGFConfig() if switches_work else dead
    runs = []
    for watched in (False, True):
        sgf = SGF(config)
        endstops = SimulatedEndstops(config, START)
        read = endstops.read if switches_work else (lambda pulses: (False,) * 4)
        replies, k, polls = _home_on_grid(sgf, read, watched)
        trip = sgf.homing_trip_raw  # None when homing failed
        pulses = sgf.pulses_at((k + 1) * 1e-3)[0].tolist()
        runs.append((replies, k, pulses, None if trip is None else trip.tolist(), polls))
    assert runs[0][:4] == runs[1][:4]
    assert (runs[0][0] == ["ok"]) == switches_work
    assert runs[1][4] < runs[0][4] / 10, (runs[0][4], runs[1][4])


def test_move_before_homing_is_refused():
    sgf = SGF(SGFConfig())
    sgf.receive("G1 X0 Y180 Z50", 0.0)
    replies = sgf.poll(0.0)
    assert replies == ["error:9 position unknown: home first with G28"]
    assert np.array_equal(sgf.pulses_at([0.0, 10.0]), np.zeros((2, 3), dtype=np.int64))


def test_move_pulses_reach_ik_of_target(homed):
    sgf, _, t = homed
    raw0, logical0 = sgf.raw_pulses, sgf.logical_steps
    replies, t_done = run_line(sgf, "G1 X45 Y200 Z60 S100", t)
    assert replies == ["ok"]
    theta1, theta2 = ik(sgf.config.kinematics.geometry, 0.045, 0.200)
    drives = sgf.config.drives
    expected = np.array(
        [int(drives[0].to_steps(theta1)), int(drives[1].to_steps(theta2)),
         int(drives[2].to_steps(0.060))]
    )  # fmt: skip
    assert np.array_equal(sgf.logical_steps, expected)
    assert np.array_equal(sgf.raw_pulses - raw0, expected - logical0)
    assert np.allclose(sgf.position_xyz, [0.045, 0.200, 0.060])
    # pulses over the move: start, end, and never beyond the end afterwards
    pulses = sgf.pulses_at(np.linspace(t, t_done + 1.0, 500))
    assert np.array_equal(pulses[0], raw0) and np.array_equal(pulses[-1], sgf.raw_pulses)


def test_speed_words_and_relative_moves(homed):
    sgf, _, t = homed
    _, t1 = run_line(sgf, "G1 X0 Y180 Z100 S100", t)
    _, t2 = run_line(sgf, "G1 Y200 F6000", t1)  # 100 mm/s too: same duration over 20 mm
    _, t3 = run_line(sgf, "G1 Y180", t2)  # keeps the last speed
    assert t3 - t2 == pytest.approx(t2 - t1, rel=0.02)
    _, t4 = run_line(sgf, "G91", t3)
    _, t5 = run_line(sgf, "G1 X10 Z-5 S50", t4)
    assert np.allclose(sgf.position_xyz, [0.010, 0.180, 0.095])
    assert t4 == t3 and t5 > t4


def test_unreachable_and_out_of_range_targets_move_nothing(homed):
    sgf, _, t = homed
    raw, logical = sgf.raw_pulses, sgf.logical_steps
    replies, _ = run_line(sgf, "G1 X0 Y400 Z50", t)
    assert len(replies) == 1 and replies[0].startswith("error:33 target position not reachable:")
    replies, _ = run_line(sgf, "G1 X0 Y180 Z200", t)
    assert replies[0].startswith("error:33 Z 200.000 mm outside")
    replies, _ = run_line(sgf, "G1 X0 Y180 Q5", t)
    assert replies[0].startswith("error:36")
    assert np.array_equal(sgf.raw_pulses, raw) and np.array_equal(sgf.logical_steps, logical)
    assert np.array_equal(sgf.pulses_at([t, t + 10.0]), np.stack([raw, raw]))


def test_dwell_servo_conveyor_and_reports(homed):
    sgf, endstops, t = homed
    sgf.drain_machine_events()
    replies, t1 = run_line(sgf, "G4 P250", t)
    assert replies == ["ok"] and t1 == pytest.approx(t + 0.25)
    replies, t2 = run_line(sgf, "M280 P0 S60", t1)
    assert replies == ["ok"] and t2 == t1
    assert sgf.drain_servo_commands() == [(t1, 0, 60.0)]
    replies, t3 = run_line(sgf, "M710", t2)
    assert replies == ["ok"] and t3 == pytest.approx(t2 + sgf.config.conveyor_index_s)
    assert sgf.drain_machine_events() == [(t2, "conveyor_index")]
    replies, _ = run_line(sgf, "M114", t3)
    a, b, c = sgf.logical_steps
    assert replies == [f"X:0.000 Y:{sgf.position_xyz[1] * 1e3:.3f} Z:159.000 A:{a} B:{b} C:{c}",
                       "ok"]  # fmt: skip
    sgf.poll(t3, (False, True, False, False))
    replies, _ = run_line(sgf, "M119", t3)
    assert replies == ["endstops: 1:open 2:TRIGGERED 3:open 4:open", "ok"]
    for line in ("M105", "M400", "G90"):
        assert run_line(sgf, line, t3) == (["ok"], t3)


def test_fifo_replies_in_line_order(homed):
    sgf, _, t = homed
    sgf.receive("G1 X0 Y180 Z100 S100", t)
    sgf.receive("G1 X1 Y2", t)  # unreachable, refused only when its turn comes
    sgf.receive("M280 P1 S30", t)
    sgf.receive("#bogus", t)
    assert sgf.poll(t) == []
    t_move = sgf.next_event_time()
    assert t_move > t and sgf.busy
    assert sgf.poll(t_move - 1e-6) == []
    replies = sgf.poll(t_move)
    assert replies[0] == "ok"
    assert replies[1].startswith("error:33 target position not reachable")
    assert replies[2] == "ok" and replies[3].startswith("error:1 ")
    assert sgf.drain_servo_commands() == [(t_move, 1, 30.0)]
    assert not sgf.busy and sgf.next_event_time() is None


def test_line_numbers_and_required_checksum():
    config = SGFConfig(require_checksum=True)
    sgf = SGF(config)
    sgf.receive(format_line("M105", line_number=1), 0.0)
    sgf.receive(format_line("M105", line_number=3), 0.0)
    sgf.receive("M105", 0.0)
    sgf.receive(format_line("M105", line_number=2), 0.0)
    replies = sgf.poll(0.0)
    assert replies[0] == "ok"
    assert replies[1].startswith("error:61 ")
    assert replies[2].startswith("error:62 ")
    assert replies[3] == "ok"


def test_a_line_whose_checksum_passes_advances_n_whatever_its_command():
    """Issue row 13: ``N2 G2 X1*96`` got error:20 but N stayed at 1, so the next line got
    error:61 "expected N2". As in Marlin, a good checksum counts the line as received."""
    from transplanter.machine.gcode import checksum

    sgf = SGF(SGFConfig(require_checksum=True))
    framed = "N2 G2 X1"
    bad_command = f"{framed}*{checksum(framed)}"
    assert bad_command == "N2 G2 X1*96"
    sgf.receive(format_line("M105", line_number=1), 0.0)
    sgf.receive(bad_command, 0.0)
    sgf.receive(format_line("M105", line_number=3), 0.0)
    sgf.receive("N4 M105*0", 0.0)  # bad checksum: N does not advance
    sgf.receive(format_line("M105", line_number=5), 0.0)  # so N5 is out of sequence
    sgf.receive(format_line("M105", line_number=4), 0.0)
    replies = sgf.poll(0.0)
    assert replies[0] == "ok"
    assert replies[1].startswith("error:20 ")
    assert replies[2] == "ok"
    assert replies[3].startswith("error:60 ")
    assert replies[4].startswith("error:61 ") and "expected N4" in replies[4]
    assert replies[5] == "ok"


def test_default_home_is_the_folded_back_pose_of_the_model():
    config = SGFConfig()
    assert config.home_joint_positions == pytest.approx(
        (math.radians(200.0), math.radians(-20.0), 0.160)
    )
    kinematics = config.kinematics
    x, y = fk(kinematics.geometry, kinematics.home_theta1_rad, kinematics.home_theta2_rad, "up")
    assert (float(x), float(y)) == pytest.approx((0.0, 0.075), abs=5e-4)


@pytest.mark.parametrize("mode", ["+-", "-+", "++", "--"])
def test_position_after_homing_uses_the_assembly_of_the_mode(mode):
    """Switches placed so that the pulled-off pose is the IK of (45, 200) mm in ``mode``."""
    base = SGFConfig()
    unit = np.array([d.unit_per_step for d in base.drives])
    dirs = np.array(base.homing.dirs)
    pulled_off = np.array([*ik(base.kinematics.geometry, 0.045, 0.200, mode), 0.159])
    home_q = pulled_off + dirs * np.array(base.homing.pulloff_steps) * unit
    config = SGFConfig(
        kinematics=FiveBarKinematics(
            mode=mode, home_theta1_rad=home_q[0], home_theta2_rad=home_q[1], home_z_m=home_q[2]
        )
    )
    sgf = SGF(config)
    home(sgf, SimulatedEndstops(config, home_q - dirs * np.radians(5.0)))
    assert sgf.position_xyz == pytest.approx([0.045, 0.200, 0.159], abs=3e-4)


def test_first_move_without_speed_uses_default_speed():
    durations = []
    for speed_m_s in (0.05, 0.10):
        config = SGFConfig(default_speed_m_s=speed_m_s)
        sgf = SGF(config)
        t = home(sgf, SimulatedEndstops(config, START))
        _, t1 = run_line(sgf, "G1 X0 Y180 Z100", t)
        _, t2 = run_line(sgf, "G1 Y220", t1)  # 40 mm straight line at the default speed
        durations.append(t2 - t1)
    assert durations[0] > 1.5 * durations[1]
    assert durations[1] > 0.040 / 0.10


def test_time_must_not_go_backwards():
    sgf = SGF()
    sgf.poll(1.0)
    with pytest.raises(ValueError, match="non-decreasing"):
        sgf.receive("M105", 0.5)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"kinematics": lambda: FiveBarKinematics(z_min_m=0.2)},
        {"homing": lambda: HomingConfig(dirs=(1, 0, 1))},
        {"homing": lambda: HomingConfig(rate_hz=(0.0, 1.0, 1.0))},
        {"homing": lambda: HomingConfig(pulloff_steps=(1, 2))},
        {"default_speed_m_s": 0.0},
        {"conveyor_index_s": -1.0},
    ],
)
def test_config_validation(kwargs):
    """A bad setting is refused, whether it lives on the kinematics, the homing or the SGF."""
    with pytest.raises(ValueError):
        SGFConfig(**{k: v() if callable(v) else v for k, v in kwargs.items()})


def test_every_step_is_out_at_the_ack_time(homed):
    """The ok comes when the last step has been issued: pulses at the ack time are final."""
    sgf, _, t = homed
    targets = [
        "G1 X0 Y215 Z32 S60",
        "G1 X-90 Y175 Z32 S150",
        "G1 X90 Y215 Z100 S60",
        "G1 X0 Y140 Z100 S150",
        "G1 X45 Y175 Z40 S150",
    ]
    for line in targets * 3:
        replies, t = run_line(sgf, line, t)
        assert replies == ["ok"]
        assert np.array_equal(sgf.pulses_at(t)[0], sgf.raw_pulses), line


def test_rejected_move_keeps_the_modal_speed(homed):
    sgf, _, t = homed
    _, t1 = run_line(sgf, "G1 X0 Y180 Z100 S100", t)
    _, t2 = run_line(sgf, "G1 Y200", t1)
    for refused in ("G1 X0 Y400 S5", "G1 Z200 S5", "G1 X0 Y400 F60"):
        replies, t_refused = run_line(sgf, refused, t2)
        assert replies[0].startswith("error:33") and t_refused == t2
    _, t3 = run_line(sgf, "G1 Y180", t2)  # still 100 mm/s, not 5 or 1 mm/s
    assert t3 - t2 == pytest.approx(t2 - t1, rel=0.02)


def home_lagging(sgf: SGF, endstops: SimulatedEndstops, lag_s: float, dt: float) -> float:
    """Home with motors that follow their commanded pulses lag_s late, switches read every dt."""
    sgf.receive("G28", 0.0)
    t = 0.0
    for _ in range(100_000):
        if sgf.poll(t, endstops.read(sgf.pulses_at(t - lag_s)[0])) == ["ok"]:
            return t
        t_event = sgf.next_event_time()
        t = min(t + dt, t_event if t_event is not None else math.inf)
    raise AssertionError("homing did not finish")


def test_two_pass_homing_trips_within_a_step_of_the_switch():
    """The fast seek trips ~rate * (lag + dt) late; the slow locate a tenth of that."""
    config = SGFConfig()
    lag_s, dt = 4e-3, 1e-3
    sgf = SGF(config)
    endstops = SimulatedEndstops(config, START)
    home_lagging(sgf, endstops, lag_s, dt)
    overshoot = (sgf.homing_trip_raw - endstops.trip_pulses()) * np.array(config.homing.dirs)
    locate_rate = np.array(config.homing.locate_rate_hz)
    assert np.allclose(locate_rate, np.array(config.homing.rate_hz) / 10)
    assert np.all(overshoot >= 0)
    assert np.all(overshoot <= np.ceil(locate_rate * (lag_s + dt)))  # 1, 1, 4 steps
    assert np.all(overshoot[:2] <= 1)  # the single-pass seek was 7-8 steps late on each arm


def test_homing_locate_rate_is_configurable_and_validated():
    config = SGFConfig(homing=HomingConfig(locate_rate_hz=(50.0, 50.0, 100.0)))
    assert config.homing.locate_rate_hz == (50.0, 50.0, 100.0)
    sgf_fast = SGF(SGFConfig())
    sgf_slow = SGF(config)
    t_fast = home(sgf_fast, SimulatedEndstops(sgf_fast.config, START))
    t_slow = home(sgf_slow, SimulatedEndstops(config, START))
    # the arms' locate covers >= 96 pull-off steps: 0.6 s at 160 Hz, 1.9 s at 50 Hz
    assert t_slow - t_fast > 1.0
    for bad in ((0.0, 1.0, 1.0), (1.0, 1.0), (1.0, math.nan, 1.0)):
        with pytest.raises(ValueError, match="homing locate_rate_hz"):
            SGFConfig(homing=HomingConfig(locate_rate_hz=bad))


def test_homing_fails_when_the_switch_stays_closed_after_the_pull_off():
    sgf = SGF(SGFConfig())
    sgf.receive("G28", 0.0)
    t, replies = 0.0, []
    while not replies and t < 5.0:
        replies = sgf.poll(t, (True, True, True, False))  # stuck-closed switches
        t += 1e-3
    assert replies == [
        "error:68 homing failed: limit switch 3 (Z up) still closed after the 400-step "
        "pull-off (it was already closed when homing began): the switch is stuck closed or its "
        "wiring is shorted (M119 shows it TRIGGERED), or the axis stands beyond it (steps lost "
        "since the last homing); check the switch and its wiring, or move the axis off the switch "
        "and home again"
    ]
    assert not sgf.homed and sgf.homing_trip_raw is None
    assert [n for _, n in sgf.drain_machine_events()] == ["homing_failed"]
    # the motors stopped where they were: nothing moves afterwards
    assert np.array_equal(sgf.pulses_at(t + 1.0)[0], sgf.raw_pulses)


def test_homing_locate_fails_when_the_switch_is_lost():
    """Switches that close for one poll of the seek and never again: the locate gives up."""
    sgf = SGF(SGFConfig())
    sgf.receive("G28", 0.0)
    replies = []
    for k in range(10_000):
        replies = sgf.poll(k * 1e-3, (k == 50,) * 3 + (False,))
        if replies:
            break
    # Z gives up first: 5 x 400 steps at 800 Hz after its debounce (0.25 s) and pull-off
    assert replies == [
        "error:69 homing failed: limit switch 3 (Z up) closed in the seek but not again within "
        "2000 steps (5.0 mm) of the slow locate: an intermittent switch (a loose wire, a "
        "bouncing contact); check the switch and its wiring"
    ]
    assert k * 1e-3 == pytest.approx(0.05 + 0.25 + 400 / 8000 + 2000 / 800, abs=2e-3)
    assert [n for _, n in sgf.drain_machine_events()] == ["homing_failed"]


def test_homing_alone_seeks_pulls_off_locates_and_pulls_off_again():
    """firmware.homing.Homing without the SGF: the raw pulses of each leg, in closed form."""
    from transplanter.machine.homing import Homing

    config = SGFConfig()
    endstops = SimulatedEndstops(config, START)
    homing = Homing(config.homing, config.kinematics.axes, 0.0, np.zeros(3, dtype=np.int64))
    t, dt = 0.0, 1e-3
    for _ in range(20_000):  # 20 s of polls at most
        assert homing.update(t, endstops.read(homing.pulses(np.array([t]))[0])) is None
        if homing.done_seeking:
            break
        t += dt
    assert homing.done_seeking and not homing.failed
    trip = endstops.trip_pulses()
    dirs = np.array(config.homing.dirs)
    assert np.all((homing.trip_raw - trip) * dirs >= 0)
    assert np.all((homing.trip_raw - trip) * dirs <= [1, 1, 1])
    # after the final pull-off every motor stands homing.pulloff_steps back from its trip
    end = homing.pulses(np.array([homing.t_done, homing.t_done + 1.0]))
    expected = homing.trip_raw - dirs * np.array(config.homing.pulloff_steps)
    np.testing.assert_array_equal(end, [expected, expected])
    # raw pulses never jump: at most one step per motor between polls 0.1 ms apart
    times = np.arange(0.0, homing.t_done, 1e-4)
    assert np.abs(np.diff(homing.pulses(times), axis=0)).max() <= 1


@pytest.mark.parametrize(
    ("steps_per_rev", "microsteps", "named"),
    [(100000, 16, "steps_per_rev=100000"), (100000, 256, "microsteps=256")],
)
def test_drives_whose_moves_cannot_be_held_are_refused(steps_per_rev, microsteps, named):
    """Issue row 8: drives.steps_per_rev = 100000 (in the scenario's range) ran 17 s into
    a MemoryError. The SGF refuses, at configuration, drives whose move across the
    workspace needs more step pulses than a move may emit, naming the values."""
    import time

    from transplanter.machine.steppers import StepperDrive
    from transplanter.scenario.assemble import machine_config
    from transplanter.scenario.schema import ScenarioError, load_scenario

    drives = tuple(
        StepperDrive(name, steps_per_rev=steps_per_rev, microsteps=microsteps, **extra)
        for name, extra in (("arm1", {}), ("arm2", {}), ("z", {"ratio": 1.0, "lead_m": 0.008}))
    )
    with pytest.raises(ValueError, match=named) as info:
        SGFConfig(kinematics=FiveBarKinematics(drives=drives))
    assert "step pulses one move may emit" in str(info.value)
    t0 = time.perf_counter()
    overrides = {"drives.steps_per_rev": steps_per_rev, "drives.microsteps": microsteps}
    with pytest.raises(ScenarioError, match=named):
        machine_config(load_scenario(Path(__file__).parents[1] / "scenarios/paper.toml", overrides))
    assert time.perf_counter() - t0 < 5.0


def test_paper_class_drives_are_accepted():
    from transplanter.machine.steppers import StepperDrive

    drives = tuple(
        StepperDrive(name, steps_per_rev=400, microsteps=256, **extra)
        for name, extra in (("arm1", {}), ("arm2", {}), ("z", {"ratio": 1.0, "lead_m": 0.008}))
    )
    SGFConfig(kinematics=FiveBarKinematics(drives=drives))


def test_a_move_with_too_many_step_pulses_is_refused_before_its_events(homed, monkeypatch):
    """Row 8, the planner's bound: a move is refused (error:33) before its step events exist."""
    import transplanter.machine.motion as motion

    sgf, endstops, t = homed
    monkeypatch.setattr(motion, "MAX_STEPS_PER_MOVE", 1000)
    replies, t = run_line(sgf, "G1 X0 Y200 Z100", t)
    assert replies[-1].startswith("error:33 move refused: plan_line: the move needs ")
    assert "step pulses, more than 1000 a move" in replies[-1]


def test_receive_buffer_is_bounded_like_marlins():
    """Issue row 14: 200,000 lines queued without an ok (185 MB). Four parsed lines wait
    (BUFSIZE), then rx_buffer_bytes of raw lines; the rest is dropped with error:66."""
    import time

    sgf = SGF(SGFConfig())
    t0 = time.perf_counter()
    for _ in range(200_000):
        sgf.receive("G4 P1", 0.0)
    assert time.perf_counter() - t0 < 10.0
    assert len(sgf._queue) == 4
    held = len(sgf._rx)
    assert held == 512 // len("G4 P1\n")
    assert sgf.rx_dropped == 200_000 - 4 - held
    replies = sgf.poll(0.0)
    assert len(replies) == sgf.rx_dropped and replies[0].startswith("error:66 receive buffer")
    # the held lines run in order once slots free: every kept line gets its ok
    t, oks = 0.0, 0
    while sgf.busy:
        t = sgf.next_event_time()
        oks += sgf.poll(t).count("ok")
    assert oks == 4 + held


def test_held_lines_keep_order_and_numbering():
    config = SGFConfig(command_queue_lines=1)
    sgf = SGF(config)
    for n in range(1, 6):
        sgf.receive(format_line("G4", {"P": 10}, line_number=n), 0.0)
    t, replies = 0.0, []
    while sgf.busy:
        t = sgf.next_event_time()
        replies += sgf.poll(t)
    assert replies == ["ok"] * 5 and t == pytest.approx(0.05)


def test_an_over_long_line_is_refused_with_line_overflow_at_once():
    """Issue row 14: a 1M-character line was accepted; it gets error:11 without parsing."""
    import time

    from transplanter.machine.gcode import MAX_LINE_CHARS, GcodeError, parse_line

    sgf = SGF(SGFConfig())
    long_line = "G4 P1 ;" + "x" * 1_000_000
    t0 = time.perf_counter()
    sgf.receive(long_line, 0.0)
    (reply,) = sgf.poll(0.0)
    assert time.perf_counter() - t0 < 0.5
    assert reply.startswith(f"error:11 line of 1000007 characters overflows the {MAX_LINE_CHARS}")
    assert not sgf._queue
    with pytest.raises(GcodeError) as info:
        parse_line("G4 P1 ;" + "x" * MAX_LINE_CHARS)
    assert info.value.code == 11
    assert parse_line("G4 P1 ;" + "x" * (MAX_LINE_CHARS - 7)).command == "G4"


def test_homing_distances_follow_the_drives_and_256_microsteps_plan():
    """Row 8: drives.microsteps = 256 (in range) ran into a MemoryError; with homing
    distances in steps fixed for 16 microsteps it could not even home. The defaults are
    joint distances converted with the drives, and the example program plans quickly."""
    import time

    from transplanter.machine.planner import plan_program
    from transplanter.scenario.assemble import machine_config
    from transplanter.scenario.schema import load_scenario

    assert SGFConfig().homing.pulloff_steps == (96, 96, 400)
    assert SGFConfig().homing.max_steps == (4800, 4800, 80000)
    root = Path(__file__).parents[1]
    machine = machine_config(
        load_scenario(root / "scenarios/paper.toml", {"drives.microsteps": 256})
    )
    assert machine.sgf.homing.pulloff_steps == (1536, 1536, 6400)
    t0 = time.perf_counter()
    rows = plan_program(machine, (root / "scenarios/example.gcode").read_text())
    assert time.perf_counter() - t0 < 30.0
    lift = next(r for r in rows if r.text.startswith("G1 X0 Y215 Z60 S60"))
    assert list(lift.steps) == [0, 0, 26 * 400 * 16]


STALL = "error:67 motor 2 stalled"


def test_a_stall_stops_the_motors_where_they_are_and_locks_until_homed(homed):
    """A stall in the middle of a move: the pulses hold from that moment, the move is
    answered error:67, the queued lines each get error:67, the next move is locked out
    (error:9) and a G28 re-references the motors."""
    sgf, endstops, t = homed
    sgf.receive("G1 X45 Y200 Z60 S100", t)
    sgf.receive("G4 P100", t)
    sgf.receive("M280 P0 S90", t)
    assert sgf.poll(t) == []
    t_done = sgf.next_event_time()
    t_stall = t + 0.4 * (t_done - t)
    held = sgf.pulses_at(t_stall)[0]
    assert sgf.poll(t_stall) == []
    sgf.stall(t_stall, 1)
    replies = sgf.poll(t_stall)
    assert len(replies) == 3 and all(r.startswith(STALL) for r in replies)
    assert "home with G28" in replies[0]
    assert sgf.drain_servo_commands() == []  # the flushed M280 never ran
    assert np.array_equal(sgf.pulses_at([t_stall, t_done, t_done + 5.0]), [held] * 3)
    assert np.array_equal(sgf.raw_pulses, held)
    assert not sgf.homed and np.isnan(sgf.position_xyz).all() and not sgf.busy
    assert sgf.stalls == [(t_stall, 1)]
    assert [name for _, name in sgf.drain_machine_events()][-1] == "stalled"
    replies, t1 = run_line(sgf, "G1 X0 Y180 Z60", t_stall + 0.1)
    assert replies[0].startswith("error:9")
    t2 = home(sgf, endstops, t1)
    replies, _ = run_line(sgf, "G1 X45 Y200 Z60 S100", t2)
    assert replies == ["ok"] and np.allclose(sgf.position_xyz, [0.045, 0.200, 0.060])


def test_a_stall_while_idle_answers_the_next_line_and_a_g28_clears_it(homed):
    sgf, endstops, t = homed
    sgf.stall(t + 0.1, 0)
    assert sgf.poll(t + 0.1) == []  # nothing running: the host hears of it with its next line
    replies, t1 = run_line(sgf, "M280 P0 S90", t + 0.2)
    assert len(replies) == 1 and replies[0].startswith(
        f"error:67 motor 1 stalled at t={t + 0.1:.3f} s"
    )
    assert sgf.drain_servo_commands() == []
    replies, t2 = run_line(sgf, "M280 P0 S90", t1)  # reported once: now only locked
    assert replies == ["ok"]
    sgf2 = SGF(SGFConfig())  # a G28 after an idle stall homes as usual
    t3 = home(sgf2, SimulatedEndstops(sgf2.config, START))
    sgf2.stall(t3 + 0.1, 2)
    assert home(sgf2, SimulatedEndstops(sgf2.config, START), t3 + 0.2) > t3
    assert sgf2.homed


def test_stalls_while_stopped_or_before_homing_change_nothing():
    sgf = SGF(SGFConfig())
    sgf.stall(0.5, 0)  # never homed: nothing runs
    assert sgf.stalls == [] and sgf.poll(0.6) == []
    replies, _ = run_line(sgf, "M280 P0 S90", 0.7)
    assert replies == ["ok"]
    with pytest.raises(ValueError, match=r"motor must be 0 \.\. 2, got 3"):
        sgf.stall(0.8, 3)


def test_moves_slower_than_their_feed_are_reported(homed):
    """The SGF obeys its limits without a word (as grbl does), but keeps count: a vertical
    move at 60 mm/s cruises at Z's 50 mm/s (400 microsteps/mm at 20,000 steps/s); a move
    within every limit adds nothing."""
    sgf, _, t = homed
    x, y, z = (v / 1e-3 for v in sgf.position_xyz)
    _, t = run_line(sgf, f"G01 X{x:.3f} Y{y:.3f} Z{z - 10:.3f} F{60 * 60:g}", t)
    _, t = run_line(sgf, f"G01 X{x:.3f} Y{y:.3f} Z{z - 20:.3f} F{60 * 60:g}", t)
    _, t = run_line(sgf, f"G01 X{x:.3f} Y{y:.3f} Z{z - 25:.3f} F{20 * 60:g}", t)
    from transplanter.machine.sgf import SLOWED_MEANS

    assert sgf.speed_warnings() == [
        "2 moves asked for 60 mm/s cruised at 50.0 mm/s or less: motor 3 reaches its top "
        f"step rate, 20000 steps/s (drives.max_step_rate_hz). {SLOWED_MEANS}"
    ]
    assert SLOWED_MEANS.startswith("Not a fault: ") and "paper's machine as built" in SLOWED_MEANS


@pytest.mark.parametrize("words", ["F0.0000001", "S0.000001"])
def test_a_move_too_slow_to_end_within_the_longest_move_is_refused(homed, words):
    """`G1 ... F0.0000001` was accepted and would have run for 700,000 years: a move whose
    planned duration exceeds MAX_MOVE_S is refused with error 63 (naming the word, the
    bound and the slowest speed that would do), nothing moves, the modal speed is kept."""
    from transplanter.machine.sgf import MAX_MOVE_S

    sgf, _, t = homed
    _, t1 = run_line(sgf, "G1 X0 Y180 Z100 S100", t)
    raw, position = sgf.raw_pulses, sgf.position_xyz
    replies, t2 = run_line(sgf, f"G1 X0 Y200 Z60 {words}", t1)
    assert len(replies) == 1 and replies[0].startswith(f"error:63 G1 {words}: ")
    assert f"longer than the {MAX_MOVE_S:g} s a move may take" in replies[0]
    assert t2 == t1 and np.array_equal(sgf.raw_pulses, raw)
    assert np.array_equal(sgf.position_xyz, position)
    _, t3 = run_line(sgf, "G1 Y200", t2)  # still 100 mm/s
    assert t3 - t2 < 1.0


def test_the_slowest_feed_a_refusal_offers_does_the_move(homed):
    from transplanter.machine.sgf import MAX_MOVE_S

    sgf, _, t = homed
    replies, t1 = run_line(sgf, "G1 X0 Y220 Z60 F0.0001", t)
    assert replies[0].startswith("error:63")
    offered = replies[0].split("give F")[1].split(" ")[0]
    replies, t2 = run_line(sgf, f"G1 X0 Y220 Z60 F{offered}", t1)
    assert replies == ["ok"] and t2 - t1 <= MAX_MOVE_S


KILLED = "error:71 Printer halted. kill() called! Emergency stop (M112)"


def test_m112_stops_every_motor_at_once_flushes_and_locks_motion_until_homed(homed):
    """M112 during a move was queued behind it and answered 'unsupported' once the move had
    run: it acts when it arrives, before any queue (Marlin's EMERGENCY_PARSER): the motors
    hold where they are, the running line and every queued line get error:71 (one reply
    each, in order), then the M112 itself; motion (moves, servos, conveyor) is refused until
    a G28; the stop position is reported."""
    sgf, endstops, t = homed
    sgf.drain_machine_events()
    sgf.receive("G1 X45 Y200 Z60 S10", t)  # seconds long
    sgf.receive("G4 P100", t)
    sgf.receive("M280 P0 S90", t)
    assert sgf.poll(t) == []
    t_done = sgf.next_event_time()
    t_stop = t + 0.4 * (t_done - t)
    assert sgf.poll(t_stop) == []
    held = sgf.pulses_at(t_stop)[0]
    sgf.receive("M112", t_stop)
    replies = sgf.poll(t_stop)
    assert [r.split(" ")[0] for r in replies] == ["error:71"] * 4
    assert f"G1 stopped by the emergency stop (M112) at t={t_stop:.3f} s" in replies[0]
    assert all("not run: emergency stop (M112)" in r for r in replies[1:3])
    assert replies[3].startswith(KILLED) and "2 queued lines flushed" in replies[3]
    assert not sgf.busy and sgf.next_event_time() is None
    assert sgf.drain_servo_commands() == []  # the flushed M280 never ran
    assert np.array_equal(sgf.pulses_at([t_stop, t_done, t_done + 5.0]), [held] * 3)
    assert np.array_equal(sgf.raw_pulses, held)
    stopped = sgf.position_xyz  # where the arm stopped, part way along the move
    assert 0.0 < stopped[0] < 0.045 and not sgf.homed
    assert [name for _, name in sgf.drain_machine_events()] == ["emergency_stop"]
    t1 = t_stop + 0.1
    for line in ("G1 X0 Y180 Z60", "M280 P0 S90", "M710", "G0 Z100"):
        replies, _ = run_line(sgf, line, t1)
        assert len(replies) == 1 and replies[0].startswith(f"error:71 {line.split()[0]} refused")
        assert "home with G28" in replies[0]
    assert sgf.drain_servo_commands() == [] and sgf.drain_machine_events() == []
    for line in ("M105", "G4 P10", "G90"):
        replies, t1 = run_line(sgf, line, t1)
        assert replies == ["ok"], line
    replies, _ = run_line(sgf, "M114", t1)
    assert replies[0].startswith(f"X:{stopped[0] * 1e3:.3f} Y:{stopped[1] * 1e3:.3f}")
    t2 = home(sgf, endstops, t1)
    replies, _ = run_line(sgf, "G1 X45 Y200 Z60 S100", t2)
    assert replies == ["ok"] and np.allclose(sgf.position_xyz, [0.045, 0.200, 0.060])


def test_m112_while_idle_or_framed_and_in_band_after_a_comment(homed):
    sgf, endstops, t = homed
    sgf.receive("N1 M112*32", t)  # framed: its line number counts
    assert len(replies := sgf.poll(t)) == 1 and replies[0].startswith(KILLED)
    assert "0 queued lines flushed" in replies[0]
    replies, _ = run_line(sgf, "N2 G1 X0 Y180 Z60*94", t)
    assert replies[0].startswith("error:71 G1 refused")
    # a comment before the word hides it from the scan (as from Marlin's): it stops the
    # machine in its turn, and still flushes what came after it
    t1 = home(sgf, endstops, t)
    sgf.receive("G4 P500", t1)
    sgf.receive("(stop) M112", t1)
    sgf.receive("M280 P0 S90", t1)
    replies, _ = run_line(sgf, "M105", t1)
    assert [r.split(" ")[0] for r in replies] == ["ok", "error:71", "error:71", "error:71"]
    assert replies[1].startswith(KILLED)
    assert sgf.drain_servo_commands() == []


def test_the_motion_version_changes_with_the_motion_and_is_none_while_homing():
    """`motion_version` (what `twin.loop.StepLoop` keeps a block of pulses by): None during a
    G28, whose legs change as switches trip; then a move changes it, a dwell does not (its
    pulses are the last move's end), and answers kept under one version stay true."""
    config = SGFConfig()
    sgf = SGF(config)
    endstops = SimulatedEndstops(config, START)
    sgf.receive("G28", 0.0)
    t, replies, during = 0.0, [], set()
    while not replies:
        replies = sgf.poll(t, endstops.read(sgf.pulses_at(t)[0]))
        if not replies:
            during.add(sgf.motion_version)
        t += 1e-3
    assert replies == ["ok"] and during == {None}
    v0 = sgf.motion_version
    assert v0 is not None
    _, t = run_line(sgf, "G4 P100", t)
    assert sgf.motion_version == v0
    sgf.receive("G1 X10 Y200 Z100 S50", t)
    sgf.poll(t)
    v1 = sgf.motion_version
    assert v1 != v0
    times = t + np.arange(200) * 1e-3
    kept = sgf.pulses_at(times)
    _, t_done = run_line(sgf, "G4 P10", t)
    assert sgf.motion_version == v1
    np.testing.assert_array_equal(sgf.pulses_at(times), kept)
