"""The package's errors: one root, the typed refusals of a point, and every firmware code.

:class:`TransplanterError` is the root of every exception the package raises on purpose (a
scenario, a file, a move, a G-code line, a sweep refused; a simulation that went invalid), so a
caller catches "any refusal" with one ``except``. A point the kinematics refuse carries
:class:`Refusal` records (a :class:`RefusalReason` with the joint or quantity, its value and
its bounds), formatted in one place for the command line and the JSON (:meth:`Refusal.text`,
:meth:`Refusal.as_dict`) and the 20-column LCD (:meth:`Refusal.short`): nothing reads a
message back.

Every error code the firmware replies with is named once (like grbl's report.h).

A refused line is answered ``error:<code> <message>``. Codes 1-38 are grbl's numbers with
grbl's meanings; 60 and up are this firmware's own, for the Marlin-style line framing
(``N<n> ... *<checksum>``) and value ranges grbl has no code for.

| code | name | meaning |
| --- | --- | --- |
| 1 | EXPECTED_COMMAND_LETTER | a character that cannot start a word, or no G/M command |
| 2 | BAD_NUMBER_FORMAT | a letter with no number, ``1.2.3``, a non-finite value |
| 4 | NEGATIVE_VALUE | negative value where only a positive one makes sense (F, S, G4 P) |
| 9 | SYSTEM_LOCKED | motion refused while the position is unknown (grbl's alarm lock) |
| 11 | LINE_OVERFLOW | more than 80 characters of payload, or a line over 256 characters |
| 20 | UNSUPPORTED_COMMAND | a G or M command this firmware does not know |
| 21 | MODAL_GROUP_VIOLATION | more than one command on the line |
| 22 | UNDEFINED_FEED_RATE | F or S is zero |
| 23 | VALUE_NOT_INTEGER | an integer was required (line number, servo index) |
| 25 | WORD_REPEATED | a word is repeated |
| 26 | NO_AXIS_WORDS | G0/G1 without any axis word |
| 27 | INVALID_LINE_NUMBER | line number out of range |
| 28 | VALUE_WORD_MISSING | a required word is missing (G4 P, M280 P and S) |
| 33 | INVALID_TARGET | invalid motion target (unreachable, Z out of range) |
| 36 | UNUSED_WORDS | a word the command does not use (or both F and S on one move) |
| 60 | BAD_CHECKSUM | checksum mismatch, or not an integer 0-255 |
| 61 | LINE_OUT_OF_SEQUENCE | line number is not the one expected |
| 62 | CHECKSUM_MISSING | line number given (or framing required) without a checksum |
| 63 | VALUE_OUT_OF_RANGE | servo index not 0/1, servo angle not 0-180 deg, dwell or move > 1 h |
| 64 | UNTERMINATED_COMMENT | a ``(`` comment is never closed |
| 65 | CHECKSUM_WITHOUT_LINE_NUMBER | ``*<checksum>`` on a line with no ``N<n>`` |
| 66 | RX_BUFFER_OVERFLOW | command queue and receive buffer full: the line was dropped |
| 67 | MOTOR_STALLED | a driver reported a stall: motion stopped, queue flushed, home with G28 |
| 68 | HOMING_SWITCH_STUCK | homing failed: a switch still closed after the pull-off (ALARM:8) |
| 69 | HOMING_SWITCH_NOT_FOUND | homing failed: a limit switch never closed (grbl's ALARM:9) |
| 70 | LIMIT_SWITCH_CLOSED | a move towards a limit switch that reads closed (a hard limit) |
| 71 | EMERGENCY_STOP | M112: motors stopped, queue flushed; motion refused until G28 |
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum, StrEnum

from transplanter.units import show, show_outside

__all__ = ["ErrorCode", "Refusal", "RefusalReason", "TransplanterError"]


class TransplanterError(Exception):
    """Root of every error the package raises on purpose: catch it to catch any refusal."""


class RefusalReason(StrEnum):
    """Why a kinematics refuses a point (the value of ``Refusal.reason`` in JSON)."""

    NOT_FINITE = "not_finite"
    """A coordinate is NaN or infinite."""
    OUT_OF_WORKSPACE = "out_of_workspace"
    """No joint values reach the point (a chain cannot close)."""
    JOINT_LIMIT = "joint_limit"
    """An axis would leave its window (a motor angle, a slide's travel)."""
    SERIAL_SINGULARITY = "serial_singularity"
    """A link pair too folded or too stretched: the workspace boundary."""
    PARALLEL_SINGULARITY = "parallel_singularity"
    """The closed chain near a pose where it loses stiffness (uncontrollable)."""
    ILL_CONDITIONED = "ill_conditioned"
    """The Jacobian's condition number above its limit."""
    AXIS_RANGE = "axis_range"
    """A Cartesian coordinate outside the machine's range (Z below or above its travel)."""


@dataclass(frozen=True)
class Refusal:
    """One reason a point is refused, with its numbers: what (``subject``), its ``value`` and
    the bounds it crossed, in ``unit``. ``bound_names`` names the bounds where they are
    quantities (``L1+L2``) rather than settings."""

    reason: RefusalReason
    subject: str
    value: float = math.nan
    low: float | None = None
    high: float | None = None
    unit: str = ""
    note: str = ""
    bound_names: tuple[str, str] = ("", "")
    label: str = ""
    """A short name for the 20-column LCD ("motor1", "elbow B"); default: the subject."""

    def text(self) -> str:
        """The refusal as the command line, the firmware's error reply and the JSON show it."""
        reason, unit = self.reason, self.unit
        if reason is RefusalReason.NOT_FINITE:
            return f"outside workspace: {self.subject} are not finite"
        if reason is RefusalReason.OUT_OF_WORKSPACE:
            if self.high is not None and self.value > self.high:
                return (
                    f"outside workspace: {self.subject}={show(self.value, 1)} {unit} > "
                    f"{self.bound_names[1]}={self.high:.1f} {unit}"
                )
            return (
                f"outside workspace: {self.subject}={self.value:.1f} {unit} < "
                f"{self.bound_names[0]}={self.low:.1f} {unit}"
            )
        if reason is RefusalReason.ILL_CONDITIONED:
            return f"{self.subject} {self.value:.3g} > {self.high:g}"
        if reason is RefusalReason.AXIS_RANGE:
            # enough digits that the value visibly lies outside (4.9999999, not 5.000)
            value, low, high = show_outside(self.value, self.low, self.high, decimals=3)
            return f"{self.subject} {value} {unit} outside [{low}, {high}] {unit}"
        value, low, high = show_outside(self.value, self.low, self.high)
        note = f" ({self.note})" if self.note else ""
        return f"{self.subject} {value} {unit} outside [{low}, {high}] {unit}{note}"

    def short(self, width: int = 17) -> str:
        """The most telling form that fits ``width`` characters (a line of the teach
        pendant's LCD less its 'NO '): 'motor1 79.97<80', else 'motor1 limit', else the name;
        'Z 170 > 160' for a coordinate's range; a word or two for reach and singularity."""
        reason = self.reason
        if reason in (RefusalReason.NOT_FINITE, RefusalReason.OUT_OF_WORKSPACE):
            forms = ["out of reach", "no reach"]
        elif reason is RefusalReason.ILL_CONDITIONED:
            forms = ["near singularity", "singular"]
        else:
            name = self.label or self.subject
            if reason is RefusalReason.AXIS_RANGE:
                above = self.value > self.high
                bound = self.high if above else self.low
                forms = [f"{name} {self.value:g} {'>' if above else '<'} {bound:g}"]
            else:
                value, low, high = show_outside(self.value, self.low, self.high)
                bound = f"<{low}" if self.value < self.low else f">{high}"
                forms = [f"{name} {value}{bound}", f"{name}{value}{bound}"]
            forms += [f"{name} limit", name]
        return next((form for form in forms if len(form) <= width), forms[-1][:width])

    def as_dict(self) -> dict:
        """The refusal for JSON: reason, subject, value and bounds (None where not set)."""
        finite = math.isfinite(self.value)
        return {
            "reason": str(self.reason),
            "subject": self.subject,
            "value": self.value if finite else None,
            "low": self.low,
            "high": self.high,
            "unit": self.unit,
            "text": self.text(),
        }


def refusal_text(refusals) -> str:
    """Several refusals of one point as one line (``; ``-joined)."""
    return "; ".join(r.text() for r in refusals)


class ErrorCode(IntEnum):
    """The number after ``error:`` in a reply; an int, so ``f"error:{code}"`` shows it."""

    EXPECTED_COMMAND_LETTER = 1
    BAD_NUMBER_FORMAT = 2
    NEGATIVE_VALUE = 4
    SYSTEM_LOCKED = 9
    LINE_OVERFLOW = 11
    UNSUPPORTED_COMMAND = 20
    MODAL_GROUP_VIOLATION = 21
    UNDEFINED_FEED_RATE = 22
    VALUE_NOT_INTEGER = 23
    WORD_REPEATED = 25
    NO_AXIS_WORDS = 26
    INVALID_LINE_NUMBER = 27
    VALUE_WORD_MISSING = 28
    INVALID_TARGET = 33
    UNUSED_WORDS = 36
    BAD_CHECKSUM = 60
    LINE_OUT_OF_SEQUENCE = 61
    CHECKSUM_MISSING = 62
    VALUE_OUT_OF_RANGE = 63
    UNTERMINATED_COMMENT = 64
    CHECKSUM_WITHOUT_LINE_NUMBER = 65
    RX_BUFFER_OVERFLOW = 66
    MOTOR_STALLED = 67
    HOMING_SWITCH_STUCK = 68
    HOMING_SWITCH_NOT_FOUND = 69
    LIMIT_SWITCH_CLOSED = 70
    EMERGENCY_STOP = 71

    def reply(self, message: str) -> str:
        """The firmware's answer for this code: ``error:<code> <message>``."""
        return f"error:{int(self)} {message}"

    @classmethod
    def of_reply(cls, reply: str) -> ErrorCode | None:
        """The code of an ``error:<code> ...`` reply; None for any other line or code."""
        head, _, number = reply.partition(" ")[0].partition(":")
        if head != "error" or not (number.isascii() and number.isdigit()):
            return None
        try:
            return cls(int(number))
        except ValueError:
            return None
