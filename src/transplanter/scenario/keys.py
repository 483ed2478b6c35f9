"""The key reference (`transplanter keys [SCENARIO]`, docs/keys.md): every scenario key with
its unit, range or choices, default and meaning, from the schema (`scenario.schema.SCHEMA`)
and the kinds' declared reads (`transplanter.kinds`).

For a scenario: the keys its kinds (robot, effector, job) read, each with the value the
scenario gives it (file units), so a user sees what a run of it can be changed by, and
nothing else (a key its kinds do not read is refused by every command). Without one: every
key of every section, each with who reads it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, is_dataclass
from typing import Any

from transplanter import kinds
from transplanter.scenario import schema

__all__ = ["KeyRow", "all_key_rows", "format_keys", "markdown", "scenario_key_rows"]

_UNITS = {"_ms": "ms", "_s": "s", "_mm": "mm", "_deg": "deg", "_g": "g"}


@dataclass(frozen=True)
class KeyRow:
    """One key: `section.key` (file units), its kind, unit, range or choices, default
    (None: required, given by every scenario of the kinds that read it), the value in the
    scenario (None without one), who reads it and its meaning."""

    section: str
    key: str
    kind: str
    unit: str
    allowed: str
    default: Any
    value: Any
    readers: str
    doc: str

    @property
    def dotted(self) -> str:
        return f"{self.section}.{self.key}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "key": self.dotted,
            "kind": self.kind,
            "unit": self.unit,
            "allowed": self.allowed,
            "default": self.default,
            "value": self.value,
            "read_by": self.readers,
            "doc": self.doc,
        }


def _unit(key: str) -> str:
    """The file unit a key's suffix names ('' for none): `z_low_mm` -> 'mm'."""
    unit = schema._unit_of(key)
    if unit is None:
        return ""
    return _UNITS.get(unit, unit.lstrip("_").replace("_", "/"))


def _number(v: float) -> str:
    if isinstance(v, int):
        return str(v)
    return str(int(v)) if float(v).is_integer() and abs(v) < 1e15 else f"{v:g}"


def _allowed(spec: schema.Key) -> str:
    if spec.choices:
        return " | ".join(spec.choices)
    if spec.lo is None and spec.hi is None:
        return ""
    lo = "" if spec.lo is None else _number(spec.lo)
    hi = "" if spec.hi is None else _number(spec.hi)
    return f"{lo} .. {hi}"


def _file_value(spec: schema.Key, value: Any) -> Any:
    """A section field's value (SI) in the key's file unit (the taught pickups: a table each,
    as the file gives them)."""
    if isinstance(value, tuple) and value and is_dataclass(value[0]):
        return [
            {k: _file_value(sub, getattr(item, schema.si_key(k))) for k, sub in
             schema.PICKUP_SCHEMA.items()}
            for item in value
        ]  # fmt: skip
    if isinstance(value, bool) or spec.scale == 1.0:
        return list(value) if isinstance(value, tuple) else value
    if isinstance(value, tuple | list):
        return [_file_value(spec, v) for v in value]
    if isinstance(value, float | int) and math.isfinite(value):
        return round(value / spec.scale, 9)
    return value


def _row(section: str, key: str, value: Any, readers: str) -> KeyRow:
    spec = schema.SCHEMA[section][key]
    return KeyRow(
        section=section,
        key=key,
        kind=spec.kind,
        unit=_unit(key),
        allowed=_allowed(spec),
        default=schema.DEFAULT_SECTIONS.get(section, {}).get(key),
        value=value,
        readers=readers,
        doc=spec.doc,
    )


def scenario_key_rows(scenario) -> list[KeyRow]:
    """The keys a loaded scenario's kinds read, in the schema's order, each with its value."""
    table = kinds.reads(scenario.robot.kind, scenario.effector.kind, scenario.workcell.kind)
    rows = []
    for section, keys in schema.SCHEMA.items():
        read = table.get(section)
        if read is None:
            continue
        values = getattr(scenario, "meta" if section == "scenario" else section)
        for key, spec in keys.items():
            if read != kinds.ALL and key not in read:
                continue
            value = _file_value(spec, getattr(values, schema.si_key(key)))
            rows.append(_row(section, key, value, ", ".join(kinds.readers(section, key))))
    return rows


def all_key_rows() -> list[KeyRow]:
    """Every key of every section, with who reads it (no value)."""
    return [
        _row(section, key, None, ", ".join(kinds.readers(section, key)) or "no kind")
        for section, keys in schema.SCHEMA.items()
        for key in keys
    ]


def _shown(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return _number(v)
    if isinstance(v, list):
        return "[" + ", ".join(_shown(x) for x in v) + "]"
    return str(v)


def format_keys(rows: list[KeyRow], title: str) -> str:
    """The rows as text, a block per section: key, unit, range, default, value, meaning."""
    lines = [title]
    width = max((len(r.key) for r in rows), default=10)
    section = None
    for r in rows:
        if r.section != section:
            section = r.section
            lines.append(f"[{section}]")
        value = f" = {_shown(r.value)}" if r.value is not None else ""
        default = f"default {_shown(r.default)}" if r.default is not None else "no default"
        allowed = f" {r.allowed}" if r.allowed else ""
        unit = f" {r.unit}" if r.unit else ""
        who = f"; read by {r.readers}" if r.value is None else ""
        lines.append(f"  {r.key:<{width}}{value}  ({r.kind}{unit}{allowed}; {default}{who})")
        if r.doc:
            lines.append(f"  {'':<{width}}  {r.doc}")
    return "\n".join(lines) + "\n"


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def markdown() -> str:
    """docs/keys.md: every key, a table per section (`transplanter keys --markdown`)."""
    out = [
        "# Every scenario key",
        "",
        "Generated by `transplanter keys --markdown > docs/keys.md` from the schema and the",
        "kinds' declared reads (`tests/test_keys.py` checks it is current). A scenario's own",
        "keys with their values: `transplanter keys SCENARIO`. A key no kind of a scenario",
        "reads is refused by every command, naming who reads it. Units are in the key's",
        "name (`_mm`, `_deg`, `_s`, `_ms`, `_g`, ...); ranges are in those units.",
        "",
    ]
    section = None
    for r in all_key_rows():
        if r.section != section:
            section = r.section
            owner = schema.KIND_SECTIONS.get(section, ("",))[0]
            out += ["", f"## [{section}]", ""]
            if owner:
                out += [f"Declared by {owner} (its kind module's `SECTIONS`).", ""]
            out += ["| key | kind | unit | allowed | default | read by | meaning |",
                    "| --- | --- | --- | --- | --- | --- | --- |"]  # fmt: skip
        out.append(
            f"| `{r.key}` | {r.kind} | {r.unit} | {_cell(r.allowed)} | "
            f"{_cell(_shown(r.default))} | {_cell(r.readers)} | {_cell(r.doc)} |"
        )
    return "\n".join(out) + "\n"
