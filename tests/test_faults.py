"""Injected faults (firmware.faults): the config, the switch states, the lost reply, kinds."""

import pytest

from transplanter.machine.bus import ComBus, LineTransport
from transplanter.machine.faults import FaultConfig, FaultKind, LostReplyTransport, kind_of_reply


def test_no_faults_by_default():
    faults = FaultConfig()
    assert faults.switches((True, False, True, False)) == (True, False, True, False)
    assert not faults.jam_active(5.0) and faults.next_jam_change(0.0) is None


def test_switch_faults_override_what_the_switches_read():
    assert FaultConfig(switch_stuck_closed=4).switches([False] * 4) == (False, False, False, True)
    assert FaultConfig(switch_dead=2).switches([True] * 4) == (True, False, True, True)


def test_the_jam_holds_from_its_start_for_its_duration():
    jam = FaultConfig(jam_motor=3, jam_at_s=2.0, jam_duration_s=0.5, jam_torque_nm=1.0)
    assert [jam.jam_active(t) for t in (1.999, 2.0, 2.4999, 2.5)] == [False, True, True, False]
    assert [jam.next_jam_change(t) for t in (0.0, 2.0, 2.5)] == [2.0, 2.5, None]


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"switch_stuck_closed": 5}, "switch_stuck_closed must be 0-4"),
        ({"switch_dead": 4}, "switch_dead must be 0-3"),
        ({"jam_motor": 1}, "needs faults.jam_torque_nm > 0"),
        ({"switch_dead": 2, "switch_stuck_closed": 2}, "both stuck closed and dead"),
        ({"lost_reply_line": -1}, "whole number >= 0"),
        ({"jam_at_s": float("nan")}, "jam_at_s must be >= 0"),
    ],
)
def test_bad_fault_configs_are_refused(kwargs, needle):
    with pytest.raises(ValueError, match=needle):
        FaultConfig(**kwargs)


def test_the_reply_to_the_nth_line_is_lost_and_reports_pass():
    bus = LostReplyTransport(ComBus(), 2)
    assert isinstance(bus, LineTransport) and bus.baud_bps == 115200.0
    for reply in ("ok", "X:0.000 Y:0.000 Z:0.000 A:0 B:0 C:0", "ok", "error:33 no"):
        bus.device_send(reply, 0.0)
    assert bus.host_receive(1.0) == ["ok", "X:0.000 Y:0.000 Z:0.000 A:0 B:0 C:0", "error:33 no"]
    assert bus.lost == [(0.0, "ok")]
    with pytest.raises(ValueError):
        LostReplyTransport(ComBus(), 0)


def test_kind_of_reply():
    assert kind_of_reply("error:67 motor 1 stalled") is FaultKind.MOTOR_STALLED
    assert kind_of_reply("error:9 position unknown") is FaultKind.LINE_REFUSED
    assert str(FaultKind.BUS_TIMEOUT) == "bus_timeout"
