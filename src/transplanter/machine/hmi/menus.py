"""The teach-mode menus (paper Fig. 8) as data: each menu's title, where ``*`` goes back to,
and its items (digit, label, action); the state machine (``states.Hmi``) carries out the
action of the item selected.

An action is a tuple: ``("open", menu)``, ``("pickup", k)`` (open pickup k's menu),
``("entry", field)`` (type a value), ``("jog", what, k)`` (teach a point by jogging),
``("home",)`` (G28) or ``("write",)`` (the Write EEPROM screen).
"""

from __future__ import annotations

from transplanter.machine.hmi.lcd import num
from transplanter.machine.hmi.teach import (
    TeachData,
    drop_wrist_field,
    mm,
    pickups_field,
    speed_field,
    wrist_field,
    z_field,
)
from transplanter.machine.sgf import SGFConfig
from transplanter.units import M_PER_MM

__all__ = ["PARENT", "TITLES", "Action", "Item", "menu_items", "menu_title"]

Action = tuple
"""What selecting an item does (module docstring)."""
Item = tuple[str, str, Action]
"""(digit, label, action) of a menu item; digit '' for an item no digit selects."""

TITLES = {
    "main": "MENU A^ Bv #ok",
    "pickups": "PICKUPS   *back",
    "drop": "DROP POINT *back",
    "z": "Z LEVELS  *back",
    "speeds": "SPEEDS    *back",
}
PARENT = {
    "pickups": "main",
    "pickup": "pickups",
    "drop": "main",
    "z": "main",
    "speeds": "main",
}
"""The menu ``*`` goes back to."""


def menu_title(menu: str, pickup: int) -> str:
    if menu == "pickup":
        return f"PICKUP {pickup + 1}  *back"
    return TITLES[menu]


def _xy(xy) -> str:
    if xy is None:
        return "---"
    return f"{xy[0] / M_PER_MM:.1f} {xy[1] / M_PER_MM:.1f}"


def menu_items(menu: str, pickup: int, d: TeachData, config: SGFConfig) -> list[Item]:
    """The items of ``menu`` (``pickup``: the slot of the 'pickup' menu), labelled with what
    ``d`` holds now."""
    if menu == "main":
        return [
            ("1", f"Pickups  Mpp {num(d.m_pp, 0)}", ("open", "pickups")),
            ("2", "Drop point", ("open", "drop")),
            ("3", "Z_up / Z_low", ("open", "z")),
            ("4", "Speeds S_l S_h", ("open", "speeds")),
            ("5", "Home arm (G28)", ("home",)),
            ("6", "Write EEPROM", ("write",)),
        ]
    if menu == "pickups":
        items: list[Item] = [("0", f"Mpp (count) {num(d.m_pp, 0)}", ("entry", pickups_field()))]
        for k in range(d.m_pp or 0):
            flags = "".join(
                c if v[k] is not None else "-"
                for c, v in (("A", d.approach), ("G", d.grip), ("E", d.wrist))
            )
            digit = str(k + 1) if k < 9 else ""
            items.append((digit, f"Pickup {k + 1:<2}  {flags}", ("pickup", k)))
        return items
    if menu == "pickup":
        k = pickup
        return [
            ("1", f"Appr {_xy(d.approach[k])}", ("jog", "approach", k)),
            ("2", f"Grip {_xy(d.grip[k])}", ("jog", "grip", k)),
            ("3", f"Elbow {num(d.wrist[k], 2)}", ("entry", wrist_field(k))),
        ]
    if menu == "drop":
        return [
            ("1", f"Pos {_xy(d.drop)}", ("jog", "drop", None)),
            ("2", f"Elbow {num(d.drop_wrist, 2)}", ("entry", drop_wrist_field())),
        ]
    if menu == "z":
        return [
            ("1", f"Z_up  {num(mm(d.z_up), 3)} mm", ("entry", z_field("z_up", config))),
            ("2", f"Z_low {num(mm(d.z_low), 3)} mm", ("entry", z_field("z_low", config))),
        ]
    if menu == "speeds":
        return [
            ("1", f"S_l {num(mm(d.s_low))} mm/s", ("entry", speed_field("s_low"))),
            ("2", f"S_h {num(mm(d.s_high))} mm/s", ("entry", speed_field("s_high"))),
        ]
    raise AssertionError(menu)
