"""The teach-mode state machine (:class:`Hmi`): a screen at a time (menu, entry, jog, write),
each with a ``_render_<screen>`` (its 4 lines, through ``lcd``) and a ``_key_<screen>`` (what a
key does there). The package docstring (``transplanter.machine.hmi``) describes the HMI."""

from __future__ import annotations

import dataclasses
import zlib
from pathlib import Path

import numpy as np

from transplanter.machine.config import Machine
from transplanter.machine.eeprom import (
    CRC_OFFSET,
    DATA_SIZE,
    EepromError,
    EepromImage,
)
from transplanter.machine.hmi.jog import (
    JOG_KEYS,
    JOG_STEPS_MM,
    check_move,
    jog_line,
    jog_target,
    jog_title,
)
from transplanter.machine.hmi.keys import KEYS
from transplanter.machine.hmi.lcd import (
    LCD_COLS,
    LCD_ROWS,
    crop,
    entry_screen,
    fit,
    framed,
    jog_screen,
    menu_screen,
    num,
    refusal_note,
    sgf_note,
    write_screen,
)
from transplanter.machine.hmi.menus import PARENT, Action, Item, menu_items, menu_title
from transplanter.machine.hmi.port import SGFPort
from transplanter.machine.hmi.teach import (
    Field,
    TeachData,
    write_image,
)
from transplanter.units import M_PER_MM

__all__ = ["Hmi"]

MAX_ENTRY_CHARS = 8
"""Characters a numeric entry takes."""


class Hmi:
    """The teach-mode state machine (``transplanter.machine.hmi``). ``out_path``: where
    ``Write EEPROM`` writes the image (atomically); None keeps it in ``image_bytes`` only."""

    def __init__(
        self,
        machine: Machine,
        out_path: str | Path | None = None,
        image: EepromImage | None = None,
    ):
        self.machine = machine
        self.config = machine.sgf
        self.out_path = None if out_path is None else Path(out_path)
        self.data = TeachData.of_image(image) if image is not None else TeachData()
        self.port = SGFPort(self.config)
        self.position = np.full(3, np.nan)
        """Where the SGF says the arm is (x, y, z m), from its last M114."""
        self.steps = np.zeros(3, dtype=np.int64)
        """The SGF's logical step counters, from its last M114."""
        self.step_index = 0
        self.screen = "menu"
        self.menu = "main"
        self.pickup = 0  # the pickup slot of the 'pickup' menu
        self.cursor = {"main": 0}
        self.field: Field | None = None
        self.typed = ""
        self.jog_target: tuple[str, int | None] | None = None  # ('approach'|'grip'|'drop', k)
        self.note: str | None = None
        self.last_refusal: str | None = None
        """The full reason of the last refusal (the LCD shows it shortened)."""
        self.refused = False
        """The last key (or the power-on) was refused: the LCD shows why."""
        self.image_bytes: bytes | None = None
        """The last image written."""
        self.writes = 0
        self.write_error: str | None = None
        """Why the last Write EEPROM could not write ``out_path`` (a full disk: the file is
        then as it was, no part of the image in it); None once one succeeds."""
        self._home()

    # -- the LCD --------------------------------------------------------------------
    @property
    def lcd(self) -> tuple[str, str, str, str]:
        """The 4 lines of 20 characters on the LCD now."""
        lines = getattr(self, f"_render_{self.screen}")()
        assert len(lines) == LCD_ROWS
        return tuple(fit(line) for line in lines)

    def lcd_text(self) -> str:
        """The LCD in a frame, for a terminal."""
        return framed(self.lcd)

    # -- keys -----------------------------------------------------------------------
    def press(self, key: str) -> None:
        """One key of the keypad (``KEYS``)."""
        if not (isinstance(key, str) and len(key) == 1 and key in KEYS):
            raise ValueError(f"{key!r} is not a key; the keys are {' '.join(KEYS)}")
        self.note = None
        self.refused = False
        getattr(self, f"_key_{self.screen}")(key)

    # -- the SGF --------------------------------------------------------------------
    def _send(self, line: str) -> str | None:
        """Send a line; None if it was done, else the SGF's error reply."""
        replies = self.port.send(line)
        return None if replies[-1] == "ok" else replies[-1]

    def _fetch_position(self) -> None:
        """M114: the position and the step counters, as the SGF reports them."""
        found = self.port.where()
        if found is None:
            self.position = np.full(3, np.nan)
        else:
            self.position, self.steps = found

    def _home(self) -> None:
        error = self._send("G28")
        if error is None:
            error = self._send("G90")
        self._fetch_position()
        if error is not None:
            self._sgf_refused(error)
            return
        x, y, z = self.position / M_PER_MM
        self.note = f"Homed X{x:.0f} Y{y:.0f} Z{z:.0f}"

    def _note_refusal(self, reason: str) -> None:
        self.last_refusal = reason
        self.refused = True

    def _refuse(self, reason: str, short: str) -> None:
        """Keep the full reason; the LCD shows 'NO <short>' (20 characters)."""
        self._note_refusal(reason)
        self.note = refusal_note(short)

    def _sgf_refused(self, reply: str) -> None:
        """The SGF's own error reply: kept whole, shown by its code ('SGF9 not homed')."""
        self._note_refusal(reply)
        self.note = sgf_note(reply)

    # -- menus ----------------------------------------------------------------------
    def _open(self, menu: str) -> None:
        self.menu = menu
        self.screen = "menu"
        self.cursor.setdefault(self._cursor_key(), 0)

    def _cursor_key(self) -> str:
        return f"pickup{self.pickup}" if self.menu == "pickup" else self.menu

    def _items(self) -> list[Item]:
        """(digit, label, action) of the current menu."""
        return menu_items(self.menu, self.pickup, self.data, self.config)

    def _select(self, action: Action) -> None:
        """Carry out a menu item's action (``menus``)."""
        kind, *args = action
        if kind == "open":
            self._open(*args)
        elif kind == "pickup":
            self.pickup = args[0]
            self._open("pickup")
        elif kind == "entry":
            self._entry(*args)
        elif kind == "jog":
            self._jog(*args)
        elif kind == "home":
            self._home()
        elif kind == "write":
            self.screen = "write"
        else:
            raise AssertionError(action)

    def _render_menu(self) -> list[str]:
        items = self._items()
        cursor = min(self.cursor.get(self._cursor_key(), 0), len(items) - 1)
        labels = [(digit, label) for digit, label, _ in items]
        title = menu_title(self.menu, self.pickup)
        return menu_screen(title, labels, cursor, self.note)

    def _key_menu(self, key: str) -> None:
        items = self._items()
        where = self._cursor_key()
        cursor = min(self.cursor.get(where, 0), len(items) - 1)
        if key == "A":
            self.cursor[where] = max(0, cursor - 1)
        elif key == "B":
            self.cursor[where] = min(len(items) - 1, cursor + 1)
        elif key == "#":
            self._select(items[cursor][2])
        elif key == "*":
            if self.menu == "main":
                self.note = "Main menu"
            else:
                self._open(PARENT[self.menu])
        elif key.isdigit():
            for i, (digit, _, action) in enumerate(items):
                if digit == key:
                    self.cursor[where] = i
                    self._select(action)
                    return
            if self.menu == "pickups" and not self.data.m_pp:
                self.note = "Set M_pp first: 0"
            else:
                self.note = f"No item {key} here"
        else:
            self.note = f"Key {key}: no use here"

    # -- numeric entry (paper Fig. 11) ---------------------------------------------
    def _entry(self, field: Field) -> None:
        self.field = field
        self.typed = ""
        self.screen = "entry"

    def _render_entry(self) -> list[str]:
        f = self.field
        title = f"{f.name} {f.unit}".strip()
        now = self.data.current(f)
        return entry_screen(title, f.lo, f.hi, now, f.decimals, self.typed, self.note)

    def _key_entry(self, key: str) -> None:
        f = self.field
        if key.isdigit() or key == "D":
            char = "." if key == "D" else key
            if len(self.typed) >= MAX_ENTRY_CHARS:
                self.note = f"Max {MAX_ENTRY_CHARS} characters"
            elif char == "." and (f.decimals == 0 or "." in self.typed):
                self.note = "Whole number" if f.decimals == 0 else "One point only"
            else:
                self.typed += char
        elif key == "C":
            self.typed = self.typed[:-1]
        elif key == "*":
            self._open(self.menu)
        elif key == "#":
            error = self.data.store(f, self.typed)
            if error is not None:
                self._note_refusal(error)
                self.note = error
            else:
                self._open(self.menu)
                self.note = f"Saved {f.short} {num(self.data.current(f), f.decimals)}"
        else:
            self.note = f"Key {key}: no use here"

    # -- jogging (paper Fig. 12) ---------------------------------------------------
    def _jog(self, what: str, k: int | None) -> None:
        self.jog_target = (what, k)
        self.screen = "jog"
        self._fetch_position()

    def _render_jog(self) -> list[str]:
        step_mm = JOG_STEPS_MM[self.step_index]
        return jog_screen(jog_title(*self.jog_target), self.position.tolist(), step_mm, self.note)

    def _key_jog(self, key: str) -> None:
        if key in JOG_KEYS:
            axis, direction = JOG_KEYS[key]
            self._jog_move(axis, direction)
        elif key == "5":
            self.step_index = (self.step_index + 1) % len(JOG_STEPS_MM)
            self.note = f"Step {num(JOG_STEPS_MM[self.step_index])} mm"
        elif key == "#":
            self._store_position()
        elif key == "*":
            self._open(self.menu)
        else:
            self.note = f"Key {key}: no use here"

    def jog_target_of(self, axis: int, direction: int) -> np.ndarray:
        """Where a jog goes: the next multiple of the step along the axis (0.1 mm grid)."""
        return jog_target(self.position, JOG_STEPS_MM[self.step_index], axis, direction)

    def check_move(self, target: np.ndarray) -> tuple[str, str] | None:
        """Why the SGF would refuse the straight move from here to ``target`` (the reason and
        its LCD form; None: it would not): the target's range, then every interpolated point
        (``motion.plan_line``)."""
        return check_move(self.config, self.steps, self.position, target)

    def _jog_move(self, axis: int, direction: int) -> None:
        if not np.isfinite(self.position).all():
            self._refuse("position unknown: home first (menu 5)", "not homed")
            return
        target = self.jog_target_of(axis, direction)
        refused = self.check_move(target)
        if refused is not None:
            self._refuse(*refused)
            return
        error = self._send(jog_line(target))
        self._fetch_position()
        if error is not None:
            self._sgf_refused(error)

    def _store_position(self) -> None:
        self._fetch_position()  # the coordinates come from the SGF (paper Fig. 12)
        if not np.isfinite(self.position).all():
            self._refuse("position unknown: home first (menu 5)", "not homed")
            return
        xy = (float(self.position[0]), float(self.position[1]))
        self.data.set_point(*self.jog_target, xy)
        title = jog_title(*self.jog_target)
        self._open(self.menu)
        self.note = f"{title} stored"

    # -- writing the EEPROM ----------------------------------------------------------
    def _render_write(self) -> list[str]:
        target = "file" if self.out_path is not None else "memory"
        return write_screen(self.data.m_pp, target, self.note)

    def _key_write(self, key: str) -> None:
        if key == "*":
            self._open("main")
        elif key == "#":
            self.write()
        else:
            self.note = f"Key {key}: no use here"

    def write(self) -> bool:
        """Check the taught data (complete, in range, every point and move of the cycle
        reachable, the reply timeout: ``preflight.check_program``, as the trial does) and
        write the image; False (the LCD says why) if refused or the file could not be
        written."""
        from transplanter.scenario.preflight import TaughtRefused, check_program
        from transplanter.scenario.schema import ScenarioError

        try:
            image = self.data.image()
        except EepromError as error:
            self._note_refusal(str(error))
            self.note = "NO " + crop(str(error), LCD_COLS - 3)
            return False
        try:
            check_program(dataclasses.replace(self.machine, eeprom=image))
        except TaughtRefused as error:
            self._refuse(str(error), error.short(LCD_COLS - 3))
            return False
        except ScenarioError as error:
            self._refuse(str(error), crop(str(error), LCD_COLS - 3))
            return False
        data = image.to_bytes()
        if self.out_path is not None:
            try:
                write_image(self.out_path, data)
            except OSError as error:
                self._note_refusal(f"{self.out_path}: {error}")
                self.write_error = error.strerror or str(error)
                self.note = "NO write failed"
                return False
        self.write_error = None
        self.image_bytes = data
        self.writes += 1
        crc = int.from_bytes(data[CRC_OFFSET : CRC_OFFSET + 4], "little")
        assert crc == zlib.crc32(data[:DATA_SIZE])
        self.note = f"Written CRC {crc:08x}"
        return True
