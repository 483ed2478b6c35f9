"""Seed 004's tomatoes: the pool's tomatoes picked at its station and released onto a belt,
with the paper's ten targets and its 18 gripper trials on the same arm."""

from __future__ import annotations

import math
from dataclasses import dataclass

from transplanter.kinds.interfaces import ALL
from transplanter.kinds.sections import Section, key

NAME = "pool_to_belt"
SUMMARY = "tomatoes from a pool onto a belt, the paper's targets and gripper trials (seed 004)"
WORKCELL = "transplanter.scene.workcells.pool_to_belt"
UNIT = "tomatoes"
RUN = "transplanter.runs.pool_to_belt"
KEY_POINTS = "transplanter.runs.pool_to_belt:key_points"
"""Where its tool must go (`scenario.reach`: the robot reaches them from some placement)."""
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


@dataclass(frozen=True)
class PoolToBeltSection:
    """[pool_to_belt]: the serial arm's pick-and-place workcell (`[workcell] kind =
    "pool_to_belt"`): the tomatoes queued in the sloping lane, sensor 1 across the pick
    station, the belt conveyor (`transplanter.scene.workcells.pool_to_belt.PoolToBeltConfig`,
    whose fields these are). Optional: the defaults are estimates (docs/serial_arm.md)."""

    count: int = key("int", lo=1, hi=20, doc="tomatoes queued in the pool")
    diameter_min_m: float = key("float", 20, 120, doc="smallest tomato diameter drawn")
    diameter_max_m: float = key("float", 20, 120, doc="largest tomato diameter drawn")
    mass_min_kg: float = key("float", 5, 1000, doc="lightest tomato (density x volume, clipped)")
    mass_max_kg: float = key("float", 5, 1000, doc="heaviest tomato")
    density_kg_m3: float = key("float", 500, 1500, doc="tomato density")
    friction_low: float = key("float", 0, 3, doc="skin-pad friction, lowest drawn")
    friction_high: float = key("float", 0, 3, doc="skin-pad friction, highest drawn")
    contact_timeconst_s: float = key("float", 2, 100, doc="a tomato's contact time constant")
    rolling_resistance_m: float = key("float", 0, 10, doc="lane's and belt's rolling friction")
    station_x_m: float = key("float", -160, 160, doc="pick station (a middle tomato's centre)")
    station_y_m: float = key("float", -160, 160, doc="pick station's y: the lane's centre line")
    lane_floor_z_m: float = key("float", 0, 200, doc="trough bottom at the stop above the floor")
    lane_slope_rad: float = key("float", 0.5, 20, doc="lane's slope down to the stop")
    trough_angle_rad: float = key("float", 3, 45, doc="trough faces' sideways rise")
    lane_half_width_m: float = key("float", 10, 100, doc="trough rim from the centre line")
    stop_height_m: float = key("float", 1, 100, doc="stop tab above the trough bottom")
    sensor_offset_m: float = key("float", 10, 300, doc="sensor 1's face from the lane's line")
    place_angle_rad: float = key("float", -90, 90, doc="base angle theta1 of the place spot")
    place_radius_m: float = key("float", 20, 160, doc="place spot from the base axis")
    belt_top_z_m: float = key("float", 0, 200, doc="belt's top face above the floor")
    belt_width_m: float = key("float", 20, 300, doc="between the belt's side walls")
    belt_sidewall_height_m: float = key("float", 0, 100, doc="side walls above the belt")
    belt_speed_m_s: float = key("float", 1, 500, doc="belt speed")
    cycle_s: float = key("float", 0.5, 120, doc="pick-and-place time the belt's length is for")
    release_gap_m: float = key("float", 0, 100, doc="tomato's bottom above the belt at release")


_POOL_TO_BELT_DEFAULTS = {
    "count": 6,
    "diameter_min_mm": 50.0,
    "diameter_max_mm": 70.0,
    "mass_min_g": 70.0,
    "mass_max_g": 150.0,
    "density_kg_m3": 1000.0,
    "friction_low": 0.4,
    "friction_high": 0.8,
    "contact_timeconst_ms": 8.0,
    "rolling_resistance_mm": 1.0,
    "station_x_mm": 115.0,
    "station_y_mm": 0.0,
    "lane_floor_z_mm": 20.0,
    "lane_slope_deg": 5.0,
    "trough_angle_deg": 12.0,
    "lane_half_width_mm": 40.0,
    "stop_height_mm": 30.0,
    "sensor_offset_mm": 55.0,
    "place_angle_deg": 90.0,
    "place_radius_mm": 115.0,
    "belt_top_z_mm": 25.0,
    "belt_width_mm": 80.0,
    "belt_sidewall_height_mm": 20.0,
    "belt_speed_mm_s": 25.0,
    "cycle_s": 12.0,
    "release_gap_mm": 10.0,
}


def _check(p: dict) -> str | None:
    for lo, hi, lo_file, hi_file in (
        ("diameter_min_m", "diameter_max_m", "diameter_min_mm", "diameter_max_mm"),
        ("mass_min_kg", "mass_max_kg", "mass_min_g", "mass_max_g"),
        ("friction_low", "friction_high", "friction_low", "friction_high"),
    ):
        if p[lo] > p[hi]:
            return f"pool_to_belt.{lo_file} must not be above pool_to_belt.{hi_file}."
    d_max = p["diameter_max_m"]
    if p["sensor_offset_m"] <= d_max / 2:
        return (
            f"pool_to_belt.sensor_offset_mm = {p['sensor_offset_m'] * 1e3:g} mm: sensor 1 would "
            f"stand inside the largest tomato (radius {d_max / 2 * 1e3:g} mm); move it out."
        )
    if p["belt_width_m"] <= d_max:
        return (
            f"pool_to_belt.belt_width_mm = {p['belt_width_m'] * 1e3:g} mm: the largest tomato "
            f"({d_max * 1e3:g} mm, pool_to_belt.diameter_max_mm) does not fit between the "
            "belt's side walls; widen the belt."
        )
    reach = d_max / 2 * math.sin(p["trough_angle_rad"])
    if p["lane_half_width_m"] <= reach:
        return (
            f"pool_to_belt.lane_half_width_mm = {p['lane_half_width_m'] * 1e3:g} mm: the "
            f"largest tomato rests on the trough's faces {reach * 1e3:.1f} mm from the centre "
            "line, beyond their rims; widen the trough."
        )
    return None


SECTIONS = {
    "pool_to_belt": Section(
        PoolToBeltSection,
        defaults=_POOL_TO_BELT_DEFAULTS,
        check=_check,
        file_keys={"contact_timeconst_s": "contact_timeconst_ms"},
    ),
}
"""Its own sections (transplanter.kinds.sections)."""
