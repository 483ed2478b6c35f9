"""The pot line of seed 000: paper-pot seedlings in rows on a feeding conveyor, each picked
into a drop tube. The five-bar does it through its PGF (the taught EEPROM image), the delta
and the serial arm through generated host programs (`twin.delta_pots`, `twin.serial_pots`);
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

_EFFECTOR = {"fivebar": "parallel_jaw", "delta": "fuzzy_gripper", "serial4": "fuzzy_gripper"}
_RUNNER = {
    "fivebar": "",
    "delta": "transplanter.twin.delta_pots:run_delta_pots",
    "serial4": "transplanter.twin.serial_pots:run_serial_pots",
}
_LINE = {
    "scenario": ("seedlings",),
    "drop_tube": ALL,
    "physics": ("timestep_ms",),
}


def uses_robot() -> bool:
    return True


def refusal(robot: str, effector: str) -> str | None:
    wanted = _EFFECTOR.get(robot)
    if wanted is None:
        return f"no host program drives the {robot} robot on the pot line"
    if effector != wanted:
        return f"the {robot} robot does the pot line with the {wanted} effector only"
    return None


def reads(robot: str, effector: str) -> dict:
    if robot == "fivebar":  # its PGF, its bus and the seedling judge
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
    return _RUNNER.get(robot, "")
