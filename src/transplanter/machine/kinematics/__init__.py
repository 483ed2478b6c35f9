"""Arm kinematics, one module per kind of arm, created by name (as Klipper loads
``klippy/kinematics/<name>.py`` and RepRapFirmware creates a ``Kinematics`` by type).

A scenario's ``[robot] kind`` names a robot kind of the one registry,
:mod:`transplanter.kinds`, whose ``KINEMATICS`` ("module:Class") is the class that implements
it, imported only when asked for: adding an arm adds its module and its robot kind's line
there. :func:`register` adds a kinematics alone at run time (a test's own arm, a user's
plug-in: enough for `ik` and `plan`).
"""

from __future__ import annotations

import importlib

from transplanter.errors import TransplanterError
from transplanter.machine.axes import Axis
from transplanter.machine.kinematics.base import Kinematics, ReachReport, UnreachableError

__all__ = [
    "Axis",
    "Kinematics",
    "ReachReport",
    "UnknownKind",
    "UnreachableError",
    "kinematics_class",
    "register",
]

_REGISTERED: dict[str, type[Kinematics]] = {}


class UnknownKind(TransplanterError, ValueError):
    """A kind name no registry knows."""


def register(kind: str, cls: type[Kinematics]) -> None:
    """Make ``cls`` the kinematics of ``kind`` (replacing one registered before)."""
    if not (isinstance(cls, type) and issubclass(cls, Kinematics)):
        raise TypeError(f"register({kind!r}, ...) needs a Kinematics subclass, got {cls!r}")
    _REGISTERED[kind] = cls


def _shipped() -> dict[str, str]:
    """kind -> "module:Class" of every robot kind of the registry that has a kinematics."""
    from transplanter import kinds  # declarations only: no scene, no physics

    out = {}
    for name in kinds.names("robot"):
        if name in _REGISTERED:
            continue
        target = kinds.robot(name).KINEMATICS
        if target and not target.startswith(f"{__name__}:"):
            out[name] = target
    return out


def registered_kinds() -> list[str]:
    """The kinds whose kinematics :func:`register` added at run time, sorted."""
    return sorted(_REGISTERED)


def known_kinds() -> list[str]:
    """Every kind that :func:`kinematics_class` can create, sorted."""
    return sorted(set(_shipped()) | set(_REGISTERED))


def kinematics_class(kind: str) -> type[Kinematics]:
    """The class of a kind of arm; UnknownKind naming the known ones otherwise."""
    if kind in _REGISTERED:
        return _REGISTERED[kind]
    shipped = _shipped()
    if kind not in shipped:
        raise UnknownKind(f"unknown robot kind {kind!r}; known kinds: {', '.join(known_kinds())}")
    module, _, name = shipped[kind].partition(":")
    return getattr(importlib.import_module(module), name)
