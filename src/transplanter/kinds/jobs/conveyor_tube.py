"""The pot line of seed 000: paper-pot seedlings in rows on a feeding conveyor, each picked
into a drop tube. The five-bar does it through its PGF (the taught EEPROM image) and is
judged seedling by seedling (`transplanter.twin.judge`); the delta and the serial arm do it
through generated host programs with their own judges (`twin.delta_pots`,
`twin.serial_pots`) until the one twin loop takes them over."""

from __future__ import annotations

from transplanter.kinds.interfaces import ALL

NAME = "conveyor_tube"
SUMMARY = "paper pots in rows on a feeding conveyor into a drop tube (seed 000)"
WORKCELL = "transplanter.scene.workcells.conveyor_tube"
UNIT = "seedlings"
UNITS_KEY = "scenario.seedlings"

_EFFECTOR = {"fivebar": "parallel_jaw", "delta": "fuzzy_gripper", "serial4": "fuzzy_gripper"}
_RUNNER = {
    "fivebar": "",
    "delta": "transplanter.twin.delta_pots:run_delta_pots",
    "serial4": "transplanter.twin.serial_pots:run_serial_pots",
}
_SHOOTS = ("shoot_mass_g", "stem_sway_hz", "stem_sway_sd_hz", "stem_damping_ratio")
"""The seedlings' shoots, which only the five-bar's judge follows."""
_POTS = (
    "diameter_mm", "diameter_sd_mm", "height_mm", "height_sd_mm", "mass_g", "mass_sd_g",
    "friction", "friction_sd", "placement_sd_mm", "placement_max_mm", "mass_min_g",
    "mass_max_g", "bond_share", "bond_force_n", "bond_force_sd_log", "soft_share",
    "soft_wall_mm", "crooked_share", "crooked_max_deg", "fill_gap_mm", "fill_gap_sd_mm",
    "canopy_contact", "feet", "canopy_timeconst_ms", "canopy_friction",
)  # fmt: skip
"""The pots' keys every robot's scene on the line reads (the shoots aside)."""
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
    # every pot a body (no window of live rows), the index without its drawn error
    line = {
        **_LINE,
        "conveyor": (
            "rows", "cols", "cell_pitch_mm", "row_pitch_mm", "pickup_row_y_mm",
            "index_time_s", "index_drive",
        ),
        "pots": _POTS,
        "bus": ("baud_bps",),
    }  # fmt: skip
    if robot == "delta":
        return {**line, "delta_pots": ALL, "serial_arm": ("sensor_resolution_mm",)}
    return {**line, "serial_pots": ALL}


def runner(robot: str) -> str:
    return _RUNNER.get(robot, "")


_CLI = {"delta": "transplanter.cli.delta_pots_trial", "serial4": "transplanter.cli.serial_trial"}


def cli(robot: str) -> str:
    return _CLI.get(robot, "")
