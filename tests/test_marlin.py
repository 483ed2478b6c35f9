"""The Marlin-style device layer in front of the SGF: framing, Resend, replies, keepalive."""

from __future__ import annotations

import math
import random

import pytest

from transplanter.machine.gcode import checksum
from transplanter.machine.marlin import LineNoise, MarlinDevice, split_framing
from transplanter.machine.rig import SimulatedEndstops
from transplanter.machine.sgf import SGF, SGFConfig

START = (math.radians(150.0), math.radians(30.0), 0.120)


def framed(number: int, body: str) -> str:
    head = f"N{number} {body}"
    return f"{head}*{checksum(head)}"


class Bench:
    """A MarlinDevice and its SGF on a simulated clock, with simulated switches."""

    def __init__(self, **kwargs) -> None:
        config = SGFConfig()
        self.sgf = SGF(config)
        self.endstops = SimulatedEndstops(config, START)
        self.device = MarlinDevice(self.sgf, **kwargs)
        self.t = 0.0
        self.out: list[str] = []

    def poll(self) -> list[str]:
        replies = self.device.poll(self.t, self.endstops.read(self.sgf.pulses_at(self.t)[0]))
        self.out += replies
        return replies

    def send(self, line: str, max_s: float = 60.0) -> list[str]:
        """Send one line and run until the device has answered it with an ok; its replies."""
        self.device.receive(line, self.t)
        got: list[str] = []
        deadline = self.t + max_s
        while self.t <= deadline:
            got += self.poll()
            if any(r.startswith("ok") for r in got):
                return got
            t_next = self.sgf.next_event_time()
            step = self.t + 1e-3 if self.sgf.homing or t_next is None else t_next
            self.t = min(step, self.t + 0.5)
        raise AssertionError(f"{line!r} never answered: {got}")


@pytest.fixture()
def bench():
    b = Bench(keepalive_s=0.0)  # test_busy_keepalive_during_a_long_line has it on
    assert b.send(framed(1, "G28")) == ["ok"]
    return b


def test_greeting_is_what_hosts_wait_for():
    assert MarlinDevice.greeting()[0] == "start"
    assert MarlinDevice.greeting()[1].startswith("echo:")


def test_split_framing_follows_marlin():
    assert split_framing(framed(7, "G1 X10")) == (7, "G1 X10", None)
    assert split_framing("G1 X10") == (None, "G1 X10", None)
    assert split_framing("N7 G1 X10")[2] == "No Checksum with line number"
    assert split_framing("N7 G1 X10*1")[2] == "checksum mismatch"
    assert split_framing("G1 X10*12")[2] == "No Line Number with checksum"
    assert split_framing(framed(-1, "M110 N-1")) == (-1, "M110 N-1", None)


def test_numbered_lines_run_in_order_and_get_ok(bench):
    assert bench.send(framed(2, "G90")) == ["ok"]
    assert bench.send(framed(3, "G1 X0 Y150 Z60 S100")) == ["ok"]
    assert [a.text for a in bench.device.accepted] == ["G28", "G90", "G1 X0 Y150 Z60 S100"]
    assert bench.device.last_line_number == 3


@pytest.mark.parametrize(
    ("line", "reason"),
    [
        ("N2 G1 X0 Y150 Z60*1", "checksum mismatch"),
        ("N2 G1 X0 Y150 Z60", "No Checksum with line number"),
        (framed(5, "G1 X0 Y150 Z60"), "Line Number is not Last Line Number+1"),
        ("G1 X0 Y150 Z60*33", "No Line Number with checksum"),
        ("N2 G1 X0 Y1\xb50 Z60*33", "checksum mismatch"),
    ],
)
def test_a_damaged_or_out_of_sequence_line_is_resent_and_moves_nothing(bench, line, reason):
    pulses = bench.sgf.pulses_at(bench.t)[0].copy()
    replies = bench.send(line)
    assert replies == [f"Error:{reason}, Last Line: 1", "Resend: 2", "ok"]
    assert len(bench.device.accepted) == 1 and bench.device.resends == 1
    assert (bench.sgf.pulses_at(bench.t + 5.0)[0] == pulses).all()
    # the same line, sent again intact, runs
    assert bench.send(framed(2, "G1 X0 Y150 Z60 S100")) == ["ok"]


def test_m110_sets_the_line_number_and_is_answered_in_order(bench):
    assert bench.send(framed(-1, "M110 N-1")) == ["ok"]
    assert bench.device.last_line_number == -1
    assert bench.send(framed(0, "G90")) == ["ok"]
    assert bench.send("M110 N41") == ["ok"]
    assert bench.send(framed(42, "G4 P10")) == ["ok"]


def test_only_the_command_word_makes_a_line_m110(bench):
    """Any line containing `M110`, even in a comment, became a no-op exempt from the
    line-number check: only the command word counts."""
    assert bench.send("G1 X0 Y170 Z60 S100 ; M110") == ["ok"]
    assert bench.sgf.position_xyz == pytest.approx([0.0, 0.170, 0.060])
    assert bench.send("G1 X10 Y170 Z60 (not an M110 N9)") == ["ok"]
    assert bench.sgf.position_xyz == pytest.approx([0.010, 0.170, 0.060])
    assert bench.device.last_line_number == 1
    replies = bench.send(framed(7, "G1 X0 Y170 Z60 ; M110"))  # out of sequence: refused
    error = "Error:Line Number is not Last Line Number+1, Last Line: 1"
    assert replies == [error, "Resend: 2", "ok"]
    assert bench.sgf.position_xyz == pytest.approx([0.010, 0.170, 0.060])
    assert bench.send("G4 P10 M110 N5") == ['echo:Unknown command: "G4 P10 M110 N5"', "ok"]
    assert bench.device.last_line_number == 1
    for line, last in (("M110 N41 ; from here", 41), ("m110 n7", 7), ("M0110 N3", 3)):
        assert bench.send(line) == ["ok"] and bench.device.last_line_number == last, line
    assert [a.text for a in bench.device.accepted][-3:] == ["M110 N41 ; from here", "m110 n7",
                                                            "M0110 N3"]  # fmt: skip


def test_a_line_with_nothing_to_run_never_takes_another_lines_reply(bench):
    """`; c` was queued for a reply the SGF never gives, so every later line got the reply
    of the line before it (`M999` answered `Unknown command: "; c"`, `M105` without its
    `T:0`). As Marlin's reader, an unnumbered line with nothing to run (empty, blanks, a
    comment) is skipped unanswered; a numbered one takes its line number and its `ok`."""
    for line in ("; c", "", "   ", "(a note)"):
        bench.device.receive(line, bench.t)
    assert bench.send("M999") == ['echo:Unknown command: "M999"', "ok"]
    assert bench.send("M105") == ["ok T:0"]
    assert bench.send(framed(2, "; c")) == ["ok"] and bench.device.last_line_number == 2
    assert bench.send(framed(3, "M105")) == ["ok T:0"]
    # while a move runs, with the comment between it and the poll: each its own reply
    bench.device.receive("G1 X0 Y170 Z60 S100", bench.t)
    bench.device.receive("; between", bench.t)
    assert bench.send("M105") == ["ok", "ok T:0"]
    assert bench.sgf.position_xyz == pytest.approx([0.0, 0.170, 0.060])
    assert bench.out == ["ok", 'echo:Unknown command: "M999"', "ok", "ok T:0", "ok", "ok T:0",
                         "ok", "ok T:0"]  # fmt: skip
    assert [a.text for a in bench.device.accepted] == [
        "G28", "M999", "M105", "; c", "M105", "G1 X0 Y170 Z60 S100", "M105"
    ]  # fmt: skip


def test_replies_in_marlin_form(bench):
    assert bench.send("M105") == ["ok T:0"]
    assert bench.send("M123") == ['echo:Unknown command: "M123"', "ok"]
    refused = bench.send("G1 X0 Y400 Z60")  # outside the workspace
    assert refused[-1] == "ok" and refused[0].startswith("Error:target position not reachable")
    assert refused[0].endswith("[error:33]")
    report = bench.send("M119")
    assert report[0] == "Reporting endstop status"
    assert report[1:5] == [
        "switch1 (arm 1 home): open",
        "switch2 (arm 2 home): open",
        "switch3 (Z up): open",
        "switch4 (Z down): open",
    ]
    position = bench.send("M114")
    assert position[0].startswith("X:") and position[1] == "ok"


def test_busy_keepalive_during_a_long_line():
    bench = Bench()  # Marlin's default: every 2 s
    replies = bench.send(framed(1, "G28"))  # homing takes seconds
    assert replies[-1] == "ok" and set(replies[:-1]) == {"busy: processing"}
    bench.device.receive(framed(2, "G4 P5000"), bench.t)
    t0 = bench.t
    replies = []
    for k in range(1, 61):
        bench.t = t0 + 0.1 * k
        replies += [(bench.t - t0, r) for r in bench.poll()]
    busy = [round(t, 1) for t, r in replies if r == "busy: processing"]
    assert busy == [2.0, 4.0]
    assert replies[-1][1] == "ok" and replies[-1][0] == pytest.approx(5.0)


def test_a_line_that_finds_no_room_is_resent_not_dropped(bench):
    sgf = bench.sgf
    n = 2
    bench.device.receive(framed(n, "G4 P1000"), bench.t)
    while sgf.room_for(framed(n + 1, "G4 P1000")):
        n += 1
        bench.device.receive(framed(n, "G4 P1000"), bench.t)
    bench.device.receive(framed(n + 1, "G4 P1000"), bench.t)
    replies = bench.poll()
    assert replies == [f"Error:receive buffer full, Last Line: {n}", f"Resend: {n + 1}", "ok"]
    assert sgf.rx_dropped == 0


def test_line_noise_is_seeded_and_hits_the_asked_share():
    a, b = LineNoise(0.01, seed=3), LineNoise(0.01, seed=3)
    lines = [framed(i, f"G1 X{i % 40} Y170") for i in range(1, 5001)]
    assert [a(x) for x in lines] == [b(x) for x in lines]
    assert 30 <= a.corrupted <= 75  # 50 expected
    with pytest.raises(ValueError, match="probability"):
        LineNoise(1.5)


def test_noisy_line_runs_every_line_exactly_once_in_order():
    """1,000 lines with 1 % of them hit by a byte error, through a host that resends on
    `Resend: n` (printcore's rule): every line executed once, in order."""
    bench = Bench(noise=LineNoise(0.01, seed=11), keepalive_s=0.0)
    rng = random.Random(5)
    bodies = ["G28", "G90"] + [
        f"G1 X{rng.randint(-60, 60)} Y{rng.randint(150, 230)} Z60 S200"
        if i % 2
        else f"M280 P0 S{rng.randint(60, 150)}"
        for i in range(998)
    ]
    sent = {n: framed(n, body) for n, body in enumerate(bodies, start=1)}
    next_n, resend_from = 1, None
    while next_n <= len(bodies):
        n = resend_from if resend_from is not None else next_n
        replies = bench.send(sent[n])
        resend_from = None
        for r in replies:
            if r.startswith("Resend: "):
                resend_from = int(r.split()[1])
        if resend_from is None:
            next_n = n + 1
    assert bench.device.noise.corrupted > 0  # about 10 expected
    assert bench.device.resends >= bench.device.noise.corrupted
    assert [a.text for a in bench.device.accepted] == bodies
    assert all(a.reply == "ok" for a in bench.device.accepted)


def test_an_endless_line_is_held_to_its_bound_and_refused_whole():
    """16 MB without a newline took quadratic time and served nothing else: the reader
    holds at most MAX_LINE_CHARS + 1 bytes of a line; the over-long line comes out as that
    much (which the device refuses as too long) and the next line as it was."""
    from transplanter.machine.gcode import MAX_LINE_CHARS
    from transplanter.machine.marlin import LineReader

    reader = LineReader()
    lines: list[bytes] = []
    chunk = b"G1 X1 " * 700  # 4200 bytes
    for _ in range(1000):  # 4.2 MB, no newline
        lines += reader.feed(chunk)
        assert len(reader.pending) <= MAX_LINE_CHARS + 1
    assert lines == []
    assert reader.feed(b"\r\nM105\r\nG28") == [chunk[: MAX_LINE_CHARS + 1], b"M105\r"]
    assert reader.pending == b"G28" and reader.overlong == 1
    # a carriage return kept in the cut line cannot make it short enough to pass
    assert reader.feed(b"\n" + b"\r" * 5000 + b"\n") == [b"G28", b"\x7f" * (MAX_LINE_CHARS + 1)]
    bench = Bench(keepalive_s=0.0)
    assert bench.send((b"\x7f" * (MAX_LINE_CHARS + 1)).decode("latin-1")) == [
        "Error:Line too long, Last Line: 0", "Resend: 1", "ok"
    ]  # fmt: skip
    assert bench.send("M105") == ["ok T:0"]


def test_m112_is_caught_before_any_queue_even_a_full_one(bench):
    """M112 behind a full queue and receive buffer used to be resent ('receive buffer
    full') and then run last: the device scans every line for it first (Marlin's
    EMERGENCY_PARSER) and the SGF stops at once; every line still gets one final reply and
    its ok, in order, the M112's last (Marlin's 'Printer halted. kill() called!')."""
    device, sgf = bench.device, bench.sgf
    n = 2
    device.receive(framed(n, "G1 X0 Y200 Z60 S5"), bench.t)
    while sgf.room_for(framed(n + 1, "G4 P1000")):
        n += 1
        device.receive(framed(n, "G4 P1000"), bench.t)
    assert bench.poll() == []
    bench.t += 1.0  # a second into the move
    held = sgf.pulses_at(bench.t)[0]
    device.receive("M112", bench.t)
    replies = bench.poll()
    finals = [r for r in replies if r != "ok"]
    assert replies.count("ok") == len(finals) == n  # lines 2..n, then the M112
    assert finals[0].startswith("Error:G1 stopped by the emergency stop (M112)")
    assert all(r.startswith("Error:not run: emergency stop (M112)") for r in finals[1:-1])
    assert finals[-1].startswith("Error:Printer halted. kill() called! Emergency stop (M112)")
    assert all(r.endswith("[error:71]") for r in finals)
    assert device.resends == 0 and device.accepted[-1].text == "M112"
    assert (sgf.pulses_at(bench.t + 60.0)[0] == held).all()
    # the line numbering goes on; motion waits for G28
    refused = bench.send(framed(n + 1, "G1 X0 Y180 Z60"))
    assert refused[0].startswith("Error:G1 refused") and refused[-1] == "ok"
    assert bench.send(framed(n + 2, "G28")) == ["ok"]
    assert bench.send(framed(n + 3, "G1 X0 Y180 Z60")) == ["ok"]


@pytest.mark.parametrize("line", ["N9 M112*0", "  m112", "N3 M112 ; stop"])
def test_m112_acts_whatever_its_framing(bench, line):
    """The scan reads the command word only: a damaged checksum or a wrong line number does
    not delay an emergency stop (nor does a Resend follow)."""
    replies = bench.send(line)
    assert replies[0].startswith("Error:Printer halted. kill() called!") and replies[1] == "ok"
    assert bench.device.resends == 0 and bench.device.last_line_number == 1
    assert bench.send("M1120") == ['echo:Unknown command: "M1120"', "ok"]  # not M112
