"""The HMI: the paper's teach mode (20x4 LCD, 4x4 keypad), as a package (docs/hmi.md)."""

from transplanter.machine.hmi.jog import JOG_STEPS_MM
from transplanter.machine.hmi.keys import (
    KEYPAD_ROWS,
    KEYS,
    MAX_KEY_SCRIPT_BYTES,
    KeyScriptError,
    parse_keys,
    run_keys,
)
from transplanter.machine.hmi.lcd import LCD_COLS, LCD_ROWS, short_reason
from transplanter.machine.hmi.lcd import short_reason as lcd_reason
from transplanter.machine.hmi.port import SGFPort
from transplanter.machine.hmi.states import Hmi
from transplanter.machine.hmi.teach import TeachData, write_image
from transplanter.machine.hmi.terminal import TERMINAL_KEYS, run_terminal, terminal_key

__all__ = [
    "JOG_STEPS_MM",
    "KEYPAD_ROWS",
    "KEYS",
    "LCD_COLS",
    "LCD_ROWS",
    "MAX_KEY_SCRIPT_BYTES",
    "Hmi",
    "KeyScriptError",
    "SGFPort",
    "TERMINAL_KEYS",
    "TeachData",
    "lcd_reason",
    "parse_keys",
    "run_keys",
    "run_terminal",
    "short_reason",
    "terminal_key",
    "write_image",
]
