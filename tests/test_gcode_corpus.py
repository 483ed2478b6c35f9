"""Klipper-style G-code corpus: every line of tests/gcode/*.gcode carries its expected reply.

A line ``<G-code> ; expect: <reply> | <reply> ...`` is sent, exactly as written (its
``; expect:`` comment included, which the parser drops), to a fresh SGF per file, homing with
``firmware.rig.SimulatedEndstops`` as ``transplanter plan`` does. Its replies must be the
expected ones, in order: ``ok``, a report line such as ``X:0.000 Y:78.988 ...``, or
``error:<n>`` (the reply starts with it; words after it must start the message). ``expect: none``:
the line gives no reply. ``... in <s> s`` after the last reply: the line takes that long on the
SGF's clock (to 0.5 ms). Lines without ``; expect:`` (blank, comments) are not sent.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from transplanter.machine.config import power_on_joints
from transplanter.machine.rig import DT_HOMING_S, SimulatedEndstops
from transplanter.machine.sgf import SGF, SGFConfig

CORPUS = sorted((Path(__file__).parent / "gcode").glob("*.gcode"))
MARK = "; expect:"
_TAKES = re.compile(r"^(?P<replies>.*?) in (?P<s>[0-9.]+) s$")
_MAX_POLLS = 100_000


def expectations(path: Path) -> list[tuple[int, str, list[str], float | None]]:
    """(line number, line as sent, expected replies, expected duration or None)."""
    out = []
    for number, raw in enumerate(path.read_text(encoding="utf-8").split("\n"), start=1):
        if MARK not in raw:
            continue
        expect = raw[raw.rindex(MARK) + len(MARK) :].strip()
        took = _TAKES.match(expect)
        duration = float(took["s"]) if took else None
        expect = took["replies"] if took else expect
        replies = [] if expect == "none" else [r.strip() for r in expect.split("|")]
        out.append((number, raw, replies, duration))
    return out


def _matches(reply: str, expected: str) -> bool:
    if expected.startswith("error:"):  # 'error:33' or the start of its message
        return reply.startswith(expected + " ") or (" " in expected and reply.startswith(expected))
    return reply == expected


def run_line(sgf: SGF, endstops: SimulatedEndstops, text: str, t: float):
    """Send one line at t; poll until its final reply; (replies, time of the last reply)."""
    t0 = t
    sgf.receive(text, t)
    replies: list[str] = []
    for _ in range(_MAX_POLLS):
        replies += sgf.poll(t, endstops.read(sgf.pulses_at(t)[0]))
        if replies and (replies[-1] == "ok" or replies[-1].startswith("error:")):
            return replies, t
        t_next = sgf.next_event_time()
        if t_next is None and not sgf.homing:
            return replies, t  # nothing queued: the line gave no reply
        t = t + DT_HOMING_S if sgf.homing or t_next is None else max(t_next, t)
    raise AssertionError(f"{text!r} had no final reply after {t - t0:.3f} s")


def run_corpus(path: Path) -> list[str]:
    """Every mismatch of the file, as 'file:line: ...' messages."""
    config = SGFConfig()
    sgf = SGF(config)
    endstops = SimulatedEndstops(config, power_on_joints(config))
    t = 0.0
    problems = []
    for number, text, expected, duration in expectations(path):
        t0 = t
        replies, t = run_line(sgf, endstops, text, t)
        where = f"{path.name}:{number}: {text.split(MARK)[0].strip()!r}"
        if len(replies) != len(expected) or not all(
            _matches(r, e) for r, e in zip(replies, expected, strict=False)
        ):
            problems.append(f"{where} replied {replies}, expected {expected}")
        elif duration is not None and abs((t - t0) - duration) > 5e-4:
            problems.append(f"{where} took {t - t0:.4f} s, expected {duration} s")
    return problems


def test_corpus_files_exist_and_expect_something():
    names = {path.stem for path in CORPUS}
    assert names >= {"motion", "framing", "errors", "homing", "servos"}
    for path in CORPUS:
        lines = expectations(path)
        assert len(lines) >= 8, path.name
        assert any(expected for _, _, expected, _ in lines), path.name


@pytest.mark.parametrize("path", CORPUS, ids=[p.stem for p in CORPUS])
def test_corpus_replies(path):
    problems = run_corpus(path)
    assert not problems, "\n".join(problems)


def test_a_wrong_expectation_is_caught(tmp_path):
    wrong = tmp_path / "wrong.gcode"
    wrong.write_text(
        "G28 ; expect: ok\nG4 P100 ; expect: ok in 0.2 s\nG1 X0 Y999 ; expect: ok\n"
        "M400 ; expect: error:20\n; just a comment\nG90 ; expect: none\n",
        encoding="utf-8",
    )
    problems = run_corpus(wrong)
    assert [p.split(":")[1] for p in problems] == ["2", "3", "4", "6"]
    assert "took 0.1000 s, expected 0.2 s" in problems[0]
    assert "replied ['error:33 " in problems[1]
