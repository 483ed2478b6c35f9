import pytest

from transplanter.machine.bus import TO_DEVICE, TO_HOST, ComBus, LineTransport


def test_is_a_line_transport_and_a_half_transport_is_not():
    assert isinstance(ComBus(), LineTransport)

    class SendOnly:
        def host_send(self, line: str, now: float) -> None: ...

    assert not isinstance(SendOnly(), LineTransport)


def test_line_arrives_after_its_transmission_time():
    bus = ComBus(baud_bps=115200.0)
    line = "G1 X10 Y175 Z32 S150"  # 20 characters + newline = 210 bits
    bus.host_send(line, 1.0)
    arrival = 1.0 + 21 * 10 / 115200.0
    assert bus.next_delivery_time() == pytest.approx(arrival, abs=1e-15)
    assert bus.device_receive(arrival - 1e-9) == []
    assert bus.device_receive(arrival) == [line]
    assert bus.device_receive(arrival + 1.0) == []
    assert bus.next_delivery_time() is None


def test_latency_adds_to_arrival():
    bus = ComBus(baud_bps=9600.0, latency_s=0.002)
    bus.device_send("ok", 0.0)
    assert bus.next_delivery_time() == pytest.approx(3 * 10 / 9600.0 + 0.002)
    assert bus.host_receive(0.004) == []
    assert bus.host_receive(0.006) == ["ok"]


def test_lines_in_one_direction_queue_behind_each_other():
    bus = ComBus(baud_bps=1000.0)
    bus.host_send("abcd", 0.0)  # 50 ms on the wire
    bus.host_send("ef", 0.01)  # waits for the wire: starts at 50 ms, 30 ms long
    times = [entry.t_delivered for entry in bus.transcript]
    assert times == pytest.approx([0.05, 0.08])
    assert bus.device_receive(0.06) == ["abcd"]
    assert bus.device_receive(0.08) == ["ef"]


def test_directions_are_independent_full_duplex():
    bus = ComBus(baud_bps=1000.0)
    bus.host_send("abcd", 0.0)
    bus.device_send("ok", 0.0)
    assert bus.next_delivery_time() == pytest.approx(0.03)
    assert bus.host_receive(0.03) == ["ok"]
    assert bus.device_receive(0.03) == []
    assert bus.next_delivery_time() == pytest.approx(0.05)
    assert bus.device_receive(0.05) == ["abcd"]


def test_transcript_records_both_directions():
    bus = ComBus(baud_bps=1000.0)
    bus.host_send("G28", 0.0)
    bus.device_receive(0.04)
    bus.device_send("ok", 0.5)
    assert [(e.direction, e.text) for e in bus.transcript] == [
        (TO_DEVICE, "G28"),
        (TO_HOST, "ok"),
    ]
    assert bus.transcript[1].t_sent == 0.5
    assert bus.transcript[1].t_delivered == pytest.approx(0.53)


def test_bad_input_is_refused():
    bus = ComBus()
    with pytest.raises(ValueError, match="one line"):
        bus.host_send("G1 X1\nG1 X2", 0.0)
    with pytest.raises(ValueError, match="ASCII"):
        bus.host_send("G1 X\u00e9", 0.0)
    with pytest.raises(TypeError):
        bus.host_send(b"G28", 0.0)
    bus.host_send("G28", 1.0)
    with pytest.raises(ValueError, match="backwards"):
        bus.device_receive(0.5)
    with pytest.raises(ValueError, match="baud"):
        ComBus(baud_bps=0)
    with pytest.raises(ValueError, match="latency"):
        ComBus(latency_s=-1)
    assert len(bus.transcript) == 1
