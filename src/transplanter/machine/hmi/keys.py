"""The keypad's 16 keys and key scripts: what ``transplanter hmi --keys`` and the tests press.

A key script is text: each of the 16 key characters is one press; spaces and line breaks are
ignored, and ``;`` starts a comment up to the end of its line (``tests/hmi/teach_paper.keys``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Protocol, TypeVar

__all__ = [
    "KEYPAD_ROWS",
    "KEYS",
    "MAX_KEY_SCRIPT_BYTES",
    "KeyScriptError",
    "Keypad",
    "parse_keys",
    "run_keys",
]

KEYS = "0123456789ABCD*#"
"""The 16 keys of the 4x4 membrane keypad."""
KEYPAD_ROWS = ("123A", "456B", "789C", "*0#D")
"""The keypad as it is laid out."""
MAX_KEY_SCRIPT_BYTES = 1 << 20
"""A key script file is at most this big (a teach session is a few hundred keys)."""


class KeyScriptError(ValueError):
    """A key script holds something that is not a key; the message names where."""


def parse_keys(text: str, source: str = "keys") -> list[str]:
    """The keys of a script: each of the 16 key characters is one press; spaces and line
    breaks are ignored, and ``;`` starts a comment up to the end of its line. Anything else
    is a KeyScriptError naming its line, column and the valid keys."""
    keys: list[str] = []
    for line_no, line in enumerate(text.splitlines() or [""], start=1):
        for col, char in enumerate(line, start=1):
            if char == ";":
                break
            if char in " \t\r\f\v":
                continue
            if char not in KEYS:
                where = f"line {line_no}, column {col}" if "\n" in text else f"position {col}"
                raise KeyScriptError(
                    f"{source}: {char!r} at {where} is not a key; the keypad's keys are "
                    "0-9 A B C D * # (spaces and line breaks are ignored, ';' starts a comment)"
                )
            keys.append(char)
    return keys


class Keypad(Protocol):
    """What takes key presses (``hmi.Hmi``)."""

    def press(self, key: str) -> None: ...


K = TypeVar("K", bound=Keypad)


def run_keys(
    hmi: K, keys: Iterable[str], on_screen: Callable[[int, str, K], None] | None = None
) -> K:
    """Press each key in turn; ``on_screen(i, key, hmi)`` after every press."""
    for i, key in enumerate(keys):
        hmi.press(key)
        if on_screen is not None:
            on_screen(i, key, hmi)
    return hmi
