"""The written interfaces of the three kinds a scenario is made of: a robot, the effector on
it and the job it does (``[robot] kind``, ``[effector] kind``, ``[workcell] kind``).

A kind is a module registered by name in :mod:`transplanter.kinds` (as Klipper's
``klippy/kinematics/<name>.py`` modules and MuJoCo Playground's registered environments with
their ``default_config``). The module's names below are its interface; a test checks every
registered kind against it (:func:`problems`). A kind module is a declaration: it imports
nothing heavy, so that the scenario loader can ask it which keys it reads before anything is
built, and names the modules that implement it as ``"module"`` or ``"module:attribute"``
strings, imported only when the twin needs them.

Reads: what a kind reads of a scenario, as ``{section: keys}`` with the keys as the file
writes them (``"l1_mm"``), or :data:`ALL` for every key of the section. The loader refuses a
key given in a scenario file (its ``base`` chain included) or by ``--set`` that no kind of
the scenario reads, naming the kinds that do read it: a value the user set is the value the
run uses, or it is refused.

Key points: a job that moves a robot may name ``KEY_POINTS = "module:function"``, the points
(workcell frame, m) its tool must reach: the cells it picks from and places into, its bin,
its tube; ``transplanter.scenario.reach`` then refuses a robot whose workspace (its own
kinematics' check) holds them from no placement, with the spans compared. Optional.

Sections: a kind of any category may own scenario sections, ``SECTIONS = {name: Section}``
(:mod:`transplanter.kinds.sections`: the section's key dataclass, its defaults and its
check); the loader's schema takes them, so a kind brings its own keys. Optional: a kind that
reads only shared sections has none.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import ModuleType
from typing import Any, Protocol, runtime_checkable

__all__ = [
    "ALL",
    "EffectorKind",
    "JobKind",
    "Reads",
    "RobotKind",
    "MEMBERS",
    "problems",
]

ALL = "*"
"""Every key of a section."""

Reads = Mapping[str, "tuple[str, ...] | str"]
"""{section: its file keys read, or ALL}."""


@runtime_checkable
class RobotKind(Protocol):
    """A robot: its kinematics (the firmware's ``Kinematics``, pure numpy), its scene module
    (its Menagerie folder under models/, its links, drives and switches, its ``home``
    keyframe) and the scenario keys it reads wherever it works."""

    NAME: str
    """The ``[robot] kind`` that picks it."""
    READS: Reads
    """The keys the robot reads in every job (its own section, its controller's motion)."""
    KINEMATICS: str
    """``"module:Class"`` of its ``transplanter.machine.kinematics.Kinematics``."""
    SCENE: str
    """The module of its scene (``transplanter.scene.robots.<name>``)."""
    MODEL: str
    """Its Menagerie folder: models/<MODEL>/<MODEL>.xml."""
    CONTROLLER: str
    """What drives it: ``"sgf"`` (the five-bar's controller: G-code lines from the PGF over
    the bus, the SGF's Bresenham interpolation through the robot's kinematics, stepper
    pulses; a job's PGF program then drives any such robot), or the name of its own
    controller (``"delta"``, ``"servo"``) that its jobs' host programs drive."""
    SUMMARY: str
    """One line: what it is and where it comes from."""


@runtime_checkable
class EffectorKind(Protocol):
    """An effector: the tool on the robot's mount, its channels and actuators, its own
    controller where it has one, and the keys it reads."""

    NAME: str
    READS: Reads
    SCENE: str
    """The module of its scene (``transplanter.scene.effectors.<name>``)."""
    MODEL: str
    """Its Menagerie folder under models/effectors/ ('' where it is drawn in the robot's)."""
    SUMMARY: str


@runtime_checkable
class JobKind(Protocol):
    """A job: the workcell it is done in, what it counts, which robots and effectors can do
    it, the keys it reads with each and how a run of it is started."""

    NAME: str
    """The ``[workcell] kind`` that picks it."""
    WORKCELL: str
    """The module of its workcell's scene (``transplanter.scene.workcells.<name>``), '' for a
    bench that builds its own scene."""
    UNIT: str
    """What a run counts, plural: 'seedlings', 'cells', 'tomatoes'."""
    UNITS_KEY: str
    """The scenario key ``--seedlings N`` sets: how many units a run does."""
    RUN: str
    """The module of :mod:`transplanter.runs` that runs it (trial, render, view, export and
    the studies' rows: ``transplanter.runs.JobRun``) for every robot whose ``runner`` is not
    ''."""
    SUMMARY: str

    def uses_robot(self) -> bool:
        """Whether the job moves the scenario's robot (a bench of the effector alone does
        not: the robot's keys are then not read)."""
        ...

    def refusal(self, robot: str, effector: str) -> str | None:
        """Why this robot with this effector cannot do the job, in one line (None: it can)."""
        ...

    def reads(self, robot: str, effector: str) -> Reads:
        """The keys the job reads when this robot with this effector does it."""
        ...

    def runner(self, robot: str) -> str:
        """``"module:function"`` that runs one trial of the job with this robot, or '' for
        the twin's own trial (``transplanter.twin.trial.run_trial``)."""
        ...


_TEXT = {
    "NAME", "SCENE", "MODEL", "SUMMARY", "KINEMATICS", "CONTROLLER", "WORKCELL", "UNIT",
    "UNITS_KEY", "RUN",
}  # fmt: skip
_MAY_BE_EMPTY = {"WORKCELL", "MODEL", "CONTROLLER"}
MEMBERS: dict[str, tuple[str, ...]] = {
    "robot": ("NAME", "READS", "KINEMATICS", "SCENE", "MODEL", "CONTROLLER", "SUMMARY"),
    "effector": ("NAME", "READS", "SCENE", "MODEL", "SUMMARY"),
    "job": (
        "NAME", "WORKCELL", "UNIT", "UNITS_KEY", "SUMMARY", "RUN",
        "uses_robot", "refusal", "reads", "runner",
    ),
}  # fmt: skip
"""The members of each interface above, which :func:`problems` checks."""


def _reads_problems(where: str, reads: Any) -> list[str]:
    if not isinstance(reads, Mapping):
        return [f"{where} is not a mapping of section -> keys"]
    out = []
    for section, keys in reads.items():
        if keys == ALL:
            continue
        if not (isinstance(keys, tuple) and keys and all(isinstance(k, str) for k in keys)):
            out.append(f"{where}[{section!r}] is neither ALL nor a tuple of key names")
    return out


def problems(category: str, module: ModuleType | Any) -> list[str]:
    """What a kind module of `category` ('robot', 'effector', 'job') lacks of its interface
    ([] when it implements it): a missing or empty name, a callable that is not one, reads
    that are not {section: keys}, own sections that are not Sections of key fields."""
    from transplanter.kinds.sections import section_problems

    out = []
    if not isinstance(getattr(module, "KEY_POINTS", ""), str):
        out.append('KEY_POINTS is not a "module:function" string')
    own = getattr(module, "SECTIONS", {})
    if not isinstance(own, Mapping):
        out.append("SECTIONS is not a mapping of section -> Section")
    else:
        for name, section in own.items():
            out.extend(section_problems(name, section))
    for name in MEMBERS[category]:
        if not hasattr(module, name):
            out.append(f"has no {name}")
            continue
        value = getattr(module, name)
        if name in _TEXT:
            if not isinstance(value, str):
                out.append(f"{name} is not a string")
            elif not value and name not in _MAY_BE_EMPTY:
                out.append(f"{name} is empty")
        elif name == "READS":
            out.extend(_reads_problems("READS", value))
        elif not callable(value):
            out.append(f"{name} is not callable")
    return out
