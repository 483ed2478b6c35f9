"""The pot line of seed 000: paper-pot seedlings in rows on a feeding conveyor, each picked
into a drop tube. A robot on the five-bar's controller (`CONTROLLER = "sgf"`: the five-bar,
the gantry, any robot added so) does it through the PGF (the taught EEPROM image) with the
parallel jaws; the delta and the serial arm through generated host programs for their own
controllers (`twin.delta_pots`, `twin.serial_pots`);
every robot on it is judged seedling by seedling by the one judge (`transplanter.twin.judge`:
the shoots, every failure kind, damage)."""

from __future__ import annotations

from dataclasses import dataclass

from transplanter.kinds.interfaces import ALL
from transplanter.kinds.sections import Section, key

NAME = "conveyor_tube"
SUMMARY = "paper pots in rows on a feeding conveyor into a drop tube (seed 000)"
WORKCELL = "transplanter.scene.workcells.conveyor_tube"
UNIT = "seedlings"
RUN = "transplanter.runs.pot_line"
KEY_POINTS = "transplanter.runs.pot_line:key_points"
"""Where its tool must go (`scenario.reach`: the robot reaches them from some placement)."""
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


@dataclass(frozen=True)
class DeltaPotsSection:
    """[delta_pots]: the rotary delta on the five-bar's pot line (`[robot] kind = "delta"` in
    the `conveyor_tube` workcell; read only by transplanter.twin.delta_pots): where its base
    hangs over the line, the fuzzy gripper's fixed angles and the controller's motion.
    Optional: estimates (docs/compare.md, "The delta on the pot line")."""

    base_x_m: float = key("float", -2000, 2000, doc="the base frame's origin, workcell frame")
    base_y_m: float = key("float", -2000, 2000, doc="y of the base frame's origin, workcell frame")
    base_z_m: float = key("float", -2000, 3000, doc="the base above the belt's top")
    mount_drop_m: float = key("float", 0, 200, doc="gripper's mount below the platform's face")
    gripper_yaw_rad: float = key(
        "float", -180, 180, doc="the gripper about the vertical: 0 closes along the row (x)"
    )
    grasp_z_m: float = key("float", 1, 200, doc="grip centre above the belt (a pot's bottom)")
    hover_m: float = key("float", 5, 300, doc="above a grasp or release to come down from")
    release_gap_m: float = key("float", 0, 200, doc="pot's bottom above the funnel at release")
    grip_rad: float = key("float", 0, 60, doc="gripper servo angle sent to grip a pot")
    travel_speed_m_s: float = key("float", 1, 5000, doc="G1 speed of the travel moves")
    approach_speed_m_s: float = key("float", 1, 5000, doc="G1 speed down to a grasp or release")
    path_accel_m_s2: float = key("float", 1, 1e6, doc="the controller's path acceleration")
    segment_m: float = key("float", 0.01, 10, doc="interpolation grid of the controller")
    point_time_s: float = key("float", 1, 1e5, doc="the controller's IK time per point")
    lift_m: float = key("float", 10, 300, doc="bspline5: lift of a transfer")
    arc_radius_m: float = key("float", 1, 300, doc="bspline5: arc at the top of the lift")
    exit_m: float = key("float", 0, 299, doc="bspline5: key point straight above each end")
    following_error_limit_rad: float = key("float", 0.001, 90, doc="drive alarm level")
    grip_settle_s: float = key("float", 0, 10000, doc="dwell after the grip command")
    release_settle_s: float = key("float", 0, 10000, doc="dwell after the release")
    sensor_gap_m: float = key("float", 20, 400, doc="each cell's sensor 1 to the pot's wall")
    sensor_z_m: float = key("float", 0, 200, doc="the sensors' axis above the belt")
    attempts: int = key("int", lo=1, hi=10, doc="grasps of a pot sensor 1 still hears after")


_DELTA_POTS_DEFAULTS = {
    "base_x_mm": 0.0,
    "base_y_mm": 180.0,
    "base_z_mm": 960.0,
    "mount_drop_mm": 20.0,
    "gripper_yaw_deg": 90.0,
    "grasp_z_mm": 30.0,
    "hover_mm": 60.0,
    "release_gap_mm": 10.0,
    "grip_deg": 22.5,
    "travel_speed_mm_s": 500.0,
    "approach_speed_mm_s": 200.0,
    "path_accel_mm_s2": 5000.0,
    "segment_mm": 0.5,
    "point_time_us": 100.0,
    "lift_mm": 60.0,
    "arc_radius_mm": 30.0,
    "exit_mm": 35.0,
    "following_error_limit_deg": 2.0,
    "grip_settle_ms": 300.0,
    "release_settle_ms": 300.0,
    "sensor_gap_mm": 25.0,
    "sensor_z_mm": 12.0,
    "attempts": 2,
}


@dataclass(frozen=True)
class SerialPotsSection:
    """[serial_pots]: the serial arm on the five-bar's pot line (`[robot] kind = "serial4"` in
    the `conveyor_tube` workcell; read only by transplanter.twin.serial_pots): where its base
    stands and how it picks a pot and drops it into the tube. Optional: estimates
    (docs/serial_arm.md)."""

    base_x_m: float = key("float", -1000, 1000, doc="the base plate's centre, workcell frame")
    base_y_m: float = key("float", -1000, 1000, doc="y of the base plate's centre, workcell frame")
    base_z_m: float = key("float", -1000, 1000, doc="the base plate's height (a pedestal)")
    base_yaw_rad: float = key("float", -180, 180, doc="the arm's forward from world +x")
    grasp_z_m: float = key("float", 1, 200, doc="grip centre above the belt (a pot's bottom)")
    release_gap_m: float = key("float", 0, 200, doc="pot's bottom above the funnel at release")
    sensor_gap_m: float = key("float", 20, 400, doc="each cell's sensor 1 to the pot's wall")
    sensor_z_m: float = key("float", 0, 200, doc="the sensors' axis above the belt")
    attempts: int = key("int", lo=1, hi=10, doc="grasps of a pot sensor 1 still hears after")
    release_tilt_rad: float = key("float", 0, 90, doc="most the pot leans at release (no wrist)")


_SERIAL_POTS_DEFAULTS = {
    "base_x_mm": 0.0,
    "base_y_mm": 60.0,
    "base_z_mm": 0.0,
    "base_yaw_deg": 90.0,
    "grasp_z_mm": 40.0,
    "release_gap_mm": 10.0,
    "sensor_gap_mm": 25.0,
    "sensor_z_mm": 12.0,
    "attempts": 2,
    "release_tilt_deg": 0.0,
}


SECTIONS = {
    "delta_pots": Section(DeltaPotsSection, defaults=_DELTA_POTS_DEFAULTS),
    "serial_pots": Section(SerialPotsSection, defaults=_SERIAL_POTS_DEFAULTS),
}
"""Its own sections (transplanter.kinds.sections)."""
