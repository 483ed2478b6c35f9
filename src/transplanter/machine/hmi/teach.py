"""The teach buffer: what the EEPROM image will hold as it is taught, the values entered with
the digits (``Field``: name, unit, range, decimals), and writing the image to a file.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from transplanter import fileio
from transplanter.machine.eeprom import (
    MAX_PICKUPS,
    MAX_SPEED_M_S,
    EepromError,
    EepromImage,
    Pickup,
)
from transplanter.machine.gcode import SERVO_MAX_DEG
from transplanter.machine.hmi.lcd import num
from transplanter.machine.sgf import SGFConfig
from transplanter.units import M_PER_MM

__all__ = [
    "SPEED_MAX_MM_S",
    "SPEED_MIN_MM_S",
    "Field",
    "TeachData",
    "drop_wrist_field",
    "mm",
    "pickups_field",
    "speed_field",
    "wrist_field",
    "write_image",
    "z_field",
]

SPEED_MAX_MM_S = MAX_SPEED_M_S / M_PER_MM
SPEED_MIN_MM_S = 0.1
"""Speeds: the scenario's least (0.1 mm/s) up to what the EEPROM's uint16 field holds."""


def mm(value: float | None) -> float | None:
    """Metres to millimetres; None stays None."""
    return None if value is None else value / M_PER_MM


@dataclass(frozen=True)
class Field:
    """A value entered with the digits: its LCD name, unit, range and decimals."""

    name: str
    unit: str
    lo: float
    hi: float
    decimals: int
    scale: float  # SI per unit entered
    attr: str
    index: int | None = None  # pickup slot for the per-pickup wrist angle
    short: str = ""  # the name in the 'Saved' note


@dataclass
class TeachData:
    """What the EEPROM will hold, as taught so far (SI; None: not taught yet)."""

    m_pp: int | None = None
    approach: list = dataclasses.field(default_factory=lambda: [None] * MAX_PICKUPS)
    grip: list = dataclasses.field(default_factory=lambda: [None] * MAX_PICKUPS)
    wrist: list = dataclasses.field(default_factory=lambda: [None] * MAX_PICKUPS)
    drop: tuple[float, float] | None = None
    drop_wrist: float | None = None
    z_up: float | None = None
    z_low: float | None = None
    s_low: float | None = None
    s_high: float | None = None

    @classmethod
    def of_image(cls, image: EepromImage) -> TeachData:
        data = cls(
            m_pp=image.m_pp,
            drop=image.drop_xy_m,
            drop_wrist=image.drop_wrist_deg,
            z_up=image.z_up_m,
            z_low=image.z_low_m,
            s_low=image.s_low_m_s,
            s_high=image.s_high_m_s,
        )
        for k, p in enumerate(image.pickups):
            data.approach[k], data.grip[k], data.wrist[k] = (
                p.approach_xy_m,
                p.grip_xy_m,
                p.wrist_deg,
            )
        return data

    def missing(self) -> str | None:
        """The first value still to teach, for the LCD; None when the image is complete."""
        checks = [
            (self.m_pp, "M_pp"),
            (self.z_up, "Z_up"),
            (self.z_low, "Z_low"),
            (self.s_low, "S_l"),
            (self.s_high, "S_h"),
            (self.drop, "drop point"),
            (self.drop_wrist, "drop elbow"),
        ]
        for value, name in checks:
            if value is None:
                return f"{name} not set"
        for k in range(self.m_pp):
            for values, name in (
                (self.approach, "appr"),
                (self.grip, "grip"),
                (self.wrist, "elbow"),
            ):
                if values[k] is None:
                    return f"P{k + 1} {name} not set"
        return None

    def image(self) -> EepromImage:
        """The EEPROM image (EepromError if something is missing or out of range)."""
        missing = self.missing()
        if missing is not None:
            raise EepromError(missing)
        return EepromImage(
            pickups=tuple(
                Pickup(self.approach[k], self.grip[k], self.wrist[k]) for k in range(self.m_pp)
            ),
            drop_xy_m=self.drop,
            drop_wrist_deg=self.drop_wrist,
            z_up_m=self.z_up,
            z_low_m=self.z_low,
            s_low_m_s=self.s_low,
            s_high_m_s=self.s_high,
        )

    def current(self, field: Field) -> float | None:
        """The value of ``field`` now, in the unit it is entered in; None: not set."""
        value = getattr(self, field.attr)
        if field.index is not None:
            value = value[field.index]
        return None if value is None else value / field.scale

    def store(self, f: Field, text: str) -> str | None:
        """Store the value typed for ``f``; the LCD's reason (<= 20 characters) if it is
        refused (format, range, Z_up above Z_low)."""
        if not text or text == ".":
            return "Type a value"
        decimals = len(text.partition(".")[2])
        if decimals > f.decimals:
            return f"Max {f.decimals} decimals" if f.decimals else "Whole number"
        value = float(text)
        if not f.lo <= value <= f.hi:
            return f"Range {num(f.lo, f.decimals)}-{num(f.hi, f.decimals)}"
        si = value * f.scale
        if f.attr == "z_up" and self.z_low is not None and si <= self.z_low:
            return f"Z_up<=Z_low {num(mm(self.z_low), 3)}"
        if f.attr == "z_low" and self.z_up is not None and si >= self.z_up:
            return f"Z_low>=Z_up {num(mm(self.z_up), 3)}"
        if f.attr == "m_pp":
            self.m_pp = int(value)
        elif f.index is not None:
            getattr(self, f.attr)[f.index] = si
        else:
            setattr(self, f.attr, si)
        return None

    def set_point(self, what: str, k: int | None, xy: tuple[float, float]) -> None:
        """Store a taught point: ``what`` 'drop', or 'approach'/'grip' of pickup ``k``."""
        if what == "drop":
            self.drop = xy
        else:
            getattr(self, what)[k] = xy


# -- the values entered with the digits (paper Fig. 11) ---------------------------------


def pickups_field() -> Field:
    """M_pp, the number of pickups."""
    return Field("Pickups M_pp", "", 1, MAX_PICKUPS, 0, 1.0, "m_pp", short="M_pp")


def wrist_field(k: int) -> Field:
    """M_pep, the wrist (the paper's elbow) angle of pickup k."""
    return Field(
        f"P{k + 1} elbow M_pep",
        "deg",
        0.0,
        SERVO_MAX_DEG,
        2,
        1.0,
        "wrist",
        k,
        f"P{k + 1} elbow",
    )


def drop_wrist_field() -> Field:
    """M_dep, the wrist (the paper's elbow) angle at the drop point."""
    return Field("Drop elbow M_dep", "deg", 0.0, SERVO_MAX_DEG, 2, 1.0, "drop_wrist", short="M_dep")


def z_field(attr: str, config: SGFConfig) -> Field:
    """Z_up or Z_low (``attr``), in the SGF's Z range."""
    name = "Z_up" if attr == "z_up" else "Z_low"
    lo, hi = (bound / M_PER_MM for bound in config.kinematics.axes[2].window)
    return Field(name, "mm", lo, hi, 3, M_PER_MM, attr, short=name)


def speed_field(attr: str) -> Field:
    """S_l or S_h (``attr``), as the EEPROM holds them."""
    name = "S_l low speed" if attr == "s_low" else "S_h high speed"
    short = name.split()[0]
    return Field(name, "mm/s", SPEED_MIN_MM_S, SPEED_MAX_MM_S, 1, M_PER_MM, attr, short=short)


def write_image(path: str | Path, data: bytes) -> None:
    """Write an EEPROM image atomically (``fileio``: an exclusive temporary file beside the
    target, moved into place when complete)."""
    target = Path(path)
    tmp = fileio.temp_beside(target)
    try:
        tmp.write_bytes(data)
    except BaseException:
        fileio.discard(tmp)
        raise
    fileio.commit(tmp, target)
