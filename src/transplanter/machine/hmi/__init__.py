"""The HMI: the paper's teach mode (20x4 LCD, 4x4 keypad), as a package (docs/hmi.md)."""

from transplanter.machine.hmi.states import (
    JOG_STEPS_MM,
    KEYS,
    LCD_COLS,
    LCD_ROWS,
    MAX_KEY_SCRIPT_BYTES,
    Hmi,
    KeyScriptError,
    SGFPort,
    lcd_reason,
    parse_keys,
    run_keys,
    run_terminal,
    terminal_key,
)

__all__ = [
    "JOG_STEPS_MM",
    "KEYS",
    "LCD_COLS",
    "LCD_ROWS",
    "MAX_KEY_SCRIPT_BYTES",
    "Hmi",
    "KeyScriptError",
    "SGFPort",
    "lcd_reason",
    "parse_keys",
    "run_keys",
    "run_terminal",
    "terminal_key",
]
