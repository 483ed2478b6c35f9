"""`transplanter --version` and `transplanter scenarios` (cli/scenarios.py)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import transplanter
from transplanter.cli import main
from transplanter.scenario.schema import packaged_scenarios

ROOT = Path(__file__).resolve().parents[1]


def test_version_is_the_packages(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"transplanter {transplanter.__version__}"
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert pyproject["project"]["version"] == transplanter.__version__


def test_scenarios_lists_every_packaged_scenario_with_its_kinds(capsys):
    assert main(["scenarios"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["scenario", "robot", "effector", "workcell", "description"]
    names = [line.split()[0] for line in lines[1:]]
    assert names == packaged_scenarios() and "paper" in names
    paper = next(line for line in lines[1:] if line.split()[0] == "paper")
    assert paper.split()[1:4] == ["fivebar", "parallel_jaw", "conveyor_tube"]
    assert "40 seedlings" in paper
    calibrated = next(line for line in lines[1:] if line.startswith("paper_calibrated "))
    assert "fitted" in calibrated
    # the columns line up: every description starts in the same column
    starts = {line.index(line.split()[4]) for line in lines}
    assert len(starts) == 1
