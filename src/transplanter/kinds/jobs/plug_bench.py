"""Seed 002's claws on their test bench: 64 picks a run, each plug drawn in its moisture
band; the bench moves the claws itself (no robot)."""

from __future__ import annotations

from transplanter.kinds.interfaces import ALL

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
