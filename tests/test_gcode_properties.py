"""Property-based tests (Hypothesis) of the G-code parser and Marlin framing.

Over arbitrary text, ``parse_line`` either returns None/a GcodeLine or raises GcodeError
(never another exception), and every accepted line formats back (``format_line``) to a line
that parses to the same command, words and line number. Bounded: a few seconds.
"""

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from transplanter.errors import ErrorCode  # noqa: E402
from transplanter.machine.gcode import (  # noqa: E402
    GcodeError,
    GcodeLine,
    checksum,
    format_line,
    parse_line,
)

# G-code-ish characters, so that a good share of the generated lines parse
GCODE_CHARS = st.sampled_from(list("GMNXYZFSPEe0123456789.-+ *;()\t") + ["G1 ", "M280 ", " X"])
NUMBERS = st.from_regex(r"[+-]?(?:[0-9]{1,4}(?:\.[0-9]{0,4})?|\.[0-9]{1,4})", fullmatch=True)


def _check(text: str, **kwargs) -> GcodeLine | None:
    try:
        result = parse_line(text, **kwargs)
    except GcodeError as error:
        assert isinstance(error.code, ErrorCode)
        assert error.reply.startswith(f"error:{int(error.code)} ")
        return None
    assert result is None or isinstance(result, GcodeLine)
    if result is not None:
        again = parse_line(format_line(result.command, result.words, result.line_number))
        assert (again.command, again.words, again.line_number) == (
            result.command,
            result.words,
            result.line_number,
        )
    return result


@settings(max_examples=400, deadline=None)
@given(st.text(max_size=120))
def test_arbitrary_text_gives_lines_or_typed_errors(text):
    _check(text)
    _check(text, expected_line_number=1, require_checksum=True)


@settings(max_examples=400, deadline=None)
@given(st.lists(GCODE_CHARS, max_size=40).map("".join))
def test_gcode_like_text_round_trips(text):
    _check(text)


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(["G0", "G1"]),
    st.dictionaries(st.sampled_from("XYZ"), NUMBERS, min_size=1),
    st.one_of(st.none(), st.integers(0, 2**31 - 1)),
    st.sampled_from(["", " ", "  (c*;) "]),
    st.sampled_from(["", " ", " ; tail"]),
)
def test_framed_moves_round_trip(command, words, line_number, comment, tail):
    body = " ".join([command] + [f"{k}{v}" for k, v in words.items()]) + comment
    if line_number is not None:
        framed = f"N{line_number} {body}"
        text = f"{framed}*{checksum(framed)}{tail}"
    else:
        text = body + tail
    result = _check(text, expected_line_number=line_number)
    assert result is not None and result.line_number == line_number
    assert result.words == {k: float(v) for k, v in words.items()}
