"""Seed 004's tomatoes: the pool's tomatoes picked at its station and released onto a belt,
with the paper's ten targets and its 18 gripper trials on the same arm."""

from __future__ import annotations

from transplanter.kinds.interfaces import ALL

NAME = "pool_to_belt"
SUMMARY = "tomatoes from a pool onto a belt, the paper's targets and gripper trials (seed 004)"
WORKCELL = "transplanter.scene.workcells.pool_to_belt"
UNIT = "tomatoes"
RUN = "transplanter.runs.pool_to_belt"
UNITS_KEY = "pool_to_belt.count"


def uses_robot() -> bool:
    return True


def refusal(robot: str, effector: str) -> str | None:
    if robot != "serial4":
        return f"no host program drives the {robot} robot on the pool and belt"
    if effector != "fuzzy_gripper":
        return "the tomatoes are gripped by the fuzzy_gripper effector only"
    return None


def reads(robot: str, effector: str) -> dict:
    return {
        "pool_to_belt": ALL,
        # the targets' and the bench's moves, the bruise threshold
        "serial_arm": (
            "target_speed_mm_s",
            "target_settle_ms",
            "bruise_force_n",
            "bench_radius_mm",
            "bench_height_mm",
        ),
        "bus": ("baud_bps",),
        "physics": ("timestep_ms",),
    }


def runner(robot: str) -> str:
    return "transplanter.twin.serial_arm:run_serial_arm"
