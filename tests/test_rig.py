import math

import numpy as np
import pytest

from transplanter.machine.bus import TO_DEVICE, TO_HOST, ComBus
from transplanter.machine.eeprom import EepromImage, Pickup
from transplanter.machine.gcode import checksum
from transplanter.machine.kinematics.fivebar import ik
from transplanter.machine.pgf import PGF, LinePhase, PGFConfig
from transplanter.machine.rig import FirmwareLink, SimulatedEndstops, run_firmware
from transplanter.machine.sgf import SGF, SGFConfig

CELL_X_MM = [-90, -45, 0, 45, 90]
DT_HOMING_S = 1e-3


def on_step_grid(config: SGFConfig, joints) -> np.ndarray:
    return np.array(
        [float(d.to_position(d.to_steps(q))) for d, q in zip(config.drives, joints, strict=True)]
    )


def taught_image(approach_y_m: float = 0.175) -> EepromImage:
    return EepromImage(
        pickups=tuple(Pickup((x / 1000, approach_y_m), (x / 1000, 0.215), 90.0) for x in CELL_X_MM),
        drop_xy_m=(0.0, 0.140),
        drop_wrist_deg=30.0,
        z_up_m=0.100,
        z_low_m=0.032,
        s_low_m_s=0.040,
        s_high_m_s=0.150,
    )


def expected_lines(seedlings: int) -> list[str]:
    lines = ["G28", "G90", "M280 P1 S30", "G1 X0 Y140 Z100 S150"]
    for i in range(seedlings):
        x = CELL_X_MM[i % 5]
        lines += [
            f"G1 X{x} Y175 Z32 S150",
            "M280 P1 S90",
            "M280 P0 S155",
            "G4 P200",
            f"G1 X{x} Y215 Z32 S40",
            "M280 P0 S60",
            "G4 P250",
            f"G1 X{x} Y215 Z100 S40",
            f"G1 X{x} Y175 Z100 S150",
            "M280 P1 S30",
            "G1 X0 Y140 Z100 S150",
            "M280 P0 S155",
            "G4 P200",
        ]
        if i % 5 == 4 and i < seedlings - 1:
            lines.append("M710")
    lines.append("M400")
    framed = []
    for number, text in enumerate(lines, start=1):
        body = f"N{number} {text}"
        framed.append(f"{body}*{checksum(body)}")
    return framed


def test_simulated_endstops_trip_at_home_positions():
    config = SGFConfig()
    start = on_step_grid(config, (math.radians(150), math.radians(30), 0.120))
    endstops = SimulatedEndstops(config, start)
    trip = endstops.trip_pulses()
    start_steps = [int(d.to_steps(q)) for d, q in zip(config.drives, start, strict=True)]
    # the first step at or past each switch: within a step of its nearest step
    assert np.all(np.abs(trip - (config.home_steps - start_steps)) <= 1)
    assert endstops.read([0, 0, 0]) == (False, False, False, False)
    assert endstops.read(trip - [1, -1, 1]) == (False, False, False, False)
    assert np.all(
        np.abs(endstops.joint_positions(trip) - config.home_joint_positions)
        <= endstops.unit_per_step
    )
    assert endstops.read(trip) == (True, True, True, False)
    assert endstops.read(trip + [5, -5, 5]) == (True, True, True, False)
    assert endstops.z_down_trip_m == config.kinematics.z_min_m == 0.005
    below, above = (int(config.drives[2].to_steps(z - 0.120)) for z in (0.0049, 0.0051))
    assert endstops.read([0, 0, below]) == (False, False, False, True)
    assert endstops.read([0, 0, above]) == (False, False, False, False)
    with pytest.raises(ValueError, match="beyond its limit switch"):
        SimulatedEndstops(config, (math.radians(205), 0.0, 0.1))


def test_five_pickup_cycle_through_bus(capsys):
    config = SGFConfig()
    start = on_step_grid(config, (math.radians(150), math.radians(30), 0.120))
    pgf = PGF(taught_image(), PGFConfig(seedlings=5))
    bus = ComBus(baud_bps=115200.0)
    sgf = SGF(config)
    endstops = SimulatedEndstops(config, start)
    result = run_firmware(pgf, bus, sgf, endstops, dt_homing_s=DT_HOMING_S)

    assert result.done and result.fault is None and pgf.done
    # the exact line sequence, each acknowledged with ok
    assert [s.text for s in pgf.sent] == expected_lines(5)
    assert all(s.reply == "ok" for s in pgf.sent)
    assert not any(s.phase is LinePhase.INDEX for s in pgf.sent)  # 5 seedlings: no row follows

    # no line sent before the previous line's ok arrived, on the PGF's log and on the wire
    for previous, line in zip(pgf.sent, pgf.sent[1:], strict=False):
        assert line.t_sent >= previous.t_reply > previous.t_sent
    to_device = [e for e in bus.transcript if e.direction == TO_DEVICE]
    to_host = [e for e in bus.transcript if e.direction == TO_HOST]
    assert len(to_device) == len(to_host) == len(pgf.sent)
    for k in range(1, len(to_device)):
        assert to_host[k - 1].t_sent >= to_device[k - 1].t_delivered
        assert to_device[k].t_sent >= to_host[k - 1].t_delivered

    # raw pulses: final position's step counts minus the start, plus the homing overshoot
    drives = config.drives
    theta1, theta2 = ik(config.kinematics.geometry, 0.0, 0.140)
    final_steps = np.array(
        [int(drives[0].to_steps(theta1)), int(drives[1].to_steps(theta2)),
         int(drives[2].to_steps(0.100))]
    )  # fmt: skip
    overshoot = sgf.homing_trip_raw - endstops.trip_pulses()
    locate_rate = np.array(config.homing.locate_rate_hz)
    assert np.all(np.abs(overshoot) <= np.ceil(locate_rate * DT_HOMING_S))
    assert np.array_equal(sgf.logical_steps, final_steps)
    # the logical counter was set to home_steps at raw pulse homing_trip_raw
    trip_raw = endstops.trip_pulses() + overshoot
    assert np.array_equal(sgf.raw_pulses, final_steps - config.home_steps + trip_raw)
    assert np.array_equal(sgf.pulses_at(result.end_time_s + 1.0)[0], sgf.raw_pulses)
    # physically the joints sit within half a step (IK rounding), plus the overshoot, plus
    # under a step (the switch's nearest step vs the first step past it) of the IK target
    error = np.abs(endstops.joint_positions(sgf.raw_pulses) - [theta1, theta2, 0.100])
    assert np.all(error <= (1.5 + np.abs(overshoot)) * endstops.unit_per_step + 1e-12)

    # servo commands: per seedling elbow, open, close, drop elbow, release
    servo = sgf.drain_servo_commands()
    assert [(i, d) for _, i, d in servo] == [(1, 30.0)] + [
        (1, 90.0), (0, 155.0), (0, 60.0), (1, 30.0), (0, 155.0)] * 5  # fmt: skip

    homed_at = next(s.t_reply for s in pgf.sent if s.phase is LinePhase.HOME)
    first = next(s.t_sent for s in pgf.sent if s.seedling == 0)
    last = max(s.t_reply for s in pgf.sent if s.seedling == 4)
    with capsys.disabled():
        print(
            f"\nfive-pickup cycle: homing done at {homed_at:.3f} s, 5 seedlings in "
            f"{last - first:.3f} s ({(last - first) / 5:.3f} s per seedling), "
            f"run ends at {result.end_time_s:.3f} s"
        )
    assert 1.0 < (last - first) / 5 < 20.0


def test_unreachable_taught_point_gives_error_and_moves_nothing():
    config = SGFConfig()
    start = on_step_grid(config, (math.radians(150), math.radians(30), 0.120))
    pgf = PGF(taught_image(approach_y_m=0.400), PGFConfig(seedlings=1))
    sgf = SGF(config)
    endstops = SimulatedEndstops(config, start)
    result = run_firmware(pgf, ComBus(), sgf, endstops)
    assert not result.done
    assert "target position not reachable" in result.fault
    assert [s.phase for s in pgf.sent] == [
        LinePhase.HOME,
        LinePhase.ABSOLUTE,
        LinePhase.START_ELBOW,
        LinePhase.TO_START,
        LinePhase.APPROACH,
    ]
    assert pgf.sent[-1].reply.startswith("error:33 target position not reachable")
    before = sgf.pulses_at(pgf.sent[-1].t_sent)[0]  # at the drop point, after to_start
    assert np.allclose(sgf.position_xyz, [0.0, 0.140, 0.100])
    assert np.array_equal(sgf.raw_pulses, before)
    assert np.array_equal(sgf.pulses_at([result.end_time_s, 1e3]), np.stack([before] * 2))


def test_malformed_line_over_bus_gives_error_and_moves_nothing():
    config = SGFConfig()
    start = on_step_grid(config, (math.radians(150), math.radians(30), 0.120))
    pgf = PGF(taught_image(), PGFConfig(seedlings=1))
    pgf.program = pgf.program[:2]  # home and G90 only, then done
    bus = ComBus()
    sgf = SGF(config)
    endstops = SimulatedEndstops(config, start)
    result = run_firmware(pgf, bus, sgf, endstops)
    assert result.done
    raw = sgf.raw_pulses
    t = result.end_time_s
    bus.host_send("G1 X1.2.3 Y150", t)
    t = bus.next_delivery_time()
    for line in bus.device_receive(t):
        sgf.receive(line, t)
    replies = sgf.poll(t)
    assert len(replies) == 1 and replies[0].startswith("error:2 ")
    assert np.array_equal(sgf.raw_pulses, raw)
    assert np.array_equal(sgf.pulses_at([t, t + 10.0]), np.stack([raw, raw]))
    assert not sgf.busy


def test_rig_reports_a_stall():
    config = SGFConfig()
    pgf = PGF(taught_image(), PGFConfig(seedlings=1))
    sgf = SGF(config)
    # no endstops: homing can only fail after its seek limit, which faults the PGF
    result = run_firmware(pgf, ComBus(), sgf, endstops=None)
    assert "homing failed" in result.fault


def test_firmware_link_exchanges_and_schedules():
    config = SGFConfig()
    start = on_step_grid(config, (math.radians(150), math.radians(30), 0.120))
    pgf = PGF(taught_image(), PGFConfig(seedlings=1))
    bus, sgf = ComBus(baud_bps=115200.0), SGF(config)
    endstops = SimulatedEndstops(config, start)
    log: list[tuple[float, str]] = []
    link = FirmwareLink(pgf, bus, sgf, log=log)
    sent = link.exchange(0.0)
    assert [(s.text, s.t_sent, s.reply) for s in sent] == [("N1 G28*18", 0.0, None)]
    assert log == [(0.0, "pgf> N1 G28*18")]
    t_arrive = link.next_event_time(0.0, 1e-3)
    assert t_arrive == bus.next_delivery_time() and 0.0 < t_arrive < 1e-3  # 9 bytes at 115200
    assert link.exchange(t_arrive, endstops.read(sgf.pulses_at(t_arrive)[0])) == []
    assert log[-1] == (t_arrive, "sgf< N1 G28*18") and sgf.homing
    # while homing: every dt_homing_s, to read the switches
    assert link.next_event_time(t_arrive, 2e-3) == t_arrive + 2e-3
    t = t_arrive
    for _ in range(20_000):  # 20 s of switch reads at most
        if not (pgf.current is not None and pgf.current.text.endswith("G28*18")):
            break
        t = link.next_event_time(t, 1e-3)
        sent = link.exchange(t, endstops.read(sgf.pulses_at(t)[0]))
    assert [s.phase for s in sent] == [LinePhase.ABSOLUTE] and pgf.sent[0].reply == "ok"
    assert [text for _, text in log[-3:]] == ["sgf> ok", "pgf< ok", f"pgf> {sent[0].text}"]
    # nothing in flight once the PGF has faulted and the bus is empty
    idle = FirmwareLink(PGF(taught_image(), PGFConfig(seedlings=1)), ComBus(), SGF(config))
    idle.pgf.poll(0.0, ["ok"])  # an ok nobody asked for: the PGF faults, sends nothing
    assert idle.exchange(0.0) == [] and idle.next_event_time(0.0, 1e-3) is None


# -- injected faults without physics (firmware.faults) ----------------------------------------

FAULT_START = (math.radians(150), math.radians(30), 0.120)


def _run_with_faults(faults, bus=None):
    """One seedling through the rig with the switch faults applied where they are read."""
    config = SGFConfig()
    pgf = PGF(taught_image(), PGFConfig(seedlings=1))
    sgf = SGF(config)
    endstops = SimulatedEndstops(config, on_step_grid(config, FAULT_START), faults=faults)
    result = run_firmware(pgf, bus or ComBus(), sgf, endstops)
    return result, pgf, sgf


def _assert_nothing_moves_after(result, pgf, sgf, t_fault):
    """After the fault no line is sent and the step pulses stay where they are."""
    assert not result.done and result.fault == pgf.fault
    assert all(line.t_sent <= t_fault for line in pgf.sent)
    held = sgf.pulses_at(t_fault)[0]
    times = np.linspace(t_fault, t_fault + 60.0, 7)
    assert np.array_equal(sgf.pulses_at(times), np.tile(held, (7, 1)))


@pytest.mark.parametrize(("switch", "name"), [(1, "arm 1 home"), (2, "arm 2 home"), (3, "Z up")])
def test_a_switch_stuck_closed_fails_homing_naming_it(switch, name):
    from transplanter.machine.faults import FaultConfig, FaultKind

    result, pgf, sgf = _run_with_faults(FaultConfig(switch_stuck_closed=switch))
    reply = pgf.sent[-1].reply
    assert pgf.sent[-1].phase == LinePhase.HOME and reply.startswith("error:68 homing failed: ")
    assert f"limit switch {switch} ({name}) still closed after the" in reply
    assert "(it was already closed when homing began)" in reply
    assert "stuck closed or its wiring is shorted" in reply
    assert pgf.fault_kind == FaultKind.SWITCH_STUCK_CLOSED
    _assert_nothing_moves_after(result, pgf, sgf, pgf.sent[-1].t_reply)


def test_switch_4_stuck_closed_refuses_the_first_move_down():
    from transplanter.machine.faults import FaultConfig, FaultKind

    result, pgf, sgf = _run_with_faults(FaultConfig(switch_stuck_closed=4))
    last = pgf.sent[-1]
    assert last.phase == LinePhase.TO_START
    assert last.reply.startswith("error:70 limit switch 4 (Z down) reads closed at Z 159.000 mm")
    assert pgf.fault_kind == FaultKind.SWITCH_STUCK_CLOSED
    _assert_nothing_moves_after(result, pgf, sgf, last.t_reply)


@pytest.mark.parametrize(("switch", "travel"), [(1, "4800 steps (180.0 deg)"),
                                               (2, "4800 steps (180.0 deg)"),
                                               (3, "80000 steps (200.0 mm)")])  # fmt: skip
def test_a_dead_switch_fails_homing_naming_it_and_the_travel(switch, travel):
    from transplanter.machine.faults import FaultConfig, FaultKind

    result, pgf, sgf = _run_with_faults(FaultConfig(switch_dead=switch))
    reply = pgf.sent[-1].reply
    assert reply.startswith(f"error:69 homing failed: limit switch {switch} (")
    assert f"not found: motor {switch} travelled {travel} towards it" in reply
    assert "dead or unplugged" in reply and "axis is blocked" in reply
    assert pgf.fault_kind == FaultKind.SWITCH_NOT_FOUND
    _assert_nothing_moves_after(result, pgf, sgf, pgf.sent[-1].t_reply)


def test_a_lost_reply_ends_the_run_with_a_bus_timeout():
    """The SGF's ok to line 5 (the first approach) is lost on the wire: the SGF did the move,
    the PGF hears nothing for reply_timeout_s and stops; nothing moves after."""
    from transplanter.machine.faults import FaultConfig, FaultKind, LostReplyTransport

    bus = LostReplyTransport(ComBus(), 5)
    result, pgf, sgf = _run_with_faults(FaultConfig(lost_reply_line=5), bus=bus)
    line = pgf.sent[-1]
    assert len(pgf.sent) == 5 and line.reply is None and line.phase == LinePhase.APPROACH
    assert [reply for _, reply in bus.lost] == ["ok"]
    assert result.fault == (
        f"bus timeout: no reply to line 5 {line.text!r} (approach) within 30 s; check the "
        "serial cable and that the SGF is powered and running"
    )
    assert pgf.fault_kind == FaultKind.BUS_TIMEOUT
    assert result.end_time_s == pytest.approx(line.t_sent + 30.0)
    _assert_nothing_moves_after(result, pgf, sgf, result.end_time_s)
    assert not sgf.busy


def test_firmware_link_schedules_the_reply_timeout():
    """With the reply lost nothing is in flight but the PGF's deadline: the link says when."""
    from transplanter.machine.faults import LostReplyTransport

    config = SGFConfig()
    pgf = PGF(taught_image(), PGFConfig(seedlings=1, reply_timeout_s=12.0))
    bus, sgf = LostReplyTransport(ComBus(), 2), SGF(config)
    link = FirmwareLink(pgf, bus, sgf)
    link.exchange(0.0)  # G28 sent: its reply is not lost
    assert pgf.next_event_time() == 12.0
    assert link.next_event_time(0.0, 1e-3) == bus.next_delivery_time()
