"""The seams between the generic modules and the kinds (docs/architecture.md, "The kinds"): a
module every robot, effector and job goes through names no kind and imports no kind's own
module, so that adding a kind adds files and a registry line and edits none of these. What
still breaks the rule is listed here as debt, with the reason, so that it can only shrink."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from transplanter import kinds

SRC = Path(__file__).resolve().parents[1] / "src" / "transplanter"

GENERIC = (
    "twin/loop.py",
    "twin/judge.py",
    "twin/results.py",
    "twin/motors.py",
    "machine/host.py",
    "machine/bus.py",
    "machine/rig.py",
    "scene/handles.py",
    "scene/live_rows.py",
    "scenario/keys.py",
    "studies/compare.py",
    "studies/stats.py",
    "studies/sweep.py",
    "studies/backends.py",
    "studies/jobs.py",
    "studies/grid.py",
    "runs/__init__.py",
    "cli/trials.py",
    "viewing/loop_video.py",
    "viewing/loop_recording.py",
    "viewing/html_report.py",
    "scene/export.py",
)
"""Modules every robot, effector and job goes through (the loop, the judge, the host, the
handles, the studies, the observers)."""

KIND_MODULES = (
    "transplanter.twin.delta_",
    "transplanter.twin.serial_",
    "transplanter.twin.sim",
    "transplanter.twin.trial",
    "transplanter.scene.robots.",
    "transplanter.scene.effectors.",
    "transplanter.scene.workcells.",
    "transplanter.scene.delta_scene",
    "transplanter.scene.serial_scene",
    "transplanter.kinds.robots.",
    "transplanter.kinds.effectors.",
    "transplanter.kinds.jobs.",
    "transplanter.machine.kinematics.",
    "transplanter.machine.delta_drives",
    "transplanter.machine.fuzzy_gripper",
)
"""A kind's own modules: its twin, scene, registry entry, kinematics and drives."""

DEBT = {
    "studies/backends.py": "a run with no study job registered is the five-bar's trial, run "
    "by the backend itself (twin.trial), not through a registered job",
}
"""Generic modules that still name a kind, and why: the issue's remaining work."""


def _kind_names() -> set[str]:
    return {n for category in kinds.CATEGORIES for n in kinds.names(category)}


def offences(path: Path) -> list[str]:
    """Where a module names a kind in a string constant, or imports a kind's module."""
    names = _kind_names()
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in names:
            out.append(f"line {node.lineno}: the kind {node.value!r}")
        modules = []
        if isinstance(node, ast.ImportFrom) and node.module:
            modules = [node.module]
        elif isinstance(node, ast.Import):
            modules = [a.name for a in node.names]
        out += [f"line {node.lineno}: imports {m}" for m in modules if m.startswith(KIND_MODULES)]
    return out


@pytest.mark.parametrize("module", [m for m in GENERIC if m not in DEBT])
def test_a_generic_module_names_no_kind(module):
    found = offences(SRC / module)
    assert found == [], f"{module} names a kind: {'; '.join(found)} (register it instead)"


def test_the_debt_is_still_owed():
    """Each listed debt is a generic module that still breaks the rule (else strike it off
    the list: the rule then holds for it)."""
    for module, why in DEBT.items():
        assert module in GENERIC
        assert offences(SRC / module), f"{module} no longer names a kind: remove it from DEBT"
        assert why


def test_the_check_sees_a_kind_named_or_imported(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text('from transplanter.twin.delta_pots import run_delta_pots\nKIND = "delta"\n')
    assert offences(bad) == [
        "line 1: imports transplanter.twin.delta_pots",
        "line 2: the kind 'delta'",
    ]
