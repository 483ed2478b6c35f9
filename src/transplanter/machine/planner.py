"""Plans a G-code program through the SGF on a simulated clock (`transplanter plan`).

Each line goes to the SGF exactly as over the bus, one at a time after the previous reply
(``rig.DirectLink``, as the HMI drives it); homing reads simulated limit switches. For every
line it reports how long the SGF took to answer and the net step pulses each motor made, or
stops at the first error reply.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from transplanter.errors import TransplanterError
from transplanter.machine.config import Machine, power_on_joints
from transplanter.machine.gcode import GcodeError, parse_line, split_program_lines
from transplanter.machine.rig import DirectLink, NoAnswer, SimulatedEndstops
from transplanter.machine.sgf import SGF

__all__ = ["PlanError", "PlannedLine", "plan_program"]

_ASCII_BLANKS = " \t\r\n"
MAX_LINE_S = 3600.0
"""Machine time one line may take before the planner gives up on it (s). The SGF itself
refuses a dwell or a move longer than this (``gcode.MAX_DWELL_MS``, ``sgf.MAX_MOVE_S``, error
63), so this bounds only what has no such limit of its own."""


class PlanError(TransplanterError, ValueError):
    """A line the SGF refused; `line_no` is its 1-based line number in the file."""

    def __init__(self, line_no: int, message: str):
        super().__init__(message)
        self.line_no = line_no


@dataclass(frozen=True)
class PlannedLine:
    line_no: int
    text: str
    duration_s: float
    steps: np.ndarray  # net pulses per motor (arm 1, arm 2, Z)
    replies: tuple[str, ...]


def plan_program(machine: Machine, lines: str | Iterable[str]) -> list[PlannedLine]:
    """Run every line through a fresh SGF; PlanError at the first refused line.

    ``lines``: the program's text (split with ``gcode.split_program_lines``: at newlines only)
    or its lines.
    """
    if isinstance(lines, str):
        lines = split_program_lines(lines)
    config = machine.sgf
    link = DirectLink(SGF(config), SimulatedEndstops(config, power_on_joints(config)))
    rows: list[PlannedLine] = []
    for line_no, raw in enumerate(lines, start=1):
        text = raw.strip(_ASCII_BLANKS)  # a Unicode space is not a blank: the SGF refuses it
        try:
            if parse_line(text) is None:
                continue
        except GcodeError as exc:
            raise PlanError(line_no, exc.reply) from None
        t0, pulses0 = link.t, link.pulses
        try:
            replies = link.send(text, until_s=t0 + MAX_LINE_S)
        except NoAnswer:
            raise PlanError(
                line_no, f"{text!r} did not finish within an hour of machine time"
            ) from None
        if replies[-1].startswith("error"):
            raise PlanError(line_no, replies[-1])
        steps = link.pulses - pulses0
        rows.append(PlannedLine(line_no, text, link.t - t0, steps, tuple(replies[:-1])))
    return rows
