"""The kinds the scene is assembled from, one module each, created by name: a robot
(`[robot] kind`), the end effector on it (`[effector] kind`) and the workcell of the job
(`[workcell] kind`). Adding a kind adds its module and one line here.

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

from transplanter.machine.kinematics import UnknownKind

__all__ = [
    "EFFECTORS",
    "ROBOTS",
    "WORKCELLS",
    "effector",
    "judge_class",
    "robot",
    "workcell",
]

ROBOTS = {
    "fivebar": "transplanter.scene.robots.fivebar",
    "delta": "transplanter.scene.robots.delta",
    "serial4": "transplanter.scene.robots.serial4",
    "gantry": "transplanter.scene.robots.gantry",
}
EFFECTORS = {
    "parallel_jaw": "transplanter.scene.effectors.parallel_jaw",
    "plug_claws": "transplanter.scene.effectors.plug_claws",
    "fuzzy_gripper": "transplanter.scene.effectors.fuzzy_gripper",
}
WORKCELLS = {
    "conveyor_tube": "transplanter.scene.workcells.conveyor_tube",
    "plug_trays": "transplanter.scene.workcells.plug_trays",
    "pool_to_belt": "transplanter.scene.workcells.pool_to_belt",
}


def _load(table: dict[str, str], what: str, kind: str) -> ModuleType:
    if kind not in table:
        raise UnknownKind(f"unknown {what} kind {kind!r}; known kinds: {', '.join(table)}")
    return importlib.import_module(table[kind])


def robot(kind: str) -> ModuleType:
    """The scene module of a robot kind."""
    return _load(ROBOTS, "robot", kind)


def effector(kind: str) -> ModuleType:
    """The scene module of an end-effector kind."""
    return _load(EFFECTORS, "effector", kind)


def workcell(kind: str) -> ModuleType:
    """The scene module of a workcell kind."""
    return _load(WORKCELLS, "workcell", kind)


def judge_class(kind: str) -> type:
    """The judge of a workcell kind's job (its module's ``JUDGE``), imported when asked for."""
    module, _, name = workcell(kind).JUDGE.partition(":")
    return getattr(importlib.import_module(module), name)
