"""Jogging (paper Fig. 12): the jog keys and steps, where a jog goes, and whether the SGF would
take the move there (checked before anything is sent)."""

from __future__ import annotations

import math

import numpy as np

from transplanter.machine.hmi.lcd import LCD_COLS, crop
from transplanter.machine.kinematics import UnreachableError
from transplanter.machine.motion import plan_line
from transplanter.machine.sgf import SGFConfig
from transplanter.units import M_PER_MM

__all__ = [
    "JOG_GRID_TICKS_PER_MM",
    "JOG_KEYS",
    "JOG_SPEED_MM_S",
    "JOG_STEPS_MM",
    "check_move",
    "jog_line",
    "jog_target",
    "jog_title",
]

JOG_STEPS_MM = (10.0, 1.0, 0.1)
"""Jog step sizes, cycled by key 5 (the first is the power-on step)."""
JOG_GRID_TICKS_PER_MM = 10
"""Jog targets lie on a 0.1 mm grid: a jog goes to the next multiple of the step."""
JOG_SPEED_MM_S = 20.0
"""Speed of a jog move (the ``S`` word of its G1 line)."""
JOG_KEYS = {"4": (0, -1), "6": (0, +1), "8": (1, -1), "2": (1, +1), "9": (2, -1), "3": (2, +1)}
"""(axis, direction) of each jog key: 4/6 X-/X+, 8/2 Y-/Y+, 9/3 Z-/Z+."""


def jog_title(what: str, k: int | None) -> str:
    """The name of the point taught: 'P1 appr', 'P1 grip', 'Drop pos'."""
    name = {"approach": "appr", "grip": "grip", "drop": "Drop pos"}[what]
    return name if k is None else f"P{k + 1} {name}"


def jog_target(position: np.ndarray, step_mm: float, axis: int, direction: int) -> np.ndarray:
    """Where a jog goes: the next multiple of the step along the axis (0.1 mm grid)."""
    step = round(step_mm * JOG_GRID_TICKS_PER_MM)
    ticks = position[axis] / M_PER_MM * JOG_GRID_TICKS_PER_MM
    if direction > 0:
        n = math.floor(ticks / step + 1e-6) + 1
    else:
        n = math.ceil(ticks / step - 1e-6) - 1
    target = position.copy()
    target[axis] = n * step / JOG_GRID_TICKS_PER_MM * M_PER_MM
    return target


def check_move(
    config: SGFConfig, steps: np.ndarray, position: np.ndarray, target: np.ndarray
) -> tuple[str, str] | None:
    """Why the SGF would refuse the straight move from ``position`` (its step counters
    ``steps``) to ``target``, as (the whole reason, its 17-character form for the LCD); None
    when it would not. The target's range first (the arm's ``limit_target``), then every
    interpolated point (``motion.plan_line``), as the SGF checks them."""
    kinematics = config.kinematics
    width = LCD_COLS - 3
    refusal = kinematics.limit_target(target)
    if refusal is not None:
        return refusal.text(), refusal.short(width)
    try:
        plan_line(steps, position, target, JOG_SPEED_MM_S * M_PER_MM, kinematics, config.motion)
    except UnreachableError as error:
        return error.reason, error.refusals[0].short(width)
    except ValueError as error:
        return str(error), crop(str(error), width)
    return None


def jog_line(target: np.ndarray) -> str:
    """The G1 line of a jog to ``target`` (m)."""
    x, y, z = (target / M_PER_MM).tolist()
    return f"G1 X{x:.1f} Y{y:.1f} Z{z:.1f} S{JOG_SPEED_MM_S:g}"
