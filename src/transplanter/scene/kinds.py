"""The scene modules of the kinds a scene is assembled from: a robot (`[robot] kind`), the
end effector on it (`[effector] kind`) and the workcell of the job (`[workcell] kind`), each
found through the one registry, :mod:`transplanter.kinds` (a robot's and an effector's
``SCENE``, a job's ``WORKCELL``). Adding a kind adds its modules and its line there; nothing
here names one.

A robot module has ``MODEL`` (its folder, models/<MODEL>/<MODEL>.xml), ``INERTIAL_BODIES``,
``ACTUATORS`` (its drives' actuator names: transplanter.twin.motors meters them),
``apply(spec, cfg)``, ``apply_inertials(spec, cfg)``, ``home_joints(cfg)`` and ``home_ctrl(cfg)``
(its actuators' power-on commands, first in the model). An effector module has ``ACTUATORS``,
``apply(spec, cfg)``, ``add_canopy_contact(spec, cfg)``, ``home_joints(cfg)`` and
``home_ctrl(cfg)`` (its actuators follow the robot's). A workcell module has ``MODEL`` (its
folder, models/workcells/<MODEL>/<MODEL>.xml), ``apply(spec, cfg)``,
``populate(spec, cfg, seed, decor)`` (what the job puts in it: the pots of a seed),
``leaf_proxies(cfg, pots)`` (the leaves the scene tests for contact), ``home_joints(cfg)`` and
``JUDGE`` ("module:Class" of the judge of its job, see :func:`judge_class`).
"""

from __future__ import annotations

import importlib
from types import ModuleType

from transplanter import kinds as registry
from transplanter.machine.kinematics import UnknownKind

__all__ = [
    "effector",
    "has_scene",
    "judge_class",
    "robot",
    "workcell",
]


def _module(category: str, kind: str) -> str:
    """The scene module's name of a kind ('' where it has none)."""
    the_kind = registry.get(category, kind)  # UnknownKind naming the known ones
    return the_kind.WORKCELL if category == "job" else the_kind.SCENE


def _load(category: str, what: str, kind: str) -> ModuleType:
    name = _module(category, kind)
    if not name:
        raise UnknownKind(f"the {what} kind {kind!r} has no scene module")
    return importlib.import_module(name)


def has_scene(category: str, kind: str) -> bool:
    """Whether the kind ('robot', 'effector' or 'job') is registered with a scene module (a
    kinematics registered alone, for `ik` and `plan`, has none)."""
    try:
        return bool(_module(category, kind))
    except UnknownKind:
        return False


def robot(kind: str) -> ModuleType:
    """The scene module of a robot kind."""
    return _load("robot", "robot", kind)


def effector(kind: str) -> ModuleType:
    """The scene module of an end-effector kind."""
    return _load("effector", "effector", kind)


def workcell(kind: str) -> ModuleType:
    """The scene module of a workcell kind (its job's ``WORKCELL``)."""
    return _load("job", "workcell", kind)


def judge_class(kind: str) -> type:
    """The judge of a workcell kind's job (its module's ``JUDGE``), imported when asked for."""
    module, _, name = workcell(kind).JUDGE.partition(":")
    return getattr(importlib.import_module(module), name)
