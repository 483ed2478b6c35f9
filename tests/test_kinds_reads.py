"""What the kinds declare they read is what a run reads: every packaged job run through
`transplanter trial` for one unit (in a child process, with an offscreen GL context for the
delta's vision) while every scenario section records the keys read of it. A key a
scenario's kinds declare but its run never reads would be accepted and ignored; the loader
refuses every key outside the declarations (tests/test_kinds.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from transplanter import kinds
from transplanter.scenario import schema

PRESENTATION = {("costs", "drives_usd"), ("scenario", "description"), ("scenario", "name")}
"""Keys every scenario reads for its reports and `compare`, not its run."""

RUNS = (
    "paper",
    "paper_tuned",  # the bspline5 planner
    "gantry_pots",  # the gantry on the five-bar's pipeline
    "delta_refill",  # the vision pipeline grades the trays
    "delta_pots",
    "serial_arm",  # its ten targets, 18 gripper trials and the tomatoes
    "serial_arm_pots",
    "plug_bench",
)

TRACER = """
import dataclasses, json, sys
from transplanter.scenario import schema
read = set()
for section, cls in schema.SECTIONS.items():
    names = {f.name: schema._file_key(f.name, section) for f in dataclasses.fields(cls)}
    def getter(self, name, _section=section, _names=names):
        if name in _names:
            read.add((_section, _names[name]))
        return object.__getattribute__(self, name)
    cls.__getattribute__ = getter
from transplanter.cli import main
status = main(sys.argv[2:])
with open(sys.argv[1], "w") as f:
    json.dump(sorted(read), f)
sys.exit(status)
"""


def _traced_reads(tmp_path, argv: list[str]) -> set[tuple[str, str]]:
    """(section, file key) of every scenario key read while `transplanter ARGV` runs, in a
    child process with EGL (else OSMesa; skipped where neither makes a context)."""
    out = tmp_path / "reads.json"
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    run = None
    for backend in ("egl", "osmesa"):
        env["MUJOCO_GL"] = backend
        cmd = [sys.executable, "-c", TRACER, str(out), *argv]
        run = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=900)
        if run.returncode == 0 or "OpenGL" not in run.stderr:
            break
    else:
        pytest.skip(f"no offscreen OpenGL here (egl, osmesa): {run.stderr.strip()[-300:]}")
    assert run.returncode == 0, run.stderr[-2000:]
    return {tuple(pair) for pair in json.loads(out.read_text())}


@pytest.mark.slow
@pytest.mark.parametrize("name", RUNS)
def test_a_run_reads_every_key_its_kinds_declare(name, tmp_path):
    result = tmp_path / "r.json"
    read = _traced_reads(
        tmp_path, ["trial", name, "--seedlings", "1", "--quiet", "--json", str(result)]
    )
    sc = schema.load_scenario(name)
    declared = set()
    for section, keys in kinds.reads(sc.robot.kind, sc.effector.kind, sc.workcell.kind).items():
        names = list(schema.SCHEMA[section]) if keys == kinds.ALL else keys
        declared |= {(section, k) for k in names}
    assert sorted(declared - read - PRESENTATION) == []
    assert json.loads(result.read_text())  # the run wrote its result
