"""Seed 002's claws on their test bench: 64 picks a run, each plug drawn in its moisture
band; the bench moves the claws itself (no robot)."""

from __future__ import annotations

from dataclasses import dataclass

from transplanter.kinds.interfaces import ALL
from transplanter.kinds.sections import Section, key

NAME = "plug_bench"
SUMMARY = "the plug claws on their test bench, one seedling a pick (seed 002)"
WORKCELL = ""  # the bench builds its own scene (transplanter.scene.plug_bench)
UNIT = "seedlings"
RUN = "transplanter.runs.plug_bench"
UNITS_KEY = "scenario.seedlings"


def uses_robot() -> bool:
    return False


def refusal(robot: str, effector: str) -> str | None:
    if effector != "plug_claws":
        return "the bench tests the plug_claws effector only"
    return None


def reads(robot: str, effector: str) -> dict:
    # its own timestep (plug_bench.timestep_ms), not [physics]'s
    return {"scenario": ("seedlings",), "plug_bench": ALL, "plugs": ALL}


def runner(robot: str) -> str:
    return "transplanter.twin.plug_bench_trial:run_bench_trial"


@dataclass(frozen=True)
class PlugBenchSection:
    """[plug_bench]: the claws' test bench job (`[workcell] kind = "plug_bench"`; read only by
    transplanter.twin.plug_bench_trial): `scenario.seedlings` picks, one seedling each, on the
    bench of transplanter.scene.plug_bench, as the paper's end-effector tests (64 a run).
    Optional: the defaults are estimates (docs/plug_claws.md)."""

    extraction_accel_m_s2: float = key("float", 1, 200, doc="lift's peak (paper's factor C)")
    move_accel_m_s2: float = key("float", 1, 200, doc="peak of the move to the target cell")
    moisture_band_pct: float = key("float", 0, 40, doc="moisture drawn in its level +- half")
    vigour_cv_pct: float = key("float", 0, 50, doc="spread of the seedlings' root growth")
    pose_judgement: bool = key("bool", doc="turn the claws by the seedling's leaf layout")
    fixed_rotary_rad: float = key("float", 0, 90, doc="rotary setting without pose judgement")
    timestep_s: float = key("float", 0.1, 2, doc="physics step")


_PLUG_BENCH_DEFAULTS = {
    "extraction_accel_m_s2": 10.0,
    "move_accel_m_s2": 10.0,
    "moisture_band_pct": 10.0,
    "vigour_cv_pct": 15.0,
    "pose_judgement": True,
    "fixed_rotary_deg": 0.0,
    "timestep_ms": 1.0,
}


SECTIONS = {
    "plug_bench": Section(
        PlugBenchSection,
        defaults=_PLUG_BENCH_DEFAULTS,
        file_keys={
            "extraction_accel_m_s2": "extraction_accel_m_s2",
            "move_accel_m_s2": "move_accel_m_s2",
        },
    ),
}
"""Its own sections (transplanter.kinds.sections)."""
