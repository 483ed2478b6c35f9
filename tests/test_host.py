"""transplanter.machine.host: a host program over the bus, one line outstanding, its own timers
and calls, as the delta's and the serial arm's jobs run it."""

from __future__ import annotations

import pytest

from transplanter.machine.bus import ComBus
from transplanter.machine.host import Call, HostProgram, Mark, Wait, WaitSince


def _run(host: HostProgram, bus: ComBus, replies: dict[str, str], until: float, dt=0.001):
    """Tick the host every dt until `until`; a device answering each line it gets with
    `replies.get(line, "ok")` at once; (t, line) of every line the device got."""
    got = []
    k = 0
    while k * dt <= until and not host.done:
        t = k * dt
        host.tick(t)
        for line in bus.device_receive(t):
            got.append((round(t, 6), line))
            bus.device_send(replies.get(line, "ok"), t)
        k += 1
    return got


def test_one_line_at_a_time_with_the_hosts_timers_and_calls():
    bus = ComBus(baud_bps=115200.0)
    seen = []

    def program():
        yield "G28"
        yield Mark("start")
        yield Wait(0.1)
        yield "G1 X1"
        answer = yield Call(lambda t: (seen.append(round(t, 6)), 42)[1])
        seen.append(answer)
        yield WaitSince("start", 0.5)  # the PLC's timer from the mark
        yield "M400"

    host = HostProgram(program(), bus)
    got = _run(host, bus, {}, 2.0)
    assert [line for _, line in got] == ["G28", "G1 X1", "M400"]
    # each line arrives a UART time after it was sent, the next only after its reply
    assert got[0][0] == pytest.approx(0.001, abs=1e-3)
    assert got[1][0] >= 0.1 and got[2][0] >= 0.5
    assert seen[1] == 42 and host.marks["start"] == pytest.approx(got[0][0], abs=2e-3)
    assert host.done and host.error is None


def test_an_error_reply_ends_the_program_and_a_list_program_runs_the_same():
    bus = ComBus()
    host = HostProgram(["G28", "G1 X500", "M400"], bus)
    got = _run(host, bus, {"G1 X500": "error:33"}, 1.0)
    assert [line for _, line in got] == ["G28", "G1 X500"]  # M400 never sent
    assert host.done and host.error == "error:33"


def test_an_item_that_is_no_line_nor_host_item_is_refused():
    host = HostProgram([("wait", 1.0)], ComBus())
    with pytest.raises(TypeError, match="a host program item must be a line or a host item"):
        host.tick(0.0)
