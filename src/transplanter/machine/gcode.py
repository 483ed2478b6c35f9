"""G-code parsing and formatting for the twin's dialect (docs/architecture.md).

One line holds one command: ``G0``/``G1``, ``G4``, ``G28``, ``G90``, ``G91``, ``M280``,
``M400``, ``M114``, ``M119``, ``M105``, ``M710``, ``M720`` (a via point of the next ``G0``
spline transfer, ``motion.planner = "bspline5"`` on the five-bar) or ``M112`` (emergency
stop: the SGF acts on it when it arrives, :func:`is_emergency_stop`), with value words from
X Y Z F S P.
Comments (``; ...`` to the end of the line, ``( ... )`` inline) are dropped. Marlin framing
``N<n> <command> *<checksum>`` is optional; the checksum is the XOR of every byte before
``*`` as sent, ``( ... )`` comments included (after a ``;`` comment has been cut off). A
``*`` or ``;`` inside ``( ... )`` is comment text, not framing.

The dialect is ASCII: a non-ASCII character anywhere in a line is refused (error 2 inside a
number word, error 1 elsewhere), so ``X\u0661\u0660`` (Arabic-Indic digits) or a no-break
space never pass for ``X10`` or a blank. A program splits into lines at ``\n`` (and
``\r\n``) only: :func:`split_program_lines`.

Errors carry grbl's numbers where grbl has one, and numbers from 60 up for the rest; every
code is named once in :class:`transplanter.errors.ErrorCode` (table there).

The payload that error 11 counts is what remains after comments, whitespace and the
Marlin framing are removed (grbl counts its line buffer the same way); a whole line over
``MAX_LINE_CHARS`` (256) is refused with error 11 before anything else. Numbers are
plain decimals: exponent notation (``X1e3``) is refused with error 2, naming it.
``format_number`` never rounds a value to another number (3 decimals when they hold it,
else the exact decimal), so every line ``parse_line`` accepts formats back to an
equivalent line (tests/test_gcode_properties.py).
"""

from __future__ import annotations

import decimal
import math
import numbers
import re
import unicodedata
from dataclasses import dataclass, field

from transplanter.errors import ErrorCode, TransplanterError

MAX_PAYLOAD_CHARS = 80
"""grbl's LINE_BUFFER_SIZE: the longest payload a line may carry."""

MAX_LINE_CHARS = 256
"""Longest line the serial reader holds, comments and framing included (Marlin's
MAX_CMD_SIZE, raised to take this dialect's comments): a longer line is refused whole
with error 11 before anything else is looked at."""

MAX_DWELL_MS = 3_600_000
"""Longest dwell ``G4 P`` may ask for (ms): one hour, the machine time ``transplanter plan``
gives any line (``planner.MAX_LINE_S``). A longer one is refused with error 63 naming P and
this bound. Marlin keeps P in a 32-bit millisecond counter (``millis_t``, at most
4294967295 ms, 49.7 days) and grbl takes any float; a transplanting cycle's dwells are
milliseconds, and a twin behind ``serve`` would simulate a 1e12 ms dwell for 31 years."""

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
    "M720": "XYZ",
    "M112": "",
}
_REQUIRED_WORDS: dict[str, str] = {"G4": "P", "M280": "PS"}

SERVO_INDICES = (0, 1)
SERVO_MAX_DEG = 180.0
"""Largest hobby-servo angle M280 S accepts (and the EEPROM stores), in degrees."""

# Marlin's EMERGENCY_PARSER: blanks, an optional N<n>, then the word M112 ends the scan
_EMERGENCY_STOP_RE = re.compile(r"[ \t]*(?:[Nn][ \t]*[-+]?[0-9]+[ \t]*)?[Mm]0*112(?![0-9])")

# ASCII only: Python's \d and float() also take other scripts' digits.
_NUMBER_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)")
_DIGITS_RE = re.compile(r"[0-9]+")


class GcodeError(TransplanterError, ValueError):
    """A line the firmware refuses; ``code`` is the grbl-style error number."""

    def __init__(self, code: ErrorCode | int, message: str):
        code = ErrorCode(code)
        super().__init__(f"error {int(code)}: {message}")
        self.code = code
        """An :class:`ErrorCode` (an int)."""
        self.message = message
        self.line_number: int | None = None
        """The line's ``N<n>`` when its framing passed (checksum good, in sequence) and only
        its command was refused: the firmware counts the line as received, like Marlin."""

    @property
    def reply(self) -> str:
        """The line the firmware answers: ``error:<code> <message>``."""
        return self.code.reply(self.message)


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


def _word_end(text: str, index: int) -> int:
    """End of the word whose letter (or number character) is at ``index``: the next white
    space or letter."""
    end = index + 1
    while end < len(text) and not (text[end].isspace() or _is_ascii_letter(text[end])):
        end += 1
    return end


def is_emergency_stop(text: str) -> bool:
    """Whether a received line is an emergency stop, read as Marlin's EMERGENCY_PARSER reads
    the serial bytes before they reach any queue (feature/emergency_parser.h): blanks, an
    optional line number, then the command word ``M112`` (``m112``, ``M0112``; not ``M1120``).
    Whatever follows (a checksum, good or bad, a comment) does not matter: a stop is never
    delayed by a framing error. A line with anything else first (``G1 ... ; M112``,
    ``(note) M112``) is not one; the SGF still runs ``(note) M112`` as a stop in its turn."""
    return _EMERGENCY_STOP_RE.match(text) is not None


def valid_servo_angle(angle_deg: float) -> bool:
    """True for a finite servo angle within 0..SERVO_MAX_DEG (what M280 S accepts)."""
    return math.isfinite(angle_deg) and 0.0 <= angle_deg <= SERVO_MAX_DEG


def _describe(char: str) -> str:
    return repr(char) if char.isprintable() else f"U+{ord(char):04X}"


def _unicode(char: str) -> str:
    """``U+0661 (ARABIC-INDIC DIGIT ONE)``: a character's code point and name."""
    name = unicodedata.name(char, "")
    return f"U+{ord(char):04X}" + (f" ({name})" if name else "")


def _refuse_non_ascii(line: str) -> None:
    """GcodeError for the first non-ASCII character: BAD_NUMBER_FORMAT inside a number
    (after a word letter or the checksum's ``*``), EXPECTED_COMMAND_LETTER anywhere else
    (between words, in a comment, a Unicode space such as U+00A0 or U+3000)."""
    if line.isascii():
        return
    word_start = None  # index of the letter (or '*') whose number is being read
    in_paren = False
    for index, char in enumerate(line):
        if char.isascii():
            if in_paren:
                in_paren = char != ")"
            elif char == ";":
                break
            elif char == "(":
                in_paren, word_start = True, None
            elif _is_ascii_letter(char) or char == "*":
                word_start = index
            elif char.isspace():
                word_start = None
            continue
        shown = _unicode(char)
        if word_start is None or in_paren or char.isspace():
            raise GcodeError(
                ErrorCode.EXPECTED_COMMAND_LETTER,
                f"non-ASCII character {shown}; G-code is ASCII, remove the character",
            )
        word = line[word_start : _word_end(line, index)]
        word = f"'{word}'" if word.isprintable() else ascii(word)
        raise GcodeError(
            ErrorCode.BAD_NUMBER_FORMAT,
            f"non-ASCII character {shown} in {word}; G-code is ASCII, write digits 0-9",
        )
    char = next(char for char in line if not char.isascii())  # in a ';' comment
    raise GcodeError(
        ErrorCode.EXPECTED_COMMAND_LETTER,
        f"non-ASCII character {_unicode(char)} in a comment; G-code is ASCII",
    )


def split_program_lines(text: str) -> list[str]:
    """The lines of a G-code program: split at ``\\n`` (and ``\\r\\n``) only.

    Unlike ``str.splitlines`` a form feed, U+2028 or U+0085 does not end a line: it stays in
    it, for ``parse_line`` to refuse. A final newline ends the last line (no empty line after).
    """
    if not isinstance(text, str):
        raise TypeError(f"split_program_lines needs a str, got {type(text).__name__}")
    lines = text.split("\n")
    if lines[-1] == "":
        lines.pop()
    return [line[:-1] if line.endswith("\r") else line for line in lines]


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
                ErrorCode.BAD_CHECKSUM,
                f"checksum {digits!r} after '*' is not an integer 0-255; resend the line",
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
            raise GcodeError(
                ErrorCode.BAD_NUMBER_FORMAT,
                f"line number 'N{token}' is not a number; send N<integer>",
            )
        if not _DIGITS_RE.fullmatch(token.lstrip("+")):
            if token.startswith("-") and _DIGITS_RE.fullmatch(token[1:]):
                raise GcodeError(
                    ErrorCode.INVALID_LINE_NUMBER,
                    f"line number N{token} is negative; number lines from N1",
                )
            raise GcodeError(
                ErrorCode.VALUE_NOT_INTEGER,
                f"line number N{token} is not an integer; send N<integer>",
            )
        if (
            len(token.lstrip("+").lstrip("0")) > len(str(MAX_LINE_NUMBER))
            or int(token) > MAX_LINE_NUMBER
        ):
            raise GcodeError(
                ErrorCode.INVALID_LINE_NUMBER, f"line number N{token} is above {MAX_LINE_NUMBER}"
            )
        line_number = int(token)
        body = body[end:]
    if line_number is not None and found_checksum is None:
        raise GcodeError(
            ErrorCode.CHECKSUM_MISSING,
            f"line N{line_number} has no '*<checksum>'; append the checksum",
        )
    if line_number is None and found_checksum is not None:
        raise GcodeError(
            ErrorCode.CHECKSUM_WITHOUT_LINE_NUMBER,
            "checksum given without a line number; start the line with N<n>",
        )
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
            raise GcodeError(
                ErrorCode.EXPECTED_COMMAND_LETTER,
                "unexpected ')' without an opening '('; remove it",
            )
        else:
            out.append(char)
    if in_comment:
        raise GcodeError(
            ErrorCode.UNTERMINATED_COMMENT,
            "comment '(' is never closed; add ')' or remove the comment",
        )
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
                ErrorCode.EXPECTED_COMMAND_LETTER,
                f"expected a command letter, found {_describe(char)}; remove the character",
            )
        if char in "eE" and words and index > 0 and body[index - 1] in "0123456789.":
            _refuse_exponent(body, words[-1], index)
        end = _word_end(body, index)
        words.append((char.upper(), body[index + 1 : end]))
        index = end
    return words


def _refuse_exponent(body: str, previous: tuple[str, str], index: int) -> None:
    """BAD_NUMBER_FORMAT for ``X1e3``: an exponent glued to the previous word's number."""
    letter, mantissa = previous
    end = _word_end(body, index)
    exponent = body[index + 1 : end]
    shown = f"{letter}{mantissa}{body[index]}{exponent}"
    hint = ""
    if _NUMBER_RE.fullmatch(mantissa) and _DIGITS_RE.fullmatch(exponent.lstrip("+-")):
        try:
            value = float(f"{mantissa}e{exponent}")
        except (ValueError, OverflowError):
            value = math.inf
        if math.isfinite(value):
            written = _exact_text(value)
            if len(written) <= 20:
                hint = f"; write {written}"
    raise GcodeError(
        ErrorCode.BAD_NUMBER_FORMAT,
        f"{shown}: exponent notation is not G-code{hint or '; write the number in full'}",
    )


def _number(letter: str, token: str) -> float:
    if not _NUMBER_RE.fullmatch(token):
        shown = token if token else "nothing"
        raise GcodeError(
            ErrorCode.BAD_NUMBER_FORMAT,
            f"word {letter} is followed by {shown!s}, not a number; write e.g. {letter}10.5",
        )
    value = float(token)
    if not math.isfinite(value):
        raise GcodeError(
            ErrorCode.BAD_NUMBER_FORMAT, f"word {letter}{token} is not a finite number"
        )
    return value


def _command_name(letter: str, token: str) -> str:
    value = _number(letter, token)
    if value != int(value) or value < 0:
        raise GcodeError(
            ErrorCode.UNSUPPORTED_COMMAND,
            f"unsupported command {letter}{token}; see the G-code dialect table",
        )
    name = f"{letter}{int(value)}"
    if name not in _ALLOWED_WORDS:
        supported = " ".join(_ALLOWED_WORDS)
        raise GcodeError(
            ErrorCode.UNSUPPORTED_COMMAND, f"unsupported command {name}; supported: {supported}"
        )
    return name


def _check_words(command: str, words: dict[str, float]) -> None:
    for letter in _REQUIRED_WORDS.get(command, ""):
        if letter not in words:
            raise GcodeError(ErrorCode.VALUE_WORD_MISSING, f"{command} needs a {letter} word")
    if command == "M720" and not any(letter in words for letter in AXIS_LETTERS):
        raise GcodeError(ErrorCode.NO_AXIS_WORDS, "M720 needs at least one of X, Y, Z")
    if command in ("G0", "G1"):
        if not any(letter in words for letter in AXIS_LETTERS):
            raise GcodeError(ErrorCode.NO_AXIS_WORDS, f"{command} needs at least one of X, Y, Z")
        if "F" in words and "S" in words:
            raise GcodeError(
                ErrorCode.UNUSED_WORDS,
                f"{command} takes F (mm/min) or S (mm/s), not both; drop one",
            )
        for letter in "FS":
            if letter in words:
                if words[letter] < 0:
                    raise GcodeError(
                        ErrorCode.NEGATIVE_VALUE,
                        f"{letter}{words[letter]:g} is negative; speeds are > 0",
                    )
                if words[letter] == 0:
                    raise GcodeError(
                        ErrorCode.UNDEFINED_FEED_RATE,
                        f"{letter}0 is an undefined feed rate; give a speed > 0",
                    )
    elif command == "G4":
        if words["P"] < 0:
            raise GcodeError(
                ErrorCode.NEGATIVE_VALUE,
                f"G4 P{words['P']:g} is negative; dwell milliseconds are >= 0",
            )
        if words["P"] > MAX_DWELL_MS:
            shown = format_number(words["P"])
            raise GcodeError(
                ErrorCode.VALUE_OUT_OF_RANGE,
                f"G4 P{shown}: a dwell of {shown} ms is longer than the {MAX_DWELL_MS} ms (1 h) "
                f"a dwell may take; split it into G4 lines of at most P{MAX_DWELL_MS}",
            )
    elif command == "M280":
        index = words["P"]
        if index != int(index):
            raise GcodeError(
                ErrorCode.VALUE_NOT_INTEGER, f"M280 P{index:g}: the servo index must be an integer"
            )
        if int(index) not in SERVO_INDICES:
            raise GcodeError(
                ErrorCode.VALUE_OUT_OF_RANGE,
                f"M280 P{index:g}: servo index must be 0 (gripper) or 1 (wrist)",
            )
        angle = words["S"]
        if not valid_servo_angle(angle):
            raise GcodeError(
                ErrorCode.VALUE_OUT_OF_RANGE,
                f"M280 S{angle:g}: servo angle must be within 0-{SERVO_MAX_DEG:g} degrees",
            )


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
    if len(line) > MAX_LINE_CHARS:
        raise GcodeError(
            ErrorCode.LINE_OVERFLOW,
            f"line of {len(line)} characters overflows the {MAX_LINE_CHARS}-character line "
            "buffer; shorten it",
        )
    for char in line:
        if char in "\r\n\x00":
            raise GcodeError(
                ErrorCode.EXPECTED_COMMAND_LETTER,
                f"unexpected {_describe(char)} inside the line; send one line",
            )
    _refuse_non_ascii(line)
    line, star = _cut_comment_find_star(line)
    body, line_number, found_checksum, checksummed = _split_framing(line, star)
    body = _strip_paren_comments(body)
    payload_chars = sum(1 for char in body if not char.isspace())
    if payload_chars > MAX_PAYLOAD_CHARS:
        raise GcodeError(
            ErrorCode.LINE_OVERFLOW,
            f"line has {payload_chars} characters, more than {MAX_PAYLOAD_CHARS}; shorten it",
        )
    if found_checksum is not None:
        computed = checksum(checksummed)
        if computed != found_checksum:
            raise GcodeError(
                ErrorCode.BAD_CHECKSUM,
                f"checksum mismatch: line says {found_checksum}, computed {computed}; resend",
            )
    elif require_checksum and payload_chars > 0:
        raise GcodeError(
            ErrorCode.CHECKSUM_MISSING,
            "line has no N<n> ... *<checksum> framing, which is required",
        )
    if (
        line_number is not None
        and expected_line_number is not None
        and line_number != expected_line_number
    ):
        raise GcodeError(
            ErrorCode.LINE_OUT_OF_SEQUENCE,
            f"line number N{line_number} out of sequence, expected N{expected_line_number}; "
            f"resend from N{expected_line_number}",
        )
    try:
        return _parse_body(body, line_number, text)
    except GcodeError as error:
        error.line_number = line_number  # the framing passed: N advances whatever the command
        raise


def _parse_body(body: str, line_number: int | None, text: str) -> GcodeLine | None:
    tokens = _tokenise(body)
    if not tokens:
        if line_number is not None:
            raise GcodeError(
                ErrorCode.EXPECTED_COMMAND_LETTER, f"line N{line_number} carries no command"
            )
        return None
    command = None
    words: dict[str, float] = {}
    for letter, token in tokens:
        if letter in "GM":
            name = _command_name(letter, token)
            if command is not None:
                raise GcodeError(
                    ErrorCode.MODAL_GROUP_VIOLATION,
                    f"{command} and {name} on one line; send one command a line",
                )
            command = name
            continue
        if letter not in WORD_LETTERS:
            where = f"{command} " if command else ""
            raise GcodeError(
                ErrorCode.UNUSED_WORDS,
                f"word {letter} is not used by {where}this firmware; remove it",
            )
        value = _number(letter, token)
        if letter in words:
            raise GcodeError(ErrorCode.WORD_REPEATED, f"word {letter} appears twice; give it once")
        words[letter] = value
    if command is None:
        raise GcodeError(
            ErrorCode.EXPECTED_COMMAND_LETTER,
            "the line has no G or M command; start it with e.g. G1",
        )
    for letter in words:
        if letter not in _ALLOWED_WORDS[command]:
            allowed = " ".join(_ALLOWED_WORDS[command]) or "no words"
            raise GcodeError(
                ErrorCode.UNUSED_WORDS, f"{command} does not use word {letter} (allowed: {allowed})"
            )
    _check_words(command, words)
    return GcodeLine(command=command, words=words, line_number=line_number, raw=text)


FORMAT_DECIMALS = 3
"""Decimals ``format_number`` writes when they hold the value (1 um, 0.001 mm/s)."""
_FORMAT_TOLERANCE = 1e-9
"""Relative difference between a value and its 3-decimal text that
counts as float noise (12.299999999999999 -> 12.3)."""


def _exact_text(value: float) -> str:
    """The shortest decimal text that reads back as ``value``, without exponent."""
    text = format(decimal.Decimal(repr(value)), "f")
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def format_number(value: float) -> str:
    """Compact text for a word value: integers stay integers; 3 decimals when they hold the
    value (float noise such as ``12.299999999999999`` is written ``12.3``), else the
    shortest exact decimal (``0.0001``, ``0.12349``): a value is never rounded to another
    number (``S0.0001`` used to become ``S0``)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"a G-code word value must be a number, got {value!r}")
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if not math.isfinite(value):
        raise ValueError(f"a G-code word value must be finite, got {value!r}")
    value = float(value)
    text = f"{value:.{FORMAT_DECIMALS}f}".rstrip("0").rstrip(".")
    text = "0" if text in ("-0", "") else text
    if abs(float(text) - value) > _FORMAT_TOLERANCE * abs(value):
        return _exact_text(value)
    return text


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
