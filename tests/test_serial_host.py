"""The PGF on a serial line (`SerialPGF`) against a Marlin-style device on a fake port."""

from __future__ import annotations

import dataclasses
import math

import pytest

from transplanter.machine.marlin import LineNoise, MarlinDevice
from transplanter.machine.pgf import PGF
from transplanter.machine.rig import SimulatedEndstops
from transplanter.machine.serial_host import SerialPGF, translate_reply
from transplanter.machine.sgf import SGF
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario

START = (math.radians(150.0), math.radians(30.0), 0.120)


class FakeClock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


class DevicePort:
    """A pyserial-like port wired to a MarlinDevice + SGF; reading advances a fake clock by
    the read timeout, polling the device every millisecond (it reads its switches)."""

    def __init__(self, machine, clock: FakeClock, silent: bool = False, **device_kwargs):
        self.sgf = SGF(machine.sgf)
        self.endstops = SimulatedEndstops(machine.sgf, START)
        self.device = MarlinDevice(self.sgf, **device_kwargs)
        self.clock, self.silent = clock, silent
        self.timeout = 0.0
        self._rx = b""
        self._tx = b""
        self.written: list[str] = []

    @property
    def in_waiting(self) -> int:
        return len(self._tx)

    def write(self, data: bytes) -> None:
        self._rx += data
        *lines, self._rx = self._rx.split(b"\n")
        for raw in lines:
            self.written.append(raw.decode())
            self.device.receive(raw.decode(), self.clock.t)

    def read(self, n: int) -> bytes:
        if not self._tx:
            end = self.clock.t + (self.timeout or 1e-3)
            while self.clock.t < end - 1e-12 and not self._tx:
                self.clock.t = min(self.clock.t + 1e-3, end)
                switches = self.endstops.read(self.sgf.pulses_at(self.clock.t)[0])
                out = self.device.poll(self.clock.t, switches)
                if not self.silent:
                    self._tx += "".join(f"{r}\n" for r in out).encode()
        data, self._tx = self._tx[:n], self._tx[n:]
        return data


def paper_pgf(seedlings: int = 2):
    machine = assemble(load_scenario("paper", {"scenario.seedlings": seedlings})).machine
    return machine, PGF(machine.eeprom, machine.pgf)


@pytest.mark.parametrize(
    ("line", "kind", "reply"),
    [
        ("ok", "ok", "ok"),
        ("ok T:0", "ok", "ok"),
        ("Resend: 12", "resend", None),
        ("rs N12", "resend", None),
        ("Error:checksum mismatch, Last Line: 11", "line_error", None),
        (
            "Error:target position not reachable [error:33]",
            "error",
            "error:33 target position not reachable",
        ),  # noqa: E501
        ('echo:Unknown command: "M123"', "error", 'error:20 Unknown command: "M123"'),
        ("busy: processing", "info", "busy: processing"),
    ],
)
def test_translate_reply(line, kind, reply):
    assert translate_reply(line) == (kind, reply)


def test_streams_the_taught_program_through_resends():
    machine, pgf = paper_pgf(2)
    clock = FakeClock()
    port = DevicePort(machine, clock, noise=LineNoise(0.1, seed=2))
    run = SerialPGF(pgf, port, clock=clock).run()
    assert run.done and run.fault is None
    assert run.resends >= 1 and port.device.noise.corrupted >= 1
    program = [line.text.split(" ", 1)[1].rsplit("*", 1)[0] for line in pgf.program]
    taken = [a.text for a in port.device.accepted if not a.text.startswith("M110")]
    assert taken == program
    assert all(a.reply == "ok" for a in port.device.accepted)


def test_a_device_counting_from_elsewhere_is_renumbered():
    machine, pgf = paper_pgf(1)
    clock = FakeClock()
    port = DevicePort(machine, clock)
    port.device.last_line_number = 57  # it talked to another host before
    run = SerialPGF(pgf, port, clock=clock).run()
    assert run.done and run.fault is None
    assert "M110 N0" in port.written
    assert [a.line_number for a in port.device.accepted][:2] == [None, 1]


def test_a_refused_line_stops_the_pgf_with_the_device_reason():
    machine, _ = paper_pgf(1)
    # a drop point out of reach: the device refuses the move there (Error + ok)
    eeprom = dataclasses.replace(machine.eeprom, drop_xy_m=(0.0, 0.400))
    pgf = PGF(eeprom, machine.pgf)
    clock = FakeClock()
    port = DevicePort(machine, clock)
    run = SerialPGF(pgf, port, clock=clock).run()
    assert not run.done
    assert "error:33" in run.fault and "not reachable" in run.fault
    assert "G1 X0 Y400 Z60" in run.fault  # the refused line is named
    assert run.lines_sent == 4  # nothing after it was sent


def test_no_answer_is_a_fault_naming_the_port():
    machine, pgf = paper_pgf(1)
    clock = FakeClock()
    port = DevicePort(machine, clock, silent=True)
    run = SerialPGF(pgf, port, name="/dev/ttyUSB7", clock=clock, connect_timeout_s=1.0).run()
    assert not run.done
    assert "no answer from /dev/ttyUSB7 within 1 s" in run.fault
