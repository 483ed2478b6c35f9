"""The pot line of seed 000: paper-pot seedlings in rows on a feeding conveyor, each picked
into a drop tube. A robot on the five-bar's controller (`CONTROLLER = "sgf"`: the five-bar,
the gantry, any robot added so) does it through the PGF (the taught EEPROM image) with the
parallel jaws; the delta and the serial arm through generated host programs for their own
controllers (`twin.delta_pots`, `twin.serial_pots`);
every robot on it is judged seedling by seedling by the one judge (`transplanter.twin.judge`:
the shoots, every failure kind, damage)."""

from __future__ import annotations

from transplanter.kinds.interfaces import ALL

NAME = "conveyor_tube"
SUMMARY = "paper pots in rows on a feeding conveyor into a drop tube (seed 000)"
WORKCELL = "transplanter.scene.workcells.conveyor_tube"
UNIT = "seedlings"
RUN = "transplanter.runs.pot_line"
UNITS_KEY = "scenario.seedlings"

PGF_EFFECTOR = "parallel_jaw"
"""What the PGF's program drives (its M280 lines: the jaws' servo and the wrist's)."""
# the robots with a controller of their own, each with its host program and effector
_EFFECTOR = {"delta": "fuzzy_gripper", "serial4": "fuzzy_gripper"}
_RUNNER = {
    "delta": "transplanter.twin.delta_pots:run_delta_pots",
    "serial4": "transplanter.twin.serial_pots:run_serial_pots",
}


def _on_the_pgf(robot: str) -> bool:
    """Whether the robot is driven by the five-bar's controller, so by the PGF's program."""
    from transplanter import kinds

    try:
        return kinds.robot(robot).CONTROLLER == "sgf"
    except kinds.UnknownKind:
        return False


_LINE = {
    "scenario": ("seedlings",),
    "drop_tube": ALL,
    "physics": ("timestep_ms",),
}


def uses_robot() -> bool:
    return True


def refusal(robot: str, effector: str) -> str | None:
    wanted = PGF_EFFECTOR if _on_the_pgf(robot) else _EFFECTOR.get(robot)
    if wanted is None:
        return f"no host program drives the {robot} robot on the pot line"
    if effector != wanted:
        return f"the {robot} robot does the pot line with the {wanted} effector only"
    return None


def reads(robot: str, effector: str) -> dict:
    if _on_the_pgf(robot):  # the PGF, its bus and the seedling judge
        return {
            **_LINE,
            "conveyor": ALL,
            "pots": ALL,
            "metrics": ALL,
            "taught": ALL,
            "bus": ALL,
        }
    # the same line (its window of live rows, its index error) and judge for every robot
    line = {**_LINE, "conveyor": ALL, "pots": ALL, "metrics": ALL, "bus": ("baud_bps",)}
    if robot == "delta":
        return {**line, "delta_pots": ALL, "serial_arm": ("sensor_resolution_mm",)}
    return {**line, "serial_pots": ALL}


def runner(robot: str) -> str:
    """The robot's host program's trial; '' for the PGF's (the twin's own trial)."""
    return "" if _on_the_pgf(robot) else _RUNNER.get(robot, "")
