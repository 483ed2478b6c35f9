"""The 20x4 character LCD: its screens as text, and refusal reasons cut down to fit it.

Every function here makes text from plain values (no HMI state): ``menu_screen``,
``entry_screen``, ``jog_screen`` and ``write_screen`` are the 4 lines of each screen,
``fit`` makes one of them exactly 20 ASCII characters. A refusal reaches the LCD already
short: the typed refusals format themselves (``errors.Refusal.short``,
``preflight.TaughtRefused.short``); the SGF's error replies, which reach the pendant over the
wire, are shown by their code (``sgf_note``). No message is read back.
"""

from __future__ import annotations

from collections.abc import Sequence

from transplanter.errors import ErrorCode
from transplanter.units import M_PER_MM

__all__ = [
    "ENTRY_HINT",
    "JOG_HINT",
    "LCD_COLS",
    "LCD_ROWS",
    "crop",
    "entry_screen",
    "fit",
    "framed",
    "jog_screen",
    "menu_screen",
    "num",
    "refusal_note",
    "sgf_note",
    "write_screen",
]

LCD_COLS, LCD_ROWS = 20, 4
JOG_HINT = "X4/6 Y8/2 Z9/3 5stp"
ENTRY_HINT = "D=. C=del #ok *back"


def crop(text: str, width: int = LCD_COLS) -> str:
    return text[:width]


def fit(text: str) -> str:
    """One LCD line: ASCII, cut or padded to exactly LCD_COLS characters."""
    text = text.encode("ascii", "replace").decode("ascii")
    return text[:LCD_COLS].ljust(LCD_COLS)


def num(value: float | None, decimals: int = 1) -> str:
    """A value for the LCD without trailing zeros ('60', '112.4'); '---' when not set."""
    if value is None:
        return "---"
    text = f"{value:.{decimals}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def framed(lines: Sequence[str]) -> str:
    """The LCD's lines in a frame, for a terminal."""
    edge = "+" + "-" * LCD_COLS + "+"
    return "\n".join([edge, *(f"|{line}|" for line in lines), edge])


# -- the screens -------------------------------------------------------------------------


def menu_screen(
    title: str, items: Sequence[tuple[str, str]], cursor: int, note: str | None
) -> list[str]:
    """A menu: its title (or the note) with the cursor's place, then 3 of its (digit, label)
    items around the cursor, '>' marking it."""
    top = max(0, min(cursor - 1, len(items) - (LCD_ROWS - 1)))
    position = f"{cursor + 1}/{len(items)}"
    if len(title) + 1 + len(position) <= LCD_COLS:
        title = title.ljust(LCD_COLS - len(position)) + position
    lines = [note if note is not None else title]
    for i in range(top, top + LCD_ROWS - 1):
        if i < len(items):
            digit, label = items[i]
            lines.append((">" if i == cursor else " ") + (f"{digit} " if digit else "  ") + label)
        else:
            lines.append("")
    return lines


def entry_screen(
    title: str,
    lo: float,
    hi: float,
    now: float | None,
    decimals: int,
    typed: str,
    note: str | None,
) -> list[str]:
    """A numeric entry (paper Fig. 11): the value's name and unit, its range and value now,
    what is typed so far."""
    return [
        title,
        f"{num(lo, decimals)}-{num(hi, decimals)} now {num(now, decimals)}",
        f"new {typed}_",
        note if note is not None else ENTRY_HINT,
    ]


def jog_screen(title: str, position_m, step_mm: float, note: str | None) -> list[str]:
    """Jogging (paper Fig. 12): what is taught, the jog step, where the arm is (mm)."""
    x, y, z = (value / M_PER_MM for value in position_m)
    step = f"s{num(step_mm)}"
    return [
        title.ljust(LCD_COLS - len(step)) + step,
        f"X{x:7.1f}  Y{y:7.1f}",
        f"Z{z:7.1f}  #sto *bk",
        note if note is not None else JOG_HINT,
    ]


def write_screen(m_pp: int | None, target: str, note: str | None) -> list[str]:
    return [
        "WRITE EEPROM",
        f"Mpp {num(m_pp, 0)} to {target}",
        "#=check+write *back",
        note if note is not None else "",
    ]


# -- refusals ----------------------------------------------------------------------------

SGF_LABELS = {
    ErrorCode.SYSTEM_LOCKED: "not homed",
    ErrorCode.INVALID_TARGET: "bad target",
    ErrorCode.HOMING_SWITCH_NOT_FOUND: "home fail",
    ErrorCode.HOMING_SWITCH_STUCK: "switch stuck",
    ErrorCode.LIMIT_SWITCH_CLOSED: "limit switch",
    ErrorCode.MOTOR_STALLED: "stalled",
    ErrorCode.RX_BUFFER_OVERFLOW: "buffer full",
}
"""What the pendant shows after 'SGF<N> ' for the SGF's error codes (others: the code's name)."""


def refusal_note(short: str) -> str:
    """The LCD line of a refusal the HMI found itself: 'NO <short>' in 20 characters."""
    return crop("NO " + short, LCD_COLS)


def sgf_note(reply: str) -> str:
    """The LCD line of the SGF's own error reply (``error:<code> ...``): 'SGF<N> <label>'."""
    code = ErrorCode.of_reply(reply)
    if code is None:
        return crop("SGF " + reply, LCD_COLS)
    label = SGF_LABELS.get(code, code.name.lower().replace("_", " "))
    return crop(f"SGF{int(code)} {label}", LCD_COLS)
