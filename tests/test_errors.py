"""Error codes: every ErrorCode member is a reply something really gives, every raise names it."""

import ast
from pathlib import Path

import numpy as np
import pytest

from transplanter.errors import ErrorCode
from transplanter.machine.config import power_on_joints
from transplanter.machine.gcode import GcodeError, format_line, parse_line
from transplanter.machine.homing import HomingConfig
from transplanter.machine.rig import SimulatedEndstops
from transplanter.machine.sgf import SGF, SGFConfig

SRC = Path(__file__).resolve().parents[1] / "src" / "transplanter"

# one line the parser refuses with each code (61 needs the expected line number)
PARSER = {
    ErrorCode.EXPECTED_COMMAND_LETTER: "X10 Y5",
    ErrorCode.BAD_NUMBER_FORMAT: "G1 X1.2.3",
    ErrorCode.NEGATIVE_VALUE: "G1 X1 F-100",
    ErrorCode.LINE_OVERFLOW: "G1 " + " ".join(["X1"] * 40),
    ErrorCode.UNSUPPORTED_COMMAND: "G2 X1 Y1",
    ErrorCode.MODAL_GROUP_VIOLATION: "G90 G1 X1",
    ErrorCode.UNDEFINED_FEED_RATE: "G1 X1 F0",
    ErrorCode.VALUE_NOT_INTEGER: "M280 P0.5 S10",
    ErrorCode.WORD_REPEATED: "G1 X1 X2",
    ErrorCode.NO_AXIS_WORDS: "G1 S100",
    ErrorCode.INVALID_LINE_NUMBER: "N-3 G28*16",
    ErrorCode.VALUE_WORD_MISSING: "G4",
    ErrorCode.UNUSED_WORDS: "G28 X0",
    ErrorCode.BAD_CHECKSUM: "N1 G28*0",
    ErrorCode.CHECKSUM_MISSING: "N1 G28",
    ErrorCode.VALUE_OUT_OF_RANGE: "M280 P2 S10",
    ErrorCode.UNTERMINATED_COMMENT: "G1 X1 (comment",
    ErrorCode.CHECKSUM_WITHOUT_LINE_NUMBER: "G28*27",
}


@pytest.mark.parametrize("code", list(PARSER), ids=[c.name for c in PARSER])
def test_parser_refuses_with_the_named_code(code):
    with pytest.raises(GcodeError) as info:
        parse_line(PARSER[code])
    assert info.value.code is code
    assert info.value.reply.startswith(f"error:{int(code)} ")


def _sgf_replies(lines: list[str]) -> list[str]:
    config = SGFConfig()
    sgf, endstops = SGF(config), SimulatedEndstops(config, power_on_joints(config))
    t, replies = 0.0, []
    for line in lines:
        sgf.receive(line, t)
        for _ in range(20_000):  # 20 s of homing polls at most
            replies += sgf.poll(t, endstops.read(sgf.pulses_at(np.array([t]))[0]))
            if not sgf.busy:
                break
            t_next = sgf.next_event_time()
            t = t + 1e-3 if sgf.homing or t_next is None else max(t, t_next)
    return replies


def test_every_code_is_a_reply_the_firmware_gives():
    given = {code for code in PARSER}
    with pytest.raises(GcodeError) as info:
        parse_line(format_line("G28", line_number=7), expected_line_number=6)
    given.add(info.value.code)
    replies = _sgf_replies(["G1 X0 Y200 Z50", "G28", "G1 X0 Y400 Z50", "G1 Z300"])
    assert [r.split(" ")[0] for r in replies] == ["error:9", "ok", "error:33", "error:33"]
    given |= {ErrorCode(int(r.split(" ")[0][6:])) for r in replies if r.startswith("error:")}
    flooded = SGF(SGFConfig())
    for _ in range(1000):  # nobody polls: the queue and receive buffer fill up
        flooded.receive("M105", 0.0)
    given |= {ErrorCode(int(r.split(" ")[0][6:])) for r in flooded.poll(0.0) if "error" in r}
    stalled = SGF(SGFConfig(stall_detection=True))
    stalled.homed = True  # a driver's stall flag while a line runs
    stalled.receive("G4 P100", 0.0)
    stalled.poll(0.0)
    stalled.stall(0.05, 0)
    given |= {ErrorCode(int(r.split(" ")[0][6:])) for r in stalled.poll(0.05)}
    # homing with switch 3 stuck closed (68), then with it dead (69)
    for switch_3 in (True, False):
        homing = SGF(SGFConfig(homing=HomingConfig(max_steps=(200, 200, 400))))
        homing.receive("G28", 0.0)
        replies = []
        for k in range(10_000):
            replies = homing.poll(k * 1e-3, (False, False, switch_3, False))
            if replies:
                break
        given.add(ErrorCode.of_reply(replies[0]))
    # a Z-down move while limit switch 4 reads closed (70)
    config = SGFConfig()
    sgf, endstops = SGF(config), SimulatedEndstops(config, power_on_joints(config))
    sgf.receive("G28", 0.0)
    for k in range(20_000):
        sgf.poll(k * 1e-3, endstops.read(sgf.pulses_at(k * 1e-3)[0]))
        if sgf.homed:
            break
    t = k * 1e-3
    sgf.receive("G1 X0 Y180 Z50", t)
    given.add(ErrorCode.of_reply(sgf.poll(t, (False, False, False, True))[0]))
    sgf.receive("M112", t)  # an emergency stop (71)
    given.add(ErrorCode.of_reply(sgf.poll(t)[0]))
    assert given == set(ErrorCode)


def test_the_code_of_a_reply():
    assert ErrorCode.of_reply("error:67 motor 2 stalled") is ErrorCode.MOTOR_STALLED
    assert ErrorCode.of_reply("error:9") is ErrorCode.SYSTEM_LOCKED
    for other in ("ok", "error:", "error:670 x", "error:x1", "Error:9", "error:\u0661"):
        assert ErrorCode.of_reply(other) is None, other


def test_reply_format_and_int_compatibility():
    assert ErrorCode.INVALID_TARGET.reply("Z out of range") == "error:33 Z out of range"
    assert ErrorCode(9) is ErrorCode.SYSTEM_LOCKED
    assert f"error:{ErrorCode.SYSTEM_LOCKED}" == "error:9"  # formats as its number
    assert ErrorCode.BAD_CHECKSUM + 1 == ErrorCode.LINE_OUT_OF_SEQUENCE
    assert sorted(ErrorCode)[0] == 1 and max(ErrorCode) == 71


def _first_args_of_gcode_errors(path: Path) -> list[ast.expr]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [
        node.args[0]
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name)
        and node.func.id == "GcodeError"
        and node.args
    ]


def test_every_raise_names_its_code():
    files = sorted((SRC / "machine").glob("*.py"))

    sites = {path.name: _first_args_of_gcode_errors(path) for path in files}
    assert len(sites["gcode.py"]) >= 28 and len(sites["sgf.py"]) >= 4
    for name, args in sites.items():
        for arg in args:
            assert (
                isinstance(arg, ast.Attribute)
                and isinstance(arg.value, ast.Name)
                and arg.value.id == "ErrorCode"
                and arg.attr in ErrorCode.__members__
            ), f"{name}:{arg.lineno} raises GcodeError({ast.unparse(arg)}, ...)"
    for path in files:
        assert "error:{" not in path.read_text(encoding="utf-8").replace(
            'f"error:{int(self)}', ""
        ), f"{path.name} builds an error reply by hand"
