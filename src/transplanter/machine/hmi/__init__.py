"""The HMI: a 20x4 character LCD and a 4x4 membrane keypad, the paper's teach mode.

The paper's PGF board (an Arduino Mega) has an LCD and a keypad whose buttons serve as up,
down, left, right, select, back and numerical entries (section 3.1, Fig. 10). Through a menu
(Fig. 8) the user enters the number of pickups M_pp and the other values (Fig. 11: navigate,
enter the value, select saves it), and teaches points by moving the end effector with the
keys until it is where the point should be; its X and Y are then fetched from the SGF over
the COM bus and stored (Fig. 12, 'End effector position' in the drop menu). The result is
the EEPROM image of Fig. 9 (layout: ``transplanter.machine.eeprom``).

:class:`Hmi` is that state machine, with no I/O of its own: ``press(key)`` takes one of the
16 keys (``KEYS``), ``lcd`` is the 4 lines of 20 characters shown. The arm is a real
:class:`~transplanter.machine.sgf.SGF` on a simulated clock (:class:`SGFPort`): the HMI
homes it with ``G28`` at power-on, jogs it with absolute ``G1`` lines and reads its position
with ``M114``. A jog target is checked first as the SGF would check it (Z range, every
interpolated point of the straight move through ``motion.plan_line``); a refused target never
moves the arm and the LCD says why in a few words (the full reason is in
``Hmi.last_refusal``). The SGF's own refusals are shown the same way.

Key map (docs/hmi.md)::

    1 2 3 A     menus:  A up, B down, # select, * back, a digit selects its item
    4 5 6 B     values: 0-9, D decimal point, C delete, # save, * cancel
    7 8 9 C     jog:    4/6 X-/X+, 8/2 Y-/Y+, 9/3 Z-/Z+, 5 step 10/1/0.1 mm,
    * 0 # D             # store the position, * back

Two front ends drive it: ``run_keys`` (a scripted key sequence, what the tests use and
``transplanter hmi --keys``) and ``run_terminal`` (curses, ``transplanter hmi`` on a TTY).
Pure Python and numpy: no MuJoCo.

One concern per module, none importing a later one:

- ``keys``: the 16 keys, key scripts (``parse_keys``) and ``run_keys``;
- ``lcd``: the LCD's screens as text, and the refusal lines (typed refusals format themselves;
  the SGF's error replies are shown by their code);
- ``port``: ``SGFPort``, the SGF one line at a time on a simulated clock (``rig.DirectLink``);
- ``teach``: the teach buffer (``TeachData``), the values typed in (``Field``), ``write_image``;
- ``jog``: jog keys and steps, the jog target and the SGF's check of the move;
- ``menus``: the menus as data (titles, parents, items and their actions);
- ``states``: ``Hmi``, the state machine;
- ``terminal``: the curses front end (``run_terminal``) and its keyboard mapping.
"""

from transplanter.machine.hmi.jog import JOG_STEPS_MM
from transplanter.machine.hmi.keys import (
    KEYPAD_ROWS,
    KEYS,
    MAX_KEY_SCRIPT_BYTES,
    KeyScriptError,
    parse_keys,
    run_keys,
)
from transplanter.machine.hmi.lcd import LCD_COLS, LCD_ROWS, refusal_note, sgf_note
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
    "refusal_note",
    "sgf_note",
    "parse_keys",
    "run_keys",
    "run_terminal",
    "terminal_key",
    "write_image",
]
