"""Shared fixtures: the paper scenario, its assembled config, its EEPROM image, an IK helper."""

from __future__ import annotations

import signal
from pathlib import Path

import numpy as np
import pytest

from transplanter.machine.kinematics import fivebar as kinematics
from transplanter.scenario.assemble import TwinConfig, assemble
from transplanter.scenario.schema import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[1]
PAPER_PATH = ROOT / "scenarios" / "paper.toml"


def pytest_configure(config):
    """A runner that ignores SIGINT (pytest-xdist's workers, a `nohup` launch) passes the
    ignore on to the command-line children the Ctrl-C tests interrupt: give this process
    Python's own handler back, so that a child starts with SIGINT's default."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def paper_scenario(**overrides) -> Scenario:
    """The paper scenario with 'section.key' overrides in file units."""
    return load_scenario(PAPER_PATH, overrides)


def paper_config(seedlings: int | None = None, preflight: bool = True, **overrides) -> TwinConfig:
    """The paper scenario's twin config, with `seedlings` and 'section.key' overrides."""
    if seedlings is not None:
        overrides["scenario.seedlings"] = seedlings
    return assemble(paper_scenario(**overrides), preflight=preflight)


def variant(tmp_path: Path, replacements: dict[str, str], name: str = "variant.toml") -> Path:
    """A copy of the paper scenario with texts replaced (each text must be there)."""
    text = PAPER_PATH.read_text()
    for old, new in replacements.items():
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture(scope="session")
def paper() -> Scenario:
    return paper_scenario()


@pytest.fixture(scope="session")
def paper_twin_config(paper) -> TwinConfig:
    return assemble(paper)


@pytest.fixture(scope="session")
def paper_eeprom(paper_twin_config):
    """The paper's EEPROM image as the PGF reads it (quantised, CRC-checked)."""
    return paper_twin_config.machine.eeprom


@pytest.fixture(scope="session")
def ik(paper_twin_config):
    """IK of the paper's arm in its working mode: ik(x_m, y_m) -> (theta1, theta2) rad."""
    arm = paper_twin_config.machine.kinematics

    def solve(x, y):
        t1, t2 = kinematics.ik(arm.geometry, np.asarray(x), np.asarray(y), mode=arm.mode)
        return float(t1), float(t2)

    return solve
