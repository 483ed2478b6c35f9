"""Arm kinematics, one module per kind of arm, created by name (as Klipper loads
``klippy/kinematics/<name>.py`` and RepRapFirmware creates a ``Kinematics`` by type).

A scenario's ``[robot] kind`` names a robot kind of the one registry,
:mod:`transplanter.kinds`, whose ``KINEMATICS`` ("module:Class") is the class that implements
it, imported only when asked for (``kinds.kinematics_class``): adding an arm adds its module
and its robot kind's line there; this package names no kind. :func:`register` adds a
kinematics alone at run time (a test's own arm, a user's plug-in: enough for `ik` and
`plan`).
"""

from __future__ import annotations

from transplanter.errors import TransplanterError
from transplanter.machine.axes import Axis
from transplanter.machine.kinematics.base import Kinematics, ReachReport, UnreachableError

__all__ = [
    "Axis",
    "Kinematics",
    "ReachReport",
    "UnknownKind",
    "UnreachableError",
    "registered",
    "registered_kinds",
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


def registered_kinds() -> list[str]:
    """The kinds whose kinematics :func:`register` added at run time, sorted."""
    return sorted(_REGISTERED)


def registered(kind: str) -> type[Kinematics] | None:
    """The kinematics :func:`register` made `kind`'s (None: none was)."""
    return _REGISTERED.get(kind)
