"""The 20x4 character LCD: its screens as text, and refusal reasons cut down to fit it.

Every function here makes text from plain values (no HMI state): ``menu_screen``,
``entry_screen``, ``jog_screen`` and ``write_screen`` are the 4 lines of each screen,
``fit`` makes one of them exactly 20 ASCII characters, and ``short_reason`` is the one
place that reads a refusal's message to show it in a few words.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

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
    "short_reason",
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

_SGF_ERROR = re.compile(r"error:(\d+) (.*)", re.S)
_PREFLIGHT_POINT = re.compile(r"taught\.pickup\[(\d+)\]\.(approach|grip)_mm")
_PREFLIGHT_MOVE = re.compile(r"taught\.pickup\[(\d+)\]: ")
_Z_RANGE = re.compile(
    r"Z (?P<z>\S+) mm (?P<side>above|below) the Z range (?:max|min) (?P<bound>\S+) mm"
)
_LIMIT = re.compile(
    r"(?P<what>motor (?P<motor>\d) angle|elbow angle at (?P<elbow>[BD])|transmission angle) "
    r"(?P<v>-?[\d.]+) deg outside \[(?P<lo>-?[\d.]+), (?P<hi>-?[\d.]+)\]"
)
_NEEDLES = (
    ("outside workspace", ("out of reach", "no reach")),
    ("Jacobian condition", ("near singularity", "singular")),
    ("home first", ("not homed", "home")),
    ("homing failed", ("homing failed", "home fail")),
    ("position unknown", ("not homed", "home")),
)


def short_reason(message: str, width: int = LCD_COLS - 3) -> str:
    """A refusal's message in at most ``width`` characters for the LCD: the most telling form
    that fits ('motor1 79.97<80', else 'motor1 limit'), else the message cut.

    It reads the messages as text (to be replaced by typed reasons): an SGF reply
    ``error:N <reason>`` becomes 'SGF<N> ' and its reason shortened (after its 'what: ', unless
    that is a motor); a preflight message (``preflight.check_machine``: 'taught.pickup[k].
    approach_mm ...', 'taught.pickup[k]: the move ...', 'taught.drop_mm...') the point or move
    that fails; the HMI's Z range check ('Z 170 mm above the Z range max 160 mm') 'Z 170 >
    160'; a kinematics limit ('motor 1 angle', 'elbow angle at B', 'transmission angle ... deg
    outside [lo, hi]') its name, value and the bound passed; and reach, singularity and homing
    messages a word or two."""
    text = message.strip()
    m = _SGF_ERROR.match(text)
    if m:
        prefix = f"SGF{m.group(1)} "
        inner = m.group(2)
        if ": " in inner and not inner.startswith("motor"):
            inner = inner.split(": ", 1)[1]
        return prefix + short_reason(inner, width - len(prefix))
    if text.startswith("taught."):
        if m := _PREFLIGHT_POINT.match(text):
            return crop(f"P{int(m.group(1)) + 1} {m.group(2)[:4]} unreach.", width)
        if m := _PREFLIGHT_MOVE.match(text):
            return crop(f"P{int(m.group(1)) + 1} move unreach.", width)
        if text.startswith("taught.drop_mm: "):
            return crop("home>drop unreach", width)
        if text.startswith("taught.drop_mm"):
            return crop("drop unreachable", width)
        return crop(text, width)
    if m := _Z_RANGE.match(text):
        sign = ">" if m.group("side") == "above" else "<"
        return crop(f"Z {m.group('z')} {sign} {m.group('bound')}", width)
    forms: list[str] = []
    if m := _LIMIT.search(text):
        if m.group("motor"):
            name = f"motor{m.group('motor')}"
        elif m.group("elbow"):
            name = f"elbow {m.group('elbow')}"
        else:
            name = "transm."
        value, lo, hi = m.group("v"), m.group("lo"), m.group("hi")
        bound = f"<{lo}" if float(value) < float(lo) else f">{hi}"
        forms = [f"{name} {value}{bound}", f"{name}{value}{bound}", f"{name} limit", name]
    else:
        forms = next((list(short) for needle, short in _NEEDLES if needle in text), [])
    for candidate in forms:
        if len(candidate) <= width:
            return candidate
    return crop(text, width)


def refusal_note(reason: str) -> str:
    """The LCD line of a refusal: the SGF's own error reply as 'SGF<N> <reason>', anything
    else as 'NO <reason>', in 20 characters (``short_reason``)."""
    if reason.startswith("error:"):
        return short_reason(reason, LCD_COLS)
    return "NO " + short_reason(reason, LCD_COLS - 3)
