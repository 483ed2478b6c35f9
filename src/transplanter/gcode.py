"""G-code parsing and formatting for the twin's dialect (docs/architecture.md).

One line holds one command: ``G0``/``G1``, ``G4``, ``G28``, ``G90``, ``G91``, ``M280``,
``M400``, ``M114``, ``M119``, ``M105`` or ``M710``, with value words from X Y Z F S P.
Comments (``; ...`` to the end of the line, ``( ... )`` inline) are dropped. Marlin framing
``N<n> <command> *<checksum>`` is optional; the checksum is the XOR of every byte before
``*`` as sent, ``( ... )`` comments included (after a ``;`` comment has been cut off). A
``*`` or ``;`` inside ``( ... )`` is comment text, not framing.

Errors carry grbl's numbers where grbl has one, and numbers from 60 up for the rest:

| code | meaning |
| --- | --- |
| 1 | expected a command letter: a character that cannot start a word, or no G/M command |
| 2 | bad number format: a letter with no number, ``1.2.3``, a non-finite value |
| 4 | negative value where only a positive one makes sense (F, S, G4 P) |
| 11 | line overflow: more than 80 characters of payload |
| 20 | unsupported command |
| 21 | more than one command on the line |
| 22 | undefined feed rate: F or S is zero |
| 23 | an integer was required (line number, servo index) |
| 25 | a word is repeated |
| 26 | G0/G1 without any axis word |
| 27 | line number out of range (negative) |
| 28 | a required word is missing (G4 P, M280 P and S) |
| 33 | invalid motion target (given by the SGF: unreachable, Z out of range) |
| 36 | a word the command does not use (or both F and S on one move) |
| 60 | bad checksum (mismatch, or not an integer 0-255) |
| 61 | line number out of sequence |
| 62 | checksum missing (line number given, or framing required) |
| 63 | value out of range (servo index not 0/1, servo angle not 0-180 deg) |
| 64 | unterminated ``(`` comment |
| 65 | checksum without a line number |

The payload that error 11 counts is what remains after comments, whitespace and the
Marlin framing are removed (grbl counts its line buffer the same way).
"""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass, field

MAX_PAYLOAD_CHARS = 80
"""grbl's LINE_BUFFER_SIZE: the longest payload a line may carry."""

MAX_LINE_NUMBER = 2**31 - 1
"""Largest N a line may carry (Marlin keeps it in a 32-bit long)."""

WORD_LETTERS = "XYZFSP"
AXIS_LETTERS = "XYZ"

# Allowed words and required words for every supported command.
_ALLOWED_WORDS: dict[str, str] = {
    "G0": "XYZFS",
    "G1": "XYZFS",
    "G4": "P",
    "G28": "",
    "G90": "",
    "G91": "",
    "M280": "PS",
    "M400": "",
    "M114": "",
    "M119": "",
    "M105": "",
    "M710": "",
}
_REQUIRED_WORDS: dict[str, str] = {"G4": "P", "M280": "PS"}

SERVO_INDICES = (0, 1)
SERVO_MAX_DEG = 180.0

_NUMBER_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)")
_DIGITS_RE = re.compile(r"\d+")


class GcodeError(ValueError):
    """A line the firmware refuses; ``code`` is the grbl-style error number."""

    def __init__(self, code: int, message: str):
        super().__init__(f"error {code}: {message}")
        self.code = code
        self.message = message

    @property
    def reply(self) -> str:
        """The line the firmware answers: ``error:<code> <message>``."""
        return f"error:{self.code} {self.message}"


@dataclass(frozen=True)
class GcodeLine:
    """One parsed line: ``command`` like ``G1`` or ``M280``, ``words`` like ``{"X": 10.0}``."""

    command: str
    words: dict[str, float] = field(default_factory=dict)
    line_number: int | None = None
    raw: str = ""


def checksum(payload: str) -> int:
    """Marlin's checksum: XOR of every byte of ``payload`` (UTF-8 encoded)."""
    value = 0
    for byte in payload.encode("utf-8", "surrogatepass"):
        value ^= byte
    return value


def _is_ascii_letter(char: str) -> bool:
    return ("A" <= char <= "Z") or ("a" <= char <= "z")


def _describe(char: str) -> str:
    return repr(char) if char.isprintable() else f"U+{ord(char):04X}"


def _cut_comment_find_star(line: str) -> tuple[str, int]:
    """Cut a ``;`` comment off; return (line, index of the framing ``*`` or -1).

    ``;`` and ``*`` inside a ``( ... )`` comment are comment text; an unclosed ``(`` is left
    for ``_strip_paren_comments`` to refuse.
    """
    star = -1
    in_paren = False
    for index, char in enumerate(line):
        if in_paren:
            in_paren = char != ")"
        elif char == ";":
            return line[:index], star
        elif star < 0 and char == "(":
            in_paren = True
        elif star < 0 and char == "*":
            star = index
    return line, star


def _split_framing(text: str, star: int) -> tuple[str, int | None, int | None, str]:
    """Split ``N<n> body *<cs>`` at ``star`` (-1: none).

    Returns (body, line_number, checksum, checksummed_text).
    """
    checksummed = text
    found_checksum: int | None = None
    if star >= 0:
        checksummed = text[:star]
        digits = text[star + 1 :].strip()
        if not _DIGITS_RE.fullmatch(digits) or len(digits) > 3 or int(digits) > 255:
            raise GcodeError(
                60, f"checksum {digits!r} after '*' is not an integer 0-255; resend the line"
            )
        found_checksum = int(digits)
    body = checksummed.lstrip()
    line_number = None
    if body[:1] in ("N", "n"):
        end = 1
        while end < len(body) and not (body[end].isspace() or _is_ascii_letter(body[end])):
            if body[end] == "(" or body[end] == ";":
                break
            end += 1
        token = body[1:end]
        if not _NUMBER_RE.fullmatch(token):
            raise GcodeError(2, f"line number 'N{token}' is not a number; send N<integer>")
        if not _DIGITS_RE.fullmatch(token.lstrip("+")):
            if token.startswith("-") and _DIGITS_RE.fullmatch(token[1:]):
                raise GcodeError(27, f"line number N{token} is negative; number lines from N1")
            raise GcodeError(23, f"line number N{token} is not an integer; send N<integer>")
        if (
            len(token.lstrip("+").lstrip("0")) > len(str(MAX_LINE_NUMBER))
            or int(token) > MAX_LINE_NUMBER
        ):
            raise GcodeError(27, f"line number N{token} is above {MAX_LINE_NUMBER}")
        line_number = int(token)
        body = body[end:]
    if line_number is not None and found_checksum is None:
        raise GcodeError(62, f"line N{line_number} has no '*<checksum>'; append the checksum")
    if line_number is None and found_checksum is not None:
        raise GcodeError(65, "checksum given without a line number; start the line with N<n>")
    return body, line_number, found_checksum, checksummed


def _strip_paren_comments(body: str) -> str:
    out = []
    in_comment = False
    for char in body:
        if in_comment:
            in_comment = char != ")"
        elif char == "(":
            in_comment = True
        elif char == ")":
            raise GcodeError(1, "unexpected ')' without an opening '('; remove it")
        else:
            out.append(char)
    if in_comment:
        raise GcodeError(64, "comment '(' is never closed; add ')' or remove the comment")
    return "".join(out)


def _tokenise(body: str) -> list[tuple[str, str]]:
    """Split a comment-free body into (LETTER, number text) words."""
    words = []
    index = 0
    while index < len(body):
        char = body[index]
        if char.isspace():
            index += 1
            continue
        if not _is_ascii_letter(char):
            raise GcodeError(
                1, f"expected a command letter, found {_describe(char)}; remove the character"
            )
        end = index + 1
        while end < len(body) and not (body[end].isspace() or _is_ascii_letter(body[end])):
            end += 1
        words.append((char.upper(), body[index + 1 : end]))
        index = end
    return words


def _number(letter: str, token: str) -> float:
    if not _NUMBER_RE.fullmatch(token):
        shown = token if token else "nothing"
        raise GcodeError(
            2, f"word {letter} is followed by {shown!s}, not a number; write e.g. {letter}10.5"
        )
    value = float(token)
    if not math.isfinite(value):
        raise GcodeError(2, f"word {letter}{token} is not a finite number")
    return value


def _command_name(letter: str, token: str) -> str:
    value = _number(letter, token)
    if value != int(value) or value < 0:
        raise GcodeError(20, f"unsupported command {letter}{token}; see the G-code dialect table")
    name = f"{letter}{int(value)}"
    if name not in _ALLOWED_WORDS:
        supported = " ".join(_ALLOWED_WORDS)
        raise GcodeError(20, f"unsupported command {name}; supported: {supported}")
    return name


def _check_words(command: str, words: dict[str, float]) -> None:
    for letter in _REQUIRED_WORDS.get(command, ""):
        if letter not in words:
            raise GcodeError(28, f"{command} needs a {letter} word")
    if command in ("G0", "G1"):
        if not any(letter in words for letter in AXIS_LETTERS):
            raise GcodeError(26, f"{command} needs at least one of X, Y, Z")
        if "F" in words and "S" in words:
            raise GcodeError(36, f"{command} takes F (mm/min) or S (mm/s), not both; drop one")
        for letter in "FS":
            if letter in words:
                if words[letter] < 0:
                    raise GcodeError(4, f"{letter}{words[letter]:g} is negative; speeds are > 0")
                if words[letter] == 0:
                    raise GcodeError(22, f"{letter}0 is an undefined feed rate; give a speed > 0")
    elif command == "G4":
        if words["P"] < 0:
            raise GcodeError(4, f"G4 P{words['P']:g} is negative; dwell milliseconds are >= 0")
    elif command == "M280":
        index = words["P"]
        if index != int(index):
            raise GcodeError(23, f"M280 P{index:g}: the servo index must be an integer")
        if int(index) not in SERVO_INDICES:
            raise GcodeError(63, f"M280 P{index:g}: servo index must be 0 (gripper) or 1 (wrist)")
        angle = words["S"]
        if not 0.0 <= angle <= SERVO_MAX_DEG:
            raise GcodeError(63, f"M280 S{angle:g}: servo angle must be within 0-180 degrees")


def parse_line(
    text: str, expected_line_number: int | None = None, require_checksum: bool = False
) -> GcodeLine | None:
    """Parse one line; ``None`` for a blank or comment-only line, ``GcodeError`` if invalid.

    ``expected_line_number``: if the line carries ``N<n>``, it must equal this.
    ``require_checksum``: refuse lines without Marlin framing.
    """
    if not isinstance(text, str):
        raise TypeError(f"parse_line needs a str, got {type(text).__name__}")
    line = text.rstrip("\r\n")
    for char in line:
        if char in "\r\n\x00":
            raise GcodeError(1, f"unexpected {_describe(char)} inside the line; send one line")
    line, star = _cut_comment_find_star(line)
    body, line_number, found_checksum, checksummed = _split_framing(line, star)
    body = _strip_paren_comments(body)
    payload_chars = sum(1 for char in body if not char.isspace())
    if payload_chars > MAX_PAYLOAD_CHARS:
        raise GcodeError(
            11, f"line has {payload_chars} characters, more than {MAX_PAYLOAD_CHARS}; shorten it"
        )
    if found_checksum is not None:
        computed = checksum(checksummed)
        if computed != found_checksum:
            raise GcodeError(
                60, f"checksum mismatch: line says {found_checksum}, computed {computed}; resend"
            )
    elif require_checksum and payload_chars > 0:
        raise GcodeError(62, "line has no N<n> ... *<checksum> framing, which is required")
    if (
        line_number is not None
        and expected_line_number is not None
        and line_number != expected_line_number
    ):
        raise GcodeError(
            61,
            f"line number N{line_number} out of sequence, expected N{expected_line_number}; "
            f"resend from N{expected_line_number}",
        )
    tokens = _tokenise(body)
    if not tokens:
        if line_number is not None:
            raise GcodeError(1, f"line N{line_number} carries no command")
        return None
    command = None
    words: dict[str, float] = {}
    for letter, token in tokens:
        if letter in "GM":
            name = _command_name(letter, token)
            if command is not None:
                raise GcodeError(21, f"{command} and {name} on one line; send one command a line")
            command = name
            continue
        if letter not in WORD_LETTERS:
            where = f"{command} " if command else ""
            raise GcodeError(36, f"word {letter} is not used by {where}this firmware; remove it")
        value = _number(letter, token)
        if letter in words:
            raise GcodeError(25, f"word {letter} appears twice; give it once")
        words[letter] = value
    if command is None:
        raise GcodeError(1, "the line has no G or M command; start it with e.g. G1")
    for letter in words:
        if letter not in _ALLOWED_WORDS[command]:
            allowed = " ".join(_ALLOWED_WORDS[command]) or "no words"
            raise GcodeError(36, f"{command} does not use word {letter} (allowed: {allowed})")
    _check_words(command, words)
    return GcodeLine(command=command, words=words, line_number=line_number, raw=text)


def format_number(value: float) -> str:
    """Compact text for a word value: integers stay integers, at most 3 decimals."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"a G-code word value must be a number, got {value!r}")
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if not math.isfinite(value):
        raise ValueError(f"a G-code word value must be finite, got {value!r}")
    text = f"{float(value):.3f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def format_line(
    command: str, words: dict[str, float] | None = None, line_number: int | None = None
) -> str:
    """Build one line, e.g. ``format_line("G1", {"X": 10, "Y": 5.25})`` -> ``G1 X10 Y5.25``.

    With ``line_number`` the line gets Marlin framing ``N<n> ... *<checksum>``. The result
    is parsed back, so a line this function returns is one the SGF accepts (else GcodeError).
    """
    parts = [command.upper()]
    for letter, value in (words or {}).items():
        parts.append(f"{letter.upper()}{format_number(value)}")
    text = " ".join(parts)
    if line_number is not None:
        if (
            isinstance(line_number, bool)
            or not isinstance(line_number, numbers.Integral)
            or not 0 <= line_number <= MAX_LINE_NUMBER
        ):
            raise ValueError(
                f"line_number must be an int 0..{MAX_LINE_NUMBER}, got {line_number!r}"
            )
        line_number = int(line_number)
        framed = f"N{line_number} {text}"
        text = f"{framed}*{checksum(framed)}"
    parse_line(text)
    return text
