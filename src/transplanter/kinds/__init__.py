"""The registry of the twin's kinds: robots, effectors and jobs, each a module behind the
written interface of :mod:`transplanter.kinds.interfaces`, created by name (``[robot] kind``,
``[effector] kind``, ``[workcell] kind``), as Klipper loads ``klippy/kinematics/<name>.py``.

Adding a kind adds its module and one line in its table here. A kind module is a
declaration (no MuJoCo, no physics imported): what it reads of a scenario and the modules
that implement it, so the loader can refuse a key that no kind of a scenario reads before
anything is built (:func:`unread_keys`). A kind's own scenario sections are declared in
its module too (``SECTIONS``, :mod:`transplanter.kinds.sections`) and join the loader's
schema from here (:func:`own_sections`). :func:`register` adds a kind at run time (a user's
plug-in, a test's own gantry).
"""

from __future__ import annotations

import difflib
import importlib
import sys
from collections.abc import Iterable, Mapping
from types import ModuleType
from typing import Any

from transplanter.kinds.interfaces import ALL, Reads, problems
from transplanter.kinds.sections import Section
from transplanter.machine.kinematics import UnknownKind

__all__ = [
    "ALL",
    "CATEGORIES",
    "EFFECTORS",
    "JOBS",
    "ROBOTS",
    "SHARED_READS",
    "UnknownKind",
    "effector",
    "get",
    "job",
    "kinematics_class",
    "known_kinematics",
    "names",
    "reads",
    "readers",
    "register",
    "robot",
    "own_sections",
    "describe_unread",
    "unread_keys",
]

ROBOTS: dict[str, str] = {
    "fivebar": "transplanter.kinds.robots.fivebar",
    "delta": "transplanter.kinds.robots.delta",
    "serial4": "transplanter.kinds.robots.serial4",
    "gantry": "transplanter.kinds.robots.gantry",
}
EFFECTORS: dict[str, str] = {
    "parallel_jaw": "transplanter.kinds.effectors.parallel_jaw",
    "plug_claws": "transplanter.kinds.effectors.plug_claws",
    "fuzzy_gripper": "transplanter.kinds.effectors.fuzzy_gripper",
}
JOBS: dict[str, str] = {
    "conveyor_tube": "transplanter.kinds.jobs.conveyor_tube",
    "plug_trays": "transplanter.kinds.jobs.plug_trays",
    "pool_to_belt": "transplanter.kinds.jobs.pool_to_belt",
    "plug_bench": "transplanter.kinds.jobs.plug_bench",
}
CATEGORIES: dict[str, tuple[str, dict[str, str]]] = {
    "robot": ("robot", ROBOTS),
    "effector": ("effector", EFFECTORS),
    "job": ("workcell", JOBS),
}
"""category -> (the scenario section whose `kind` picks it, its table)."""

SHARED_READS: dict[str, Any] = {
    "scenario": ("name", "description", "seed"),
    "robot": ("kind",),
    "effector": ("kind",),
    "workcell": ("kind",),
    "physics": ("sleep",),
    "costs": ALL,
}
"""What every run reads, whatever its kinds: its name and seed, the three kinds, whether
resting bodies may sleep (every job refuses what it cannot honour) and the costs that
`transplanter compare` reports."""

_REGISTERED: dict[str, dict[str, Any]] = {c: {} for c in CATEGORIES}


def register(category: str, name: str, kind: ModuleType | Any) -> None:
    """Make `kind` (a module or an object with the interface's names) the `category` kind
    `name` (replacing one registered before); TypeError naming what it lacks."""
    if category not in CATEGORIES:
        raise ValueError(f"unknown category {category!r}; one of {', '.join(CATEGORIES)}")
    missing = problems(category, kind)
    if missing:
        raise TypeError(f"the {category} kind {name!r} " + "; ".join(missing))
    before = _REGISTERED[category].get(name)
    _REGISTERED[category][name] = kind
    loader = sys.modules.get("transplanter.scenario.schema")
    if loader is not None:  # its schema takes the kind's own sections (a clash undoes it)
        try:
            loader.add_kind_sections()
        except Exception:
            if before is None:
                del _REGISTERED[category][name]
            else:
                _REGISTERED[category][name] = before
            loader.add_kind_sections()
            raise


def own_sections() -> dict[str, tuple[str, Section]]:
    """{section: (its owner, 'the gantry robot'; its Section)} of every kind's own sections;
    ValueError for a section two kinds declare."""
    out: dict[str, tuple[str, Section]] = {}
    for category in CATEGORIES:
        for name in names(category):
            for section, declared in getattr(get(category, name), "SECTIONS", {}).items():
                owner = f"the {name} {category}"
                if section in out:
                    raise ValueError(
                        f"the [{section}] section is declared by {out[section][0]} and by "
                        f"{owner}: a section belongs to one kind; rename one"
                    )
                out[section] = (owner, declared)
    return out


def _kinematics_only() -> list[str]:
    """Robot kinds whose kinematics alone was registered at run time
    (`machine.kinematics.register`): enough for `ik` and `plan`, no scene and no job."""
    from transplanter.machine.kinematics import registered_kinds

    return [k for k in registered_kinds() if k not in ROBOTS and k not in _REGISTERED["robot"]]


class _KinematicsOnly:
    """A robot kind made of a kinematics registered at run time: it reads no section of its
    own (its `from_scenario` reads what it reads), has no scene and does no job."""

    def __init__(self, name: str) -> None:
        self.NAME = name
        self.READS: dict[str, Any] = {}
        self.KINEMATICS = f"transplanter.machine.kinematics:{name}"
        self.SCENE = ""
        self.MODEL = ""
        self.CONTROLLER = ""
        self.SUMMARY = "a kinematics registered at run time (ik and plan only)"


def names(category: str) -> list[str]:
    """Every kind of `category` that :func:`get` can load, sorted."""
    extra = _kinematics_only() if category == "robot" else []
    return sorted({*CATEGORIES[category][1], *_REGISTERED[category], *extra})


def get(category: str, name: str) -> Any:
    """The kind module `name` of `category`; UnknownKind naming the known ones (and the
    nearest, for a misspelt name)."""
    if name in _REGISTERED[category]:
        return _REGISTERED[category][name]
    table = CATEGORIES[category][1]
    if category == "robot" and name not in table and name in _kinematics_only():
        return _KinematicsOnly(name)
    if name not in table:
        section = CATEGORIES[category][0]
        known = names(category)
        near = difflib.get_close_matches(str(name), known, n=1)
        hint = f"; did you mean {near[0]!r}?" if near else ""
        raise UnknownKind(
            f"unknown {category} kind {name!r}; known kinds: {', '.join(known)} "
            f"({section}.kind){hint}"
        )
    return importlib.import_module(table[name])


def known_kinematics() -> list[str]:
    """Every robot kind :func:`kinematics_class` can create, sorted."""
    return [n for n in names("robot") if robot(n).KINEMATICS]


def kinematics_class(name: str) -> type:
    """The firmware's `Kinematics` class of the robot kind `name` (its ``KINEMATICS``, or the
    one `machine.kinematics.register` gave it); UnknownKind naming the known ones."""
    from transplanter.machine import kinematics as firmware

    given = firmware.registered(name)
    if given is not None:
        return given
    try:
        target = robot(name).KINEMATICS
    except UnknownKind:
        target = ""
    if not target:
        raise UnknownKind(
            f"unknown robot kind {name!r}; known kinds: {', '.join(known_kinematics())}"
        )
    module, _, attribute = target.partition(":")
    return getattr(importlib.import_module(module), attribute)


def robot(name: str) -> Any:
    return get("robot", name)


def effector(name: str) -> Any:
    return get("effector", name)


def job(name: str) -> Any:
    return get("job", name)


def _add(out: dict[str, Any], more: Reads) -> None:
    for section, keys in more.items():
        have = out.get(section, ())
        if keys == ALL or have == ALL:
            out[section] = ALL
        else:
            out[section] = tuple(dict.fromkeys((*have, *keys)))


def reads(robot_kind: str, effector_kind: str, job_kind: str) -> dict[str, Any]:
    """{section: keys or ALL} a scenario of these kinds reads: the shared keys, the robot's
    (when the job moves it), the effector's and the job's with this robot and effector."""
    the_job = job(job_kind)
    out: dict[str, Any] = {}
    _add(out, SHARED_READS)
    if the_job.uses_robot():
        _add(out, robot(robot_kind).READS)
    _add(out, effector(effector_kind).READS)
    _add(out, the_job.reads(robot_kind, effector_kind))
    return out


def _reads_key(table: Mapping[str, Any], section: str, key: str) -> bool:
    keys = table.get(section)
    return keys is not None and (keys == ALL or key in keys)


def readers(section: str, key: str) -> list[str]:
    """Who reads `section.key`: 'every scenario', 'the delta robot', 'the plug_trays job'
    or 'the conveyor_tube job with the delta robot'."""
    if _reads_key(SHARED_READS, section, key):
        return ["every scenario"]
    out = []
    for category in ("robot", "effector"):
        for name in names(category):
            if _reads_key(get(category, name).READS, section, key):
                out.append(f"the {name} {category}")
    for name in names("job"):
        the_job = job(name)
        with_robots = [
            r
            for r in names("robot")
            if the_job.refusal(r, _any_effector(the_job, r)) is None
            and _reads_key(the_job.reads(r, _any_effector(the_job, r)), section, key)
        ]
        if not with_robots:
            continue
        able = [r for r in names("robot") if the_job.refusal(r, _any_effector(the_job, r)) is None]
        if set(with_robots) == set(able) or not the_job.uses_robot():
            out.append(f"the {name} job")
        else:
            out.append(f"the {name} job with the {' or '.join(with_robots)} robot")
    return out


def _any_effector(the_job: Any, robot_kind: str) -> str:
    """An effector with which `robot_kind` can do the job ('' if none)."""
    for name in names("effector"):
        if the_job.refusal(robot_kind, name) is None:
            return name
    return ""


def unread_keys(
    given: Mapping[str, Iterable[str]], robot_kind: str, effector_kind: str, job_kind: str
) -> list[tuple[str, str, str]]:
    """(section, key, who reads it) for each key of `given` ({section: file keys}) that a
    scenario of these kinds does not read; [] when every key is read."""
    table = reads(robot_kind, effector_kind, job_kind)
    out = []
    for section in given:
        for key in given[section]:
            if _reads_key(table, section, key):
                continue
            who = readers(section, key)
            out.append((section, key, ", ".join(who) if who else "no kind"))
    return out


def describe_unread(unread: Iterable[tuple[str, str, str]], limit: int = 6) -> str:
    """The unread keys grouped by section and reader: '[arm] l0_mm, l1_mm (read by the
    fivebar robot)'; a whole section in one line, at most `limit` groups named."""
    groups: dict[tuple[str, str], list[str]] = {}
    for section, key, who in unread:
        groups.setdefault((section, who), []).append(key)
    parts = []
    for (section, who), keys in groups.items():
        shown = ", ".join(keys[:3] if len(keys) > 4 else keys)
        if len(keys) > 4:
            shown += f" and {len(keys) - 3} more"
        parts.append(f"[{section}] {shown} (read by {who})")
    if len(parts) > limit:
        parts = [*parts[:limit], f"and {len(parts) - limit} more sections"]
    return "; ".join(parts)
