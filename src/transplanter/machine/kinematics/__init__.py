"""Arm kinematics, one module per kind of arm, created by name (as Klipper loads
``klippy/kinematics/<name>.py`` and RepRapFirmware creates a ``Kinematics`` by type).

``KINDS`` maps a scenario's ``[robot] kind`` to the class that implements it, imported only
when asked for. Adding an arm adds its module and one line here; :func:`register` adds a kind
at run time (a test's own gantry, a user's plug-in).
"""

from __future__ import annotations

import importlib

from transplanter.errors import TransplanterError
from transplanter.machine.axes import Axis
from transplanter.machine.kinematics.base import Kinematics, ReachReport, UnreachableError

__all__ = [
    "Axis",
    "Kinematics",
    "KINDS",
    "ReachReport",
    "UnknownKind",
    "UnreachableError",
    "kinematics_class",
    "register",
]

KINDS: dict[str, str] = {
    "delta": "transplanter.machine.kinematics.delta:DeltaKinematics",
    "fivebar": "transplanter.machine.kinematics.fivebar:FiveBarKinematics",
    "gantry": "transplanter.machine.kinematics.gantry:GantryKinematics",
    "serial4": "transplanter.machine.kinematics.serial4:Serial4Kinematics",
}
"""kind -> "module:Class" of every arm the package ships."""

_REGISTERED: dict[str, type[Kinematics]] = {}


class UnknownKind(TransplanterError, ValueError):
    """A kind name no registry knows."""


def register(kind: str, cls: type[Kinematics]) -> None:
    """Make ``cls`` the kinematics of ``kind`` (replacing one registered before)."""
    if not (isinstance(cls, type) and issubclass(cls, Kinematics)):
        raise TypeError(f"register({kind!r}, ...) needs a Kinematics subclass, got {cls!r}")
    _REGISTERED[kind] = cls


def known_kinds() -> list[str]:
    """Every kind that :func:`kinematics_class` can create, sorted."""
    return sorted(set(KINDS) | set(_REGISTERED))


def kinematics_class(kind: str) -> type[Kinematics]:
    """The class of a kind of arm; UnknownKind naming the known ones otherwise."""
    if kind in _REGISTERED:
        return _REGISTERED[kind]
    if kind not in KINDS:
        raise UnknownKind(f"unknown robot kind {kind!r}; known kinds: {', '.join(known_kinds())}")
    module, _, name = KINDS[kind].partition(":")
    return getattr(importlib.import_module(module), name)
