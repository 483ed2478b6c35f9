"""The scenario sections a kind owns: what a robot, an effector or a job reads that is its own
(`[gantry]`: the gantry's travel, belts and masses), declared in the kind's module beside its
``READS`` as ``SECTIONS = {"gantry": Section(GantrySection, defaults=..., check=...)}``.

The scenario loader (:mod:`transplanter.scenario.schema`) takes every registered kind's
sections into its schema: the file keys, units and ranges come from the section dataclass's
fields (:func:`key`), the defaults fill a section a file leaves out, the check runs on the
section's values once they are in SI. A section belongs to one kind; adding a kind with its
own section then edits no module of the loader.

Field names carry their SI unit (``x_min_m``); the file key carries the file's unit
(``x_min_mm``), found by the loader from the suffix, or named in ``Section.file_keys`` where
the suffix does not say (``settle_s`` read from ``settle_ms``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, is_dataclass
from typing import Any

__all__ = ["Key", "Section", "key", "section_problems"]


@dataclass(frozen=True)
class Key:
    """One scenario key: its kind, SI scale factor and allowed range (in file units)."""

    kind: str  # "float", "int", "bool", "str", "xy" (pair of floats), "list"
    scale: float = 1.0
    lo: float | None = None
    hi: float | None = None
    choices: tuple[str, ...] = ()
    doc: str = ""
    quantum: float | None = None
    """The smallest nonzero magnitude (file units) the firmware can carry out (a dwell's or a
    servo angle's resolution in its G-code word): anything between 0 and it is refused."""


def key(
    kind: str,
    lo: float | None = None,
    hi: float | None = None,
    doc: str = "",
    choices: tuple[str, ...] = (),
    quantum: float | None = None,
):
    """A section dataclass field that is a scenario key: its kind, allowed range (in the
    file's unit) and meaning. The file key is the field name with its file unit (the field
    `l1_m` is read from `l1_mm`), the scale follows from that unit."""
    return field(metadata={"key": Key(kind, 1.0, lo, hi, choices, doc, quantum)})


@dataclass(frozen=True)
class Section:
    """A section a kind owns.

    fields: the frozen dataclass of its keys (each a :func:`key` field, named in SI).
    defaults: {file key: value} for the keys a file may leave out (a whole section may then
        be left out); keys without a default must be given by a scenario of the kind.
    check: called with the section's SI values ({field name: value}) once each key is valid
        alone; returns what is wrong across its keys, one sentence naming them and what to do,
        or None.
    file_keys: {field name: file key} where the file key's unit is not the field's suffix.
    """

    fields: type
    defaults: Mapping[str, Any] = field(default_factory=dict)
    check: Callable[[dict[str, Any]], str | None] | None = None
    file_keys: Mapping[str, str] = field(default_factory=dict)


def section_problems(name: str, section: Any) -> list[str]:
    """What a kind's SECTIONS entry lacks ([] when it is a Section of key fields)."""
    where = f"SECTIONS[{name!r}]"
    if not isinstance(section, Section):
        return [f"{where} is not a kinds.sections.Section"]
    if not (isinstance(section.fields, type) and is_dataclass(section.fields)):
        return [f"{where}.fields is not a dataclass"]
    out = []
    for f in section.fields.__dataclass_fields__.values():
        if not isinstance(f.metadata.get("key"), Key):
            out.append(f"{where}.fields.{f.name} is not a kinds.sections.key() field")
    if section.check is not None and not callable(section.check):
        out.append(f"{where}.check is not callable")
    return out
