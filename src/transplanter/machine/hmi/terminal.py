"""The interactive front end of ``transplanter hmi`` on a terminal (curses): the LCD, the
keypad and the keyboard's mapping onto it; q quits."""

from __future__ import annotations

from transplanter.machine.hmi.keys import KEYPAD_ROWS, KEYS
from transplanter.machine.hmi.states import Hmi

__all__ = ["TERMINAL_KEYS", "run_terminal", "terminal_key"]

TERMINAL_KEYS = {
    "enter": "#",
    "backspace": "C",
    "escape": "*",
    "up": "A",
    "down": "B",
    ".": "D",
    "q": None,  # quit
}
"""Keyboard keys of the terminal UI beyond the keypad's own characters (0-9, a-d or A-D,
* and #): Enter = #, Backspace = C, Esc = *, arrow up/down = A/B, '.' = D; q quits."""


def terminal_key(name: str) -> str | None:
    """The keypad key of a keyboard key (a character or a TERMINAL_KEYS name); None for
    none. 'q' is handled by the caller (quit)."""
    if len(name) == 1 and name.upper() in KEYS:
        return name.upper()
    return TERMINAL_KEYS.get(name)


def run_terminal(hmi: Hmi) -> None:  # pragma: no cover - needs a terminal
    """The interactive curses front end: the LCD, the keypad and the mapping; q quits."""
    import curses

    special = {
        curses.KEY_UP: "up",
        curses.KEY_DOWN: "down",
        curses.KEY_BACKSPACE: "backspace",
        127: "backspace",
        8: "backspace",
        curses.KEY_ENTER: "enter",
        10: "enter",
        13: "enter",
        27: "escape",
    }

    def draw(screen) -> None:
        screen.erase()
        for row, line in enumerate(hmi.lcd_text().splitlines()):
            screen.addstr(row, 2, line)
        pad = ["Keypad:"] + [" ".join(r) for r in KEYPAD_ROWS]
        for row, line in enumerate(pad):
            screen.addstr(row, 28, line)
        help_lines = [
            "menus: A/up B/down #/Enter select *,Esc back, digit = item",
            "values: digits, D or '.' point, C/Backspace delete, # save",
            "jog: 4/6 X  8/2 Y  9/3 Z  5 step  # store  * back",
            "q: quit (the image is written only by 6 Write EEPROM)",
        ]
        for row, line in enumerate(help_lines, start=7):
            screen.addstr(row, 2, line)
        if hmi.last_refusal:
            screen.addstr(12, 2, ("last refusal: " + hmi.last_refusal)[: max(10, curses.COLS - 4)])
        screen.refresh()

    def loop(screen) -> None:
        curses.curs_set(0)
        while True:
            draw(screen)
            code = screen.getch()
            name = special.get(code) or (chr(code) if 0 <= code < 256 else "")
            if name in ("q", "Q"):
                return
            key = terminal_key(name)
            if key is not None:
                hmi.press(key)

    curses.wrapper(loop)
