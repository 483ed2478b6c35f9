"""`transplanter serve` behind a pty: driven by `transplanter pgf` and by Printrun's printcore.

Each test starts `serve` as its own process (as a user would), connects a host to the
printed pty path and reads the results JSON serve writes when the host hangs up.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from transplanter.machine.pgf import PGF
from transplanter.machine.serial_host import SerialPGF
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.twin.trial import run_trial

EXAMPLE = Path(__file__).resolve().parents[1] / "scenarios" / "example.gcode"

pytestmark = pytest.mark.slow


def start_serve(tmp_path: Path, *args: str) -> tuple[subprocess.Popen, str, Path]:
    out = tmp_path / "serve.json"
    cmd = [sys.executable, "-m", "transplanter.cli", "serve", "paper", "--json", str(out), *args]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = proc.stdout.readline()
    match = re.search(r" on (/dev/\S+) ", first)
    assert match, f"serve printed {first!r}; stderr: {proc.stderr.read() if proc.poll() else ''}"
    return proc, match.group(1), out


def finish_serve(proc: subprocess.Popen, out: Path, status: int = 0) -> dict:
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == status, stdout + stderr
    return json.loads(out.read_text())


def test_pgf_over_a_pty_reproduces_the_trial(tmp_path):
    # six seedlings: a conveyor index after the fifth
    scenario = load_scenario("paper", {"scenario.seedlings": 6})
    expected = run_trial(assemble(scenario)).to_dict()
    proc, device, out = start_serve(tmp_path, "--seedlings", "6")
    import serial

    port = serial.Serial(device, 115200, timeout=0)
    machine = assemble(scenario).machine
    run = SerialPGF(PGF(machine.eeprom, machine.pgf), port, name=device).run()
    port.close()
    assert run.done and run.fault is None and run.resends == 0
    got = finish_serve(proc, out)
    assert got["serial"]["program_lines_done"] == got["serial"]["program_lines"] == run.lines_sent
    assert got["serial"]["host_lines"] == 0
    for key in ("successes", "cycle_time_s", "failures", "sim_time_s"):
        assert got[key] == expected[key], key
    # serve learns that a line was sent when the device has taken it (its framing checked),
    # a few ms after the send: the belt displacement sampled in those ms can go to the
    # previous seedling's cycle, and the row's offset read at the send differs (um),
    # everything else is the same
    drop = ("wall_time_s", "max_belt_displacement_mm", "row_offset_mm")
    for mine, theirs in zip(got["per_seedling"], expected["per_seedling"], strict=True):
        assert {k: v for k, v in mine.items() if k not in drop} == {
            k: v for k, v in theirs.items() if k not in drop
        }


def test_a_dead_switch_stops_the_machine_with_its_error_on_the_line(tmp_path):
    proc, device, out = start_serve(tmp_path, "--seedlings", "1", "--set", "faults.switch_dead=2")
    import serial

    port = serial.Serial(device, 115200, timeout=0)
    machine = assemble(load_scenario("paper", {"scenario.seedlings": 1})).machine
    run = SerialPGF(PGF(machine.eeprom, machine.pgf), port, name=device).run()
    port.close()
    assert not run.done and "error:69" in run.fault and "limit switch 2" in run.fault
    assert run.lines_sent == 1  # the PGF stopped at G28: nothing after it was sent
    got = finish_serve(proc, out, status=4)
    assert got["fault_kind"] == "switch_not_found"
    assert "error:69" in got["fault"]
    assert got["serial"]["executed"] == ["G28"]
    assert got["failures"]["not_run"] == 1


def _program_lines(path: Path) -> list[str]:
    lines = []
    for raw in path.read_text().splitlines():
        text = raw.split(";", 1)[0].strip()
        if text:
            lines.append(text)
    return lines


def _printcore_session(device: str, lines: list[str], timeout_s: float = 240.0):
    from printrun import gcoder
    from printrun.printcore import printcore

    received: list[str] = []
    core = printcore()
    core.recvcb = received.append
    core.connect(device, 115200)
    deadline = time.monotonic() + 30
    while not core.online:
        assert time.monotonic() < deadline, f"printcore never came online: {received}"
        time.sleep(0.05)
    core.startprint(gcoder.LightGCode(lines))
    deadline = time.monotonic() + timeout_s
    while core.printing:
        assert time.monotonic() < deadline, "printcore did not finish"
        time.sleep(0.05)
    oks = sum(r.startswith("ok") for r in received)
    time.sleep(0.5)  # the M110 printcore sends when it finishes gets its ok
    core.send_now("M114")
    deadline = time.monotonic() + 10
    while not any(r.startswith("X:") for r in received):
        assert time.monotonic() < deadline, "no M114 report"
        time.sleep(0.05)
    core.disconnect()
    return received, oks, core


def test_printcore_streams_the_example_program(tmp_path):
    lines = _program_lines(EXAMPLE)
    rrd = tmp_path / "serve.rrd"
    proc, device, out = start_serve(tmp_path, "--seedlings", "1", "--record", str(rrd))
    received, oks, core = _printcore_session(device, lines)
    got = finish_serve(proc, out)
    assert rrd.stat().st_size > 10_000  # the session's recording, as trial --record writes
    serial = got["serial"]
    assert serial["resends"] == 0
    executed = [c for c in serial["executed"] if not c.startswith(("M110", "M105"))]
    assert executed == lines + ["M114"]
    # every line printcore sent (M105 probe, M110s, the program) got its ok
    assert oks >= len(lines) + 2
    report = next(r for r in received if r.startswith("X:"))
    assert report.split()[:3] == ["X:0.000", "Y:140.000", "Z:60.000"]  # the file's last move
    assert serial["final_position_mm"] == [0.0, 140.0, 60.0]
    assert any(r.startswith("start") for r in received) or oks  # greeted or answered


def test_printcore_with_byte_errors_completes_through_resend(tmp_path):
    """1,000 lines, 1 % of them hit by a flipped bit or a dropped byte: every line runs
    exactly once, in order, and the arm ends where the file ends."""
    lines = ["G28", "G90"]
    for i in range(998):
        x = -20.0 + (i % 41)
        y = 160.0 + (i % 7)
        lines.append(f"G1 X{x:g} Y{y:g} Z60 S100" if i % 3 else f"M280 P0 S{90 + i % 60}")
    proc, device, out = start_serve(
        tmp_path, "--seedlings", "1", "--inject-errors", "0.01", "--inject-seed", "7"
    )
    received, _, _ = _printcore_session(device, lines)
    got = finish_serve(proc, out)
    serial = got["serial"]
    assert serial["corrupted_by_noise"] >= 5  # about 10 expected
    assert serial["resends"] >= serial["corrupted_by_noise"]
    executed = [c for c in serial["executed"] if not c.startswith(("M110", "M105"))]
    assert executed == lines + ["M114"]
    last = (
        lines[-1]
        if lines[-1].startswith("G1")
        else next(ln for ln in reversed(lines) if ln.startswith("G1"))
    )
    x, y = (float(w[1:]) for w in last.split()[1:3])
    assert serial["final_position_mm"][:2] == [x, y]
    assert any(r.startswith("Resend:") for r in received)


class ScriptedEndpoint:
    """Lines a host 'writes' after given wall-clock delays; records what it is sent."""

    path = "scripted"

    def __init__(self, script: list[tuple[float, str]]) -> None:
        self.script = list(script)
        self.t0 = time.monotonic()
        self.closed = False
        self.written: list[str] = []

    def read_lines(self, timeout_s: float) -> list[bytes]:
        if not self.script:
            self.closed = True
            return []
        due, line = self.script[0]
        wait = self.t0 + due - time.monotonic()
        if wait > timeout_s:
            time.sleep(timeout_s)
            return []
        time.sleep(max(wait, 0.0))
        self.script.pop(0)
        return [line.encode()]

    def write_lines(self, lines: list[str]) -> None:
        self.written += lines


def _bare_host(endpoint, **kwargs):
    from types import SimpleNamespace

    from transplanter.machine.bus import ComBus
    from transplanter.machine.sgf import SGF
    from transplanter.twin.serve import RemoteHost

    machine = assemble(load_scenario("paper", {"scenario.seedlings": 1})).machine
    host = RemoteHost(endpoint, machine, **kwargs)
    host.attach(SimpleNamespace(sgf=SGF(machine.sgf), bus=ComBus()))
    return host


def test_idle_machine_waits_for_the_host_without_simulated_time_passing():
    endpoint = ScriptedEndpoint([(0.3, "M105")])
    host = _bare_host(endpoint)
    assert endpoint.written[0] == "start"  # the boot greeting, before any host line
    assert host.poll(0.0, []) == ["M105"]  # blocked until the host wrote, at t = 0
    assert time.monotonic() - endpoint.t0 >= 0.3


def test_realtime_paces_simulated_time_to_the_wall_clock():
    endpoint = ScriptedEndpoint([(5.0, "M105")])
    host = _bare_host(endpoint, realtime=True)
    t0 = time.monotonic()
    assert host.poll(0.0, []) == []
    assert host.poll(0.4, []) == []  # nothing from the host yet: no wait beyond the pacing
    # paced: at least the 0.4 s simulated; not waiting for the host's line (due at 5 s). The
    # bounds are far apart, so a loaded machine cannot make the test fail.
    assert 0.38 <= time.monotonic() - t0 < 4.0


class Host:
    """A host on serve's pty, one line at a time: ``ask`` writes a line and reads what comes
    back up to its ``ok``. Reads are bounded by count (each waits at most ``read_s``), so a
    line the twin never answers fails the test instead of hanging it."""

    def __init__(self, device: str, read_s: float = 0.5) -> None:
        import serial

        self.port = serial.Serial(device, 115200, timeout=read_s)
        self._buffer = b""
        self._complete: list[str] = []  # read, not yet handed out
        self.received: list[str] = []
        self.greeting = self.lines(lambda r: r.startswith("echo:"))  # start, the banner

    def lines(self, until, max_reads: int = 120) -> list[str]:
        """Lines read until one satisfies ``until`` (that one included)."""
        got: list[str] = []
        for _ in range(max_reads):
            while self._complete:
                line = self._complete.pop(0)
                got.append(line)
                self.received.append(line)
                if until(line):
                    return got
            self._buffer += self.port.read(max(1, self.port.in_waiting))
            *complete, self._buffer = self._buffer.split(b"\n")
            self._complete += [raw.decode("ascii").rstrip("\r") for raw in complete]
        raise AssertionError(f"no end of the reply after {max_reads} reads: {got}")

    def ask(self, line: str, max_reads: int = 120) -> list[str]:
        self.port.write(f"{line}\n".encode("ascii"))
        return self.lines(lambda r: r.startswith("ok"), max_reads)

    def close(self) -> None:
        self.port.close()


@pytest.fixture()
def serve(tmp_path):
    """start_serve for this test; a serve still running at teardown (a test that failed
    before its host hung up) is killed."""
    procs: list[subprocess.Popen] = []

    def start(*args: str) -> tuple[subprocess.Popen, str, Path]:
        proc, device, out = start_serve(tmp_path, *args)
        procs.append(proc)
        return proc, device, out

    yield start
    for proc in procs:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


def test_serve_answers_an_endless_dwell_or_feed_at_once(serve):
    """`G4 P1000000000000` and `G1 ... F0.0000001` were taken and never answered (the twin
    simulated the dwell or the move): both are refused with error 63 and the session goes on."""
    proc, device, out = serve("--seedlings", "1")
    host = Host(device)
    try:
        assert host.ask("G28")[-1] == "ok"
        for line in ("G4 P1000000000000", "G1 X0 Y200 Z60 F0.0000001"):
            replies = host.ask(line)
            assert len(replies) == 2 and replies[1] == "ok", replies
            assert replies[0].startswith(f"Error:{line.split()[0]} ")
            assert "longer than" in replies[0] and replies[0].endswith("[error:63]")
        assert host.ask("M400") == ["ok"]
    finally:
        host.close()
    got = finish_serve(proc, out)
    assert got["serial"]["executed"] == [
        "G28", "G4 P1000000000000", "G1 X0 Y200 Z60 F0.0000001", "M400"
    ]  # fmt: skip
    assert got["sim_time_s"] < 60


def test_a_line_without_end_is_held_to_its_bound_on_the_pty():
    """4 MB without a newline reach the endpoint: it never holds more than one over-long
    line's bound (the work per byte is constant), then hands on the cut line and the next
    good one. Loops bounded by count; the pty is written without blocking."""
    from transplanter.machine.gcode import MAX_LINE_CHARS
    from transplanter.twin.serve import PtyEndpoint

    endpoint = PtyEndpoint()
    host = os.open(endpoint.path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        data = memoryview(b"G1 X1 " * 700_000 + b"\nM105\n")
        lines: list[bytes] = []
        for _ in range(200_000):
            if data:
                try:
                    data = data[os.write(host, data[:4096]) :]
                except BlockingIOError:
                    pass
            lines += endpoint.read_lines(0.0 if data else 0.05)
            assert len(endpoint.reader.pending) <= MAX_LINE_CHARS + 1
            if len(lines) == 2:
                break
        assert lines == [b"G1 X1 " * 42 + b"G1 X1", b"M105"]
    finally:
        os.close(host)
        endpoint.close()


def test_serve_refuses_an_endless_line_and_answers_the_next(serve):
    proc, device, out = serve("--seedlings", "1")
    host = Host(device)
    try:
        host.port.write(b"X" * 4_000_000)
        replies = host.ask("\nM105")
        assert replies == ["Error:Line too long, Last Line: 0", "Resend: 1", "ok"]
        assert host.lines(lambda r: r.startswith("ok")) == ["ok T:0"]
    finally:
        host.close()
    got = finish_serve(proc, out)
    assert got["serial"]["executed"] == ["M105"] and got["serial"]["resends"] == 1


def test_a_comment_line_leaves_every_reply_with_its_own_line(serve):
    """A comment-only line (`; c`, as a host such as Printrun may send) shifted every later
    reply by one: `M999` was answered `Unknown command: "; c"`, `M105` lost its `T:0`. As
    Marlin, unnumbered empty and comment lines are skipped unanswered; a numbered one gets
    its `ok`."""
    from transplanter.machine.gcode import checksum

    proc, device, out = serve("--seedlings", "1")
    host = Host(device)
    try:
        host.port.write(b"; c\n\n(a note)\n")
        assert host.ask("M999") == ['echo:Unknown command: "M999"', "ok"]
        assert host.ask("M105") == ["ok T:0"]
        for head, reply in (("N1 ; c", "ok"), ("N2 M105", "ok T:0")):
            assert host.ask(f"{head}*{checksum(head)}") == [reply], head
    finally:
        host.close()
    got = finish_serve(proc, out)
    assert got["serial"]["executed"] == ["M999", "M105", "; c", "M105"]
    assert got["serial"]["lines_received"] == 7 and got["serial"]["resends"] == 0


def test_m112_during_a_move_stops_it_at_once(serve):
    """M112 during a move was queued and answered 'Unknown command' after the move. In real
    time (so that the move lasts 10 s of wall clock) the host sends M112 once the device's
    first 'busy: processing' shows the move running: the move is stopped part way, both lines
    answered, motion refused until G28, and the session records the emergency stop."""
    proc, device, out = serve("--seedlings", "1", "--realtime")
    host = Host(device)
    try:
        assert host.ask("G28", max_reads=240)[-1] == "ok"
        host.port.write(b"G1 X0 Y220 Z60 S14\n")  # 141 mm: 10 s
        assert host.lines(lambda r: r == "busy: processing") == ["busy: processing"]
        replies = host.ask("M112")  # the G1's reply and its ok
        replies += host.lines(lambda r: r.startswith("ok"))  # the M112's
        replies = [r for r in replies if r != "busy: processing"]
        assert replies[0].startswith("Error:G1 stopped by the emergency stop (M112)")
        assert replies[2].startswith("Error:Printer halted. kill() called!")
        assert replies[1] == replies[3] == "ok" and len(replies) == 4
        report = host.ask("M114")
        y = float(report[0].split()[1].removeprefix("Y:"))
        assert 90.0 < y < 215.0, report  # stopped part way (the move starts at Y 79)
        assert host.ask("G1 X0 Y200 Z60")[0].startswith("Error:G1 refused")
        assert host.ask("G28", max_reads=240)[-1] == "ok"
        assert host.ask("G1 X0 Y200 Z60 S200")[-1] == "ok"
    finally:
        host.close()
    got = finish_serve(proc, out, status=4)
    assert got["fault_kind"] == "emergency_stop" and "M112" in got["fault"]
    assert got["serial"]["executed"] == [
        "G28", "G1 X0 Y220 Z60 S14", "M112", "M114", "G1 X0 Y200 Z60", "G28", "G1 X0 Y200 Z60 S200"
    ]  # fmt: skip


def test_the_port_is_read_every_host_poll_while_the_machine_is_busy():
    """An M112 must not wait for the next firmware event (a whole move later): while the
    machine is busy the stand-in asks to be polled every HOST_POLL_S of simulated time."""
    from transplanter.twin.serve import HOST_POLL_S

    endpoint = ScriptedEndpoint([(0.0, "G4 P1000"), (600.0, "M105")])
    host = _bare_host(endpoint)
    assert host.next_event_time() is None  # idle: it waits for the host instead
    lines = host.poll(0.0, [])
    host.device.receive(lines[0], 0.0)
    host.device.poll(0.0)
    assert host.next_event_time() == HOST_POLL_S
    host.poll(0.25, [])
    assert host.next_event_time() == 0.25 + HOST_POLL_S


def test_serve_ends_when_the_host_hangs_up_even_mid_dwell(serve):
    """The host closed the port during a 10-minute dwell and serve simulated the dwell to
    its end (a real port never ended at all): the session ends when the port closes, says so
    in one line and writes its results as usual."""
    proc, device, out = serve("--seedlings", "1")
    host = Host(device)
    assert host.ask("G28", max_reads=240)[-1] == "ok"
    host.port.write(b"G4 P600000\nM400\n")
    assert host.lines(lambda r: r == "busy: processing") == ["busy: processing"]
    host.close()
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stdout + stderr
    ended = [line for line in stdout.splitlines() if line.startswith("session ended")]
    assert len(ended) == 1 and "the host closed the port at t = " in ended[0], stdout
    assert "2 lines not answered" in ended[0]
    got = json.loads(out.read_text())
    assert got["sim_time_s"] < 600 and got["serial"]["ended"] in ended[0]
    assert got["serial"]["executed"] == ["G28", "G4 P600000", "M400"]


def test_a_real_port_that_goes_away_ends_the_session():
    """pyserial raises on a port whose device went away (a USB adapter pulled, here a pty
    whose other side closed): the endpoint reports the port closed instead of failing."""
    from transplanter.twin.serve import SerialEndpoint

    master, slave = os.openpty()
    endpoint = SerialEndpoint(os.ttyname(slave), 115200)
    os.close(slave)
    os.write(master, b"M105\n")
    lines: list[bytes] = []
    for _ in range(100):
        lines += endpoint.read_lines(0.05)
        if lines:
            break
    assert lines == [b"M105"] and not endpoint.closed
    os.close(master)
    for _ in range(100):
        assert endpoint.read_lines(0.05) == []
        if endpoint.closed:
            break
    assert endpoint.closed
    endpoint.write_lines(["ok"])  # nobody there: nothing raised
    endpoint.close()
