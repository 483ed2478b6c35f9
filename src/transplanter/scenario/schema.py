"""Scenario files: a strict TOML schema with units in every key, read into SI values.

A scenario file holds every number a user may want to change. Each key names its unit
(`l1_mm`, `s_high_mm_s`, `mass_g`); the loader converts to SI and refuses, before anything
runs, a file with an unknown key, a missing value, a wrong unit or a value out of range, always
naming the key. A file may start from another one with `[scenario] base = "paper.toml"` and
override only what differs (a bare name not found beside the file is a packaged scenario).

The result is a `Scenario` of typed, frozen section dataclasses (`scenario.taught.z_low_m`),
values in SI and field names carrying their SI unit. Only `scenario.assemble` turns them into
the configs of the firmware, the scene, the servos and the judge.
"""

from __future__ import annotations

import difflib
import importlib.resources
import math
import reprlib
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from transplanter import fileio, kinds
from transplanter.errors import TransplanterError
from transplanter.kinds import sections as _sections
from transplanter.kinds.sections import Key, Section
from transplanter.machine.eeprom import MAX_PICKUPS

__all__ = [
    "Scenario",
    "ScenarioError",
    "check_value",
    "file_keys",
    "key_spec",
    "load_scenario",
    "parse_value",
    "resolve_scenario_path",
    "packaged_scenarios",
    "scenario_files",
    "SCHEMA",
    "SECTIONS",
]


key = _sections.key  # a section field that is a scenario key (transplanter.kinds.sections)


class ScenarioError(TransplanterError, ValueError):
    """A scenario file cannot be used; the message names the key and what to do."""


_DEG = math.pi / 180.0

GCODE_QUANTUM = 0.001
"""The finest dwell (ms, ``G4 P``) and servo angle (deg, ``M280 S``) a scenario may set: the
firmware's words carry three decimals; a value between 0 and this is refused, not rounded."""

# SI scale of each unit suffix a file key may carry (the key's unit is its suffix).
_SCALE = {
    "_mm_s2": 1e-3, "_mm_s": 1e-3, "_mm": 1e-3, "_deg_s2": _DEG, "_deg_s": _DEG, "_deg": _DEG,
    "_g": 1e-3, "_ms": 1e-3, "_us": 1e-6,
}  # fmt: skip

# Unit suffixes the loader understands (longest first, so `_mm_s` is not read as `_s`); used
# to tell a wrong unit from an unknown key.
_UNIT_SUFFIXES = tuple(
    sorted(
        ("_mm_s2", "_mm_s", "_mm", "_m_s2", "_m_s", "_m", "_deg_s2", "_deg_s", "_deg",
         "_rad_s2", "_rad_s", "_rad", "_g", "_kg", "_ms",
         "_us", "_s", "_hz", "_nm", "_n", "_bps", "_kgm2", "_rev_s",
         # the plugs' and claws' units (read as written: no SI scale)
         "_pct", "_d", "_kpa", "_mpa", "_kg_m3", "_mm2", "_n_s_m", "_nm_rad",
         # units the schema never uses, so that `l1_cm` is reported as a wrong unit
         "_cm", "_in", "_mm_min", "_rev_min", "_rpm", "_min", "_lb", "_oz", "_n_mm"),
        key=len,
        reverse=True,
    )
)  # fmt: skip

_SI_SUFFIX = {
    "_deg_s2": "_rad_s2",
    "_deg_s": "_rad_s",
    "_mm_s2": "_m_s2",
    "_mm_s": "_m_s",
    "_mm": "_m",
    "_deg": "_rad",
    "_g": "_kg",
    "_ms": "_s",
    "_us": "_s",
}


_REPR = reprlib.Repr()  # attributes, not arguments: Python 3.11's Repr takes none
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict, _REPR.maxstring, _REPR.maxother = 3, 6, 6, 60, 60


def _shown(value: Any) -> str:
    """A value for a message, bounded in depth and length (a file may hold anything)."""
    return _REPR.repr(value)


def _unit_of(key: str) -> str | None:
    for suffix in _UNIT_SUFFIXES:
        if key.endswith(suffix):
            return suffix
    return None


def _stem(key: str) -> str:
    unit = _unit_of(key)
    return key[: -len(unit)] if unit else key


def si_key(key: str) -> str:
    """The name a file key has once its value is in SI: `l1_mm` -> `l1_m`."""
    unit = _unit_of(key)
    return key[: -len(unit)] + _SI_SUFFIX[unit] if unit in _SI_SUFFIX else key


# ---------------------------------------------------------------------------------------
# The shared sections. Field names carry the SI unit of the value; the file key carries the
# unit the file uses. A new key is a field here plus one line in transplanter.scenario.assemble.
# A kind's own section is declared in its kind module (`SECTIONS`, transplanter.kinds.sections)
# and joins the schema from there (`_add_kind_sections`).
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MetaSection:
    """[scenario]: the trial's name, seed and size."""

    name: str = key("str", doc="short name used in reports")
    description: str = key(
        "str", doc="one line on what the scenario is, shown by `transplanter scenarios`"
    )
    seed: int = key("int", lo=0, hi=2**63 - 1, doc="random seed of the pots")
    seedlings: int = key("int", lo=1, hi=100000, doc="seedlings to pick in a trial")


@dataclass(frozen=True)
class RobotSection:
    """[robot]: which arm (its kinematics, model and drives); optional, default the five-bar."""

    kind: str = key("str", doc="the robot's kind, one registered in transplanter.kinds")


@dataclass(frozen=True)
class WorkcellSection:
    """[workcell]: the job around the arm; optional, default paper pots on a feeding conveyor
    into a drop tube."""

    kind: str = key("str", doc="the job's kind (its workcell), registered in transplanter.kinds")


@dataclass(frozen=True)
class EffectorSection:
    """[effector]: the tool on the arm; optional, default servo parallel jaws with a wrist."""

    kind: str = key("str", doc="the end effector's kind, one registered in transplanter.kinds")


@dataclass(frozen=True)
class ArmSection:
    """[arm]: the five-bar's geometry and working mode."""

    l0_m: float = key("float", 1, 500, doc="half the distance between the two motors")
    l1_m: float = key("float", 1, 1000, doc="active link length")
    l2_m: float = key("float", 1, 1000, doc="passive link length")
    working_mode: str = key(
        "str",
        choices=("+-", "-+", "++", "--"),
        doc="IK branch of arm 1, arm 2: '+-' elbows out (the paper's, the only one the twin runs)",
    )


@dataclass(frozen=True)
class PlugsSection:
    """[plugs]: the plug of substrate and its laws (`transplanter.scene.plug_substrate.
    PlugsConfig`, whose fields are the file keys), read by the delta's jobs. Optional: the
    defaults are PlugsConfig's, estimates but for the paper's factors (docs/plug_claws.md). The
    cell's shape (30 / 20 / 42 mm, the paper's tray) is the trays' and not a key."""

    moisture_pct: float = key("float", 1, 99, doc="wet-basis water content (paper's factor A)")
    age_d: float = key("float", 0, 365, doc="seedling age after sowing (paper's factor B)")
    surface_below_top_m: float = key("float", 0, 20, doc="substrate surface below the cell top")
    clearance_m: float = key("float", 0.01, 2, doc="plug-to-wall gap (numerical)")
    core_top_depth_m: float = key("float", 1, 38, doc="top of the pin socket below the plug top")
    adhesion_onset_speed_m_s: float = key("float", 0.01, 100, doc="full cell adhesion from")
    dry_bulk_density_kg_m3: float = key("float", 10, 2000, doc="dry bulk density")
    porosity_pct: float = key("float", 1, 99, doc="pore space: caps the wet density")
    cohesion_kpa: float = key("float", 0.001, 1000, doc="root-free cohesion at the reference")
    reference_moisture_pct: float = key("float", 1, 99, doc="moisture of the reference values")
    cohesion_moisture_scale_pct: float = key("float", 0.1, 1000, doc="cohesion e-fold per")
    root_onset_d: float = key("float", 0, 365, doc="age at which roots start to bind")
    root_time_d: float = key("float", 0.1, 365, doc="time constant of root binding")
    root_cohesion_gain: float = key("float", 0, 100, doc="cohesion x (1 + this R)")
    wall_adhesion_kpa: float = key("float", 0, 1000, doc="root-free wall adhesion")
    wall_adhesion_moisture_scale_pct: float = key("float", 0.1, 1000, doc="adhesion e-fold per")
    root_wall_gain: float = key("float", 0, 100, doc="wall adhesion x (1 + this R)")
    loose_fraction_pct: float = key("float", 0, 100, doc="root-free share that can break away")
    root_loose_reduction_pct: float = key("float", 0, 100, doc="share of it roots bind")
    weibull_modulus: float = key("float", 0.1, 20, doc="spread of the breaking loads")
    bearing_factor: float = key("float", 0.1, 100, doc="N_c round a pin")
    pin_bearing_mm2: float = key("float", 1, 2000, doc="bearing area of the two pins")
    pin_friction: float = key("float", 0.05, 5, doc="pin-substrate friction at the reference")
    pin_friction_per_pct: float = key("float", 0, 0.1, doc="friction lost per % of moisture")
    wall_friction: float = key("float", 0, 5, doc="plug-wall friction")
    substrate_timeconst_s: float = key("float", 2, 1000, doc="pin contact's solref time")
    substrate_stiffening: float = key("float", 0, 100, doc="time constant / (1 + this R)")
    reference_mass_kg: float = key("float", 0.1, 1000, doc="plug mass of the time constant")


@dataclass(frozen=True)
class LimitsSection:
    """[limits]: joint windows and conditioning limits the firmware enforces."""

    motor1_min_rad: float = key("float", -180, 360, doc="active joint 1 window")
    motor1_max_rad: float = key("float", -180, 360, doc="upper end of active joint 1's window")
    motor2_min_rad: float = key("float", -180, 360, doc="active joint 2 window")
    motor2_max_rad: float = key("float", -180, 360, doc="upper end of active joint 2's window")
    elbow_min_rad: float = key(
        "float", 0, 180, doc="least angle between active and passive link at B and D (0: folded)"
    )
    elbow_max_rad: float = key(
        "float",
        0,
        180,
        doc="largest angle between active and passive link at B and D (180: stretched)",
    )
    transmission_min_rad: float = key(
        "float", 0, 180, doc="least angle at C between the passive links (0: parallel singularity)"
    )
    transmission_max_rad: float = key(
        "float",
        0,
        180,
        doc="largest angle at C between the passive links (180: parallel singularity)",
    )
    max_condition: float = key(
        "float", 1, 1e6, doc="largest condition number of the Jacobian dC/dtheta (1: isotropic)"
    )
    z_min_m: float = key(
        "float", -100, 1000, doc="lowest Z a move may target; limit switch 4 (Z down) trips there"
    )
    z_max_m: float = key("float", -100, 1000, doc="highest Z a move may target")


@dataclass(frozen=True)
class DrivesSection:
    """[drives]: stepper motors, transmissions, limit switches and homing rates."""

    steps_per_rev: int = key(
        "int", lo=1, hi=100000, doc="full steps per revolution of each of the three steppers"
    )
    microsteps: int = key("int", lo=1, hi=256, doc="the drivers' microsteps per full step")
    arm_belt_ratio: float = key("float", 0.01, 100, doc="motor revolutions per arm revolution")
    z_lead_m: float = key("float", 0.1, 100, doc="lead screw travel per revolution")
    max_step_rate_hz: float = key(
        "float", 1, 1e6, doc="highest step pulse rate (microsteps/s) the SGF may send a motor"
    )
    holding_torque_nm: float = key(
        "float",
        0.001,
        100,
        doc="each stepper's holding torque: its torque law's peak at standstill",
    )
    rotor_inertia_kgm2: float = key("float", 1e-9, 1e-2, doc="motor rotor inertia")
    detent_torque_nm: float = key(
        "float", 0.0, 100, doc="the motor's torque unpowered, one cycle per full step"
    )
    pullout_corner_rev_s: float = key(
        "float", 0.01, 1000, doc="motor speed above which the pull-out torque falls as 1/speed"
    )
    rotor_damping_ratio: float = key(
        "float", 0.0, 10, doc="damping of the rotor against its field, unloaded rotor"
    )
    screw_efficiency: float = key("float", 0.01, 1.0, doc="lead screw efficiency")
    arm_speed_limit_rad_s: float = key(
        "float", 1, 1e5, doc="bspline5: each arm joint's speed limit (at most its step rate)"
    )
    arm_accel_limit_rad_s2: float = key(
        "float", 1, 1e7, doc="bspline5: each arm joint's acceleration limit"
    )
    arm_torque_limit_nm: float = key(
        "float",
        0.001,
        100,
        doc="bspline5: each arm motor's torque limit at its shaft, of the lumped dynamics "
        "(at most the pull-out torque at the arms' speed limit)",
    )
    z_speed_limit_m_s: float = key(
        "float", 0.1, 1e5, doc="bspline5: Z's speed limit (at most its step rate)"
    )
    z_accel_limit_m_s2: float = key("float", 1, 1e7, doc="bspline5: Z's acceleration limit")
    switch1_theta1_rad: float = key("float", -180, 360, doc="limit switch 1 trip angle")
    switch2_theta2_rad: float = key("float", -180, 360, doc="limit switch 2 trip angle")
    switch3_z_m: float = key("float", 0, 1000, doc="limit switch 3 (Z up) trip height")
    homing_rate_arm_hz: float = key(
        "float", 1, 1e5, doc="each arm motor's step rate while G28 seeks its switch and pulls off"
    )
    homing_rate_z_hz: float = key(
        "float", 1, 1e6, doc="Z motor's step rate while G28 seeks switch 3 and pulls off"
    )
    homing_locate_rate_arm_hz: float = key("float", 1, 1e5, doc="slow second homing pass")
    homing_locate_rate_z_hz: float = key(
        "float", 1, 1e6, doc="Z motor's step rate in the slow second homing pass"
    )
    homing_debounce_s: float = key(
        "float", 0, 5000, doc="dwell after a homing switch trips, before the pull-off"
    )


@dataclass(frozen=True)
class MotionSection:
    """[motion]: the SGF's interpolation and speed profile."""

    resolution_m: float = key("float", 0.001, 10, doc="Bresenham grid (paper 2.4)")
    accel_m_s2: float = key(
        "float", 1, 1e6, doc="path acceleration and deceleration of a line (scurve: its peak)"
    )
    profile: str = key(
        "str",
        choices=("trapezoid", "scurve"),
        doc="a line's speed ramps: trapezoid (constant acceleration) or scurve (smoothstep)",
    )
    compute_time_per_point_s: float = key(
        "float",
        0.01,
        1e6,
        doc="IK time per point: 198 ESP32 dual core, 276 single core, 4027 Arduino Mega",
    )
    planner: str = key(
        "str",
        choices=("lines", "bspline5"),
        doc="lines: G0 and G1 straight; bspline5: a G0 is a time-optimal quintic B-spline "
        "transfer (the delta: lift, arc, top, arc, descent; the five-bar: lifted grip point, "
        "retract point, drop point) under the arm's joint limits",
    )
    ee_accel_limit_m_s2: float = key(
        "float", 100, 1e6, doc="end-effector acceleration limit of a bspline5 transfer"
    )


@dataclass(frozen=True)
class BusSection:
    """[bus]: the UART between the PGF and the SGF."""

    baud_bps: float = key(
        "float",
        300,
        1e7,
        doc="the UART's bit rate: a line of n characters takes (n + 1) x 10 / baud s",
    )
    line_numbers: bool = key("bool", doc="Marlin N<n> ... *<checksum> framing")
    reply_timeout_s: float = key(
        "float",
        0.1,
        3600,
        doc="the PGF stops with a bus timeout when nothing comes back for this long while a "
        "line is outstanding; longer than the longest line (preflight checks it)",
    )


@dataclass(frozen=True)
class GripperSection:
    """[gripper]: gripper and wrist servos and the PGF's dwells."""

    servo_s_per_60deg: float = key("float", 0.01, 10, doc="hobby servo speed")
    max_opening_m: float = key("float", 1, 200, doc="jaw opening at 180 deg servo angle")
    open_rad: float = key(
        "float",
        0,
        180,
        quantum=GCODE_QUANTUM,
        doc="gripper servo angle (M280) that opens the jaws, before the grip and at the drop",
    )
    close_rad: float = key(
        "float",
        0,
        180,
        quantum=GCODE_QUANTUM,
        doc="gripper servo angle (M280) that closes the jaws on a pot",
    )
    grip_force_n: float = key("float", 0.01, 1000, doc="servo force limit at the jaws")
    bridge_clearance_m: float = key(
        "float", 1, 1000, doc="underside of the bridge joining the jaws, over the grip centre"
    )
    wrist_servo_s_per_60deg: float = key("float", 0.01, 10, doc="wrist hobby servo speed")
    open_dwell_s: float = key(
        "float",
        0,
        10000,
        quantum=GCODE_QUANTUM,
        doc="G4 dwell after the jaws open, before the grip move",
    )
    close_dwell_s: float = key(
        "float",
        0,
        10000,
        quantum=GCODE_QUANTUM,
        doc="G4 dwell after the jaws close, before the lift",
    )
    release_dwell_s: float = key(
        "float",
        0,
        10000,
        quantum=GCODE_QUANTUM,
        doc="G4 dwell after the jaws open at the drop point",
    )
    carry_accel_limit_m_s2: float = key(
        "float",
        100,
        1e6,
        doc="bspline5: the jaws' acceleration limit on the five-bar's spline transfer, which "
        "carries the seedling (its shoot bends more above it)",
    )


@dataclass(frozen=True)
class ConveyorSection:
    """[conveyor]: the feeding conveyor's cells and index time."""

    rows: int = key("int", lo=1, hi=10000, doc="rows of cells on the belt; row 0 is the pickup row")
    cols: int = key("int", lo=1, hi=20, doc="cells per row, along x")
    live_rows: int = key(
        "int", lo=1, hi=10000,
        doc="rows of pots that are bodies in the physics: the row just picked, the pickup row "
        "and the rows upstream being pushed into place; the others ride the belt outside the "
        "physics and enter as rows are picked (at least 6; >= rows: every pot a body)",
    )  # fmt: skip
    cell_pitch_m: float = key("float", 1, 1000, doc="cell centre to cell centre along a row (x)")
    row_pitch_m: float = key(
        "float", 1, 1000, doc="row centre to row centre (y): how far an index moves the pots"
    )
    pickup_row_y_m: float = key(
        "float",
        -1000,
        1000,
        doc="y of the pickup row's centres (row 0); the rows behind at + row_pitch_mm each",
    )
    index_time_s: float = key(
        "float",
        0.01,
        60,
        doc="duration of a conveyor index (M710): push and settle, at least 0.2 s",
    )
    index_error_sd_m: float = key(
        "float", 0, 20, doc="where an index leaves the row: belt stretch and rib play (sd)"
    )
    index_drive: str = key(
        "str", choices=("pd", "stepper"),
        doc="what moves the carriage along an index: a PD force (estimated gains), or the "
        "conveyor stepper's own stiffness about a set point following the profile",
    )  # fmt: skip


@dataclass(frozen=True)
class PotsSection:
    """[pots]: paper pots and their spread."""

    diameter_m: float = key(
        "float", 1, 500, doc="mean pot diameter; each pot's is drawn from a normal"
    )
    diameter_sd_m: float = key("float", 0, 100, doc="sd of the pot diameters (normal)")
    height_m: float = key("float", 1, 500, doc="mean pot height; each pot's is drawn from a normal")
    height_sd_m: float = key("float", 0, 100, doc="sd of the pot heights (normal)")
    mass_kg: float = key(
        "float", 0.1, 10000, doc="pot mass: mean of a normal truncated to [mass_min_g, mass_max_g]"
    )
    mass_sd_kg: float = key(
        "float", 0, 10000, doc="sd of the pot masses' normal (before truncation)"
    )
    friction: float = key("float", 0, 10, doc="sliding friction coefficient pot-jaw")
    friction_sd: float = key("float", 0, 10, doc="spread of a gamma distribution (never < 0)")
    placement_sd_m: float = key("float", 0, 100, doc="pot offset from its cell centre")
    placement_max_m: float = key("float", 0, 100, doc="largest offset the cell allows")
    mass_min_kg: float = key(
        "float", 0.1, 10000, doc="masses are a normal truncated to [min, max] (no clipping)"
    )
    mass_max_kg: float = key(
        "float",
        0.1,
        10000,
        doc="heaviest pot drawn; the five-bar's lumped dynamics carry it with the shoot",
    )
    bond_share: float = key(
        "float", 0, 1, doc="share of pots whose roots or wet paper bond them to the belt"
    )
    bond_force_n: float = key("float", 0, 100, doc="median strength of a pot's bond (N)")
    bond_force_sd_log: float = key(
        "float", 0, 3, doc="spread of bond strengths: sd of their natural log"
    )
    soft_share: float = key(
        "float", 0, 1, doc="share of soaked pots whose wall gives under the jaws"
    )
    soft_wall_m: float = key(
        "float", 0.01, 100, doc="how deep a soaked pot's wall gives before it resists fully"
    )
    crooked_share: float = key(
        "float", 0, 1, doc="share of pots whose wall leans over its flat foot"
    )
    crooked_max_rad: float = key(
        "float", 0.1, 44.9, doc="a crooked pot's wall leans up to this (uniform), to any side"
    )
    fill_gap_m: float = key(
        "float", 0, 20, doc="how far below the rim a pot's soil lies (mean; normal, truncated)"
    )
    fill_gap_sd_m: float = key("float", 0, 20, doc="spread of the fill gaps between pots")
    canopy_contact: bool = key(
        "bool", doc="the leaves' capsule proxies touch the jaws (soft): they push and drag the pot"
    )
    feet: int = key(
        "int", lo=0, hi=16,
        doc="0: a pot's cylinder stands on the belt table; 3-16: the pot stands on this many "
        "small spheres inside its base, which alone touch the table",
    )  # fmt: skip
    canopy_timeconst_s: float = key(
        "float", 0, 1000, doc="contact time constant of a leaf on a jaw: larger is softer"
    )
    canopy_friction: float = key("float", 0, 10, doc="sliding friction of a leaf on a jaw")
    shoot_mass_kg: float = key("float", 0.01, 1000, doc="the seedling's shoot above the pot")
    stem_sway_hz: float = key(
        "float", 0.01, 1000, doc="natural frequency of the shoot swaying on its stem"
    )
    stem_sway_sd_hz: float = key(
        "float", 0, 1000, doc="spread of the sway frequency between seedlings (gamma)"
    )
    stem_damping_ratio: float = key("float", 0, 10, doc="damping ratio of that sway")


@dataclass(frozen=True)
class DropTubeSection:
    """[drop_tube]: where the drop tube's funnel is."""

    x_m: float = key("float", -1000, 1000, doc="x of the drop tube's funnel centre")
    y_m: float = key("float", -1000, 1000, doc="y of the drop tube's funnel centre")
    funnel_top_diameter_m: float = key("float", 1, 1000, doc="the funnel's diameter at its top")
    funnel_top_z_m: float = key(
        "float", -1000, 1000, doc="height of the funnel's top above the belt's top face"
    )
    funnel_throat_diameter_m: float = key(
        "float",
        1,
        1000,
        doc="the funnel's throat, the tube's bore below it (a pot tilted too far is wider than it)",
    )
    funnel_height_m: float = key(
        "float", 1, 1000, doc="the funnel's cone from its top to the throat"
    )


@dataclass(frozen=True)
class MetricsSection:
    """[metrics]: how a trial judges each seedling (not physics)."""

    knocked_offset_m: float = key(
        "float", 0.1, 100, doc="a pot this far from its grip point is out of its cell"
    )
    knocked_tilt_rad: float = key("float", 1, 90, doc="a pot tilted this much is knocked over")
    lifted_fraction: float = key(
        "float", 0.01, 1.0, doc="share of the lift a gripped pot must rise"
    )
    between_jaws_m: float = key(
        "float", 1, 100, doc="pot centre within this (xy) of the grip centre at the drop"
    )
    settle_s: float = key("float", 0.0, 60, doc="physics kept running after the last line")
    damage_bend_rad: float = key(
        "float", 1, 180, doc="a shoot bent further than this from its pot's axis is damaged"
    )


@dataclass(frozen=True)
class PhysicsSection:
    """[physics]: solver settings."""

    timestep_s: float = key(
        "float",
        0.01,
        10,
        doc="MuJoCo's physics timestep (the five-bar's preflight refuses one too coarse)",
    )
    sleep: bool = key(
        "bool",
        doc="let resting bodies sleep: faster; may change a single trial's trajectory near "
        "the edge; the pooled rate over seeds is what to compare (docs/edge_trials.md)",
    )


@dataclass(frozen=True)
class RecoverySection:
    """[recovery]: what the machine does about lost steps (the paper's machine: nothing)."""

    rehome_every_cycles: int = key(
        "int",
        lo=0,
        hi=100000,
        doc="G28 and back to the drop point before every N-th cycle; 0 never",
    )
    stall_detection: bool = key(
        "bool",
        doc="drivers report a stall (StallGuard): the SGF stops, the PGF re-homes and retries",
    )
    stall_retries: int = key(
        "int", lo=1, hi=100, doc="stalls one seedling's cycle may recover from before the PGF stops"
    )
    stall_settle_s: float = key(
        "float", lo=0, hi=10000, doc="dwell after a stall before the re-home (the arm settles)"
    )


@dataclass(frozen=True)
class FaultsSection:
    """[faults]: faults injected into a trial (all 0: none, the paper's run)."""

    switch_stuck_closed: int = key(
        "int", lo=0, hi=4, doc="limit switch 1-4 that always reads closed (0: none)"
    )
    switch_dead: int = key(
        "int", lo=0, hi=4, doc="homing limit switch 1-3 that never closes, unplugged (0: none)"
    )
    jam_motor: int = key(
        "int", lo=0, hi=3, doc="motor 1-3 (arm 1, arm 2, Z) whose joint jams (0: none)"
    )
    jam_at_s: float = key("float", lo=0, hi=1e6, doc="when the jam starts (simulated s)")
    jam_duration_s: float = key("float", lo=0, hi=1e6, doc="how long the jam lasts")
    jam_torque_nm: float = key(
        "float",
        lo=0,
        hi=100,
        doc="the jam's resisting torque at the motor shaft, a friction brake through the "
        "drive (compare drives.holding_torque_nm)",
    )
    lost_reply_line: int = key(
        "int",
        lo=0,
        hi=10**9,
        doc="the SGF's reply to the n-th line it receives is lost on the wire (0: none)",
    )


@dataclass(frozen=True)
class TaughtPickup:
    """One [[taught.pickup]]: approach (via) point M_pd, grip point M_pgd, wrist angle M_pep."""

    approach_m: tuple[float, float] = key("xy", -1000, 1000, doc="approach (via) point M_pd[k]")
    grip_m: tuple[float, float] = key("xy", -1000, 1000, doc="grip point M_pgd[k]")
    wrist_rad: float = key("float", 0, 180, doc="wrist servo angle M_pep[k]")


@dataclass(frozen=True)
class TaughtSection:
    """[taught]: the EEPROM image (paper Fig. 9) as entered on the HMI."""

    z_up_m: float = key(
        "float",
        -100,
        1000,
        doc="Z_up: grip centre height of the lift, the retract and the carry to the drop",
    )
    z_low_m: float = key(
        "float", -100, 1000, doc="Z_low: grip centre height of the approach and the grip"
    )
    s_low_m_s: float = key("float", 0.1, 10000, doc="paper S_l")
    s_high_m_s: float = key("float", 0.1, 10000, doc="paper S_h")
    drop_m: tuple[float, float] = key("xy", -1000, 1000, doc="drop point M_dp")
    drop_wrist_rad: float = key("float", 0, 180, doc="wrist servo angle at the drop, M_dep")
    pickup: tuple[TaughtPickup, ...] = key(
        "list", doc="pickup points, each approach_mm, grip_mm, wrist_deg"
    )


@dataclass(frozen=True)
class SerialArmSection:
    """[serial_arm]: the serial arm's jobs (seed 004; read only by transplanter.twin.serial_arm):
    the paper's ten targets, its 18 gripper trials and the pick-and-place of the pool_to_belt
    workcell. Optional: the defaults are estimates (docs/serial_arm.md)."""

    target_speed_m_s: float = key("float", 1, 1000, doc="G1 speed to each of the ten targets")
    target_settle_s: float = key("float", 0, 10000, doc="dwell at a target before measuring")
    travel_speed_m_s: float = key("float", 1, 1000, doc="G1 speed between stations")
    approach_speed_m_s: float = key("float", 1, 1000, doc="G1 speed down to a grasp or release")
    path_accel_m_s2: float = key("float", 1, 1e5, doc="the controller's path acceleration")
    segment_m: float = key("float", 0.01, 10, doc="interpolation grid of the controller")
    point_time_s: float = key("float", 1, 1e5, doc="IK time per interpolated point")
    hover_m: float = key("float", 5, 200, doc="height above a grasp or release to come down from")
    grip_settle_s: float = key("float", 0, 10000, doc="dwell after the gripper's command")
    release_settle_s: float = key("float", 0, 10000, doc="dwell after the release")
    sensor_resolution_m: float = key("float", 0, 50, doc="reading's step (0: none; 10: whole cm)")
    bruise_force_n: float = key("float", 0.1, 1000, doc="squeeze above it bruises a tomato")
    bench_radius_m: float = key("float", 20, 160, doc="gripper trials: grip centre's radius")
    bench_height_m: float = key("float", -50, 160, doc="gripper trials: its height (paper y)")


# The file key of every field whose file unit differs from its SI unit.
_FILE_KEY_OVERRIDES = {
    "mass_kg": "mass_g", "mass_sd_kg": "mass_sd_g", "mass_min_kg": "mass_min_g",
    "mass_max_kg": "mass_max_g", "open_dwell_s": "open_dwell_ms",
    "close_dwell_s": "close_dwell_ms", "release_dwell_s": "release_dwell_ms",
    "compute_time_per_point_s": "compute_time_per_point_us", "timestep_s": "timestep_ms",
    "stall_settle_s": "stall_settle_ms", "canopy_timeconst_s": "canopy_timeconst_ms",
    "homing_debounce_s": "homing_debounce_ms",
    "shoot_mass_kg": "shoot_mass_g",
    "image_delay_s": "image_delay_ms", "point_time_s": "point_time_us",
    "tray_change_s": "tray_change_ms", "settle_after_s": "settle_after_ms",
    "target_settle_s": "target_settle_ms", "grip_settle_s": "grip_settle_ms",
    "release_settle_s": "release_settle_ms",
}  # fmt: skip
# The same, for a field of one section only (section, field): file key.
_SECTION_FILE_KEYS = {
    ("plugs", "substrate_timeconst_s"): "substrate_timeconst_ms",
    ("plugs", "reference_mass_kg"): "reference_mass_g",
}
_FILE_SUFFIX = {
    "_rad_s2": "_deg_s2", "_rad_s": "_deg_s", "_m_s2": "_mm_s2", "_m_s": "_mm_s", "_m": "_mm",
    "_rad": "_deg",
}  # fmt: skip


@dataclass(frozen=True)
class CostsSection:
    """[costs]: what the machine's drives cost; not physics: `transplanter compare` reports
    it beside what the machine does. The packaged scenarios' values are estimates
    (docs/compare.md gives each part and its source); put your own quote here."""

    drives_usd: float = key(
        "float",
        0,
        1e7,
        doc="the drives: motors with their drivers or amplifiers and gearboxes, servos, "
        "cylinders and valves (US$; 0: not given)",
    )


SECTIONS: dict[str, type] = {
    "scenario": MetaSection,
    "robot": RobotSection,
    "workcell": WorkcellSection,
    "effector": EffectorSection,
    "arm": ArmSection,
    "plugs": PlugsSection,
    "limits": LimitsSection,
    "drives": DrivesSection,
    "motion": MotionSection,
    "bus": BusSection,
    "gripper": GripperSection,
    "conveyor": ConveyorSection,
    "pots": PotsSection,
    "drop_tube": DropTubeSection,
    "metrics": MetricsSection,
    "physics": PhysicsSection,
    "recovery": RecoverySection,
    "faults": FaultsSection,
    "taught": TaughtSection,
    "serial_arm": SerialArmSection,
    "costs": CostsSection,
}


def _file_key(field_name: str, section: str | None = None) -> str:
    if (section, field_name) in _SECTION_FILE_KEYS:
        return _SECTION_FILE_KEYS[section, field_name]
    if field_name in _FILE_KEY_OVERRIDES:
        return _FILE_KEY_OVERRIDES[field_name]
    for si, unit in _FILE_SUFFIX.items():
        if field_name.endswith(si) and not field_name.endswith("_rev_s"):
            return field_name[: -len(si)] + unit
    return field_name


def _schema_of(cls: type, section: str | None = None) -> dict[str, Key]:
    """{file key: Key} of a section dataclass, the scale taken from the file key's unit."""
    out = {}
    for f in fields(cls):
        spec: Key = f.metadata["key"]
        file_key = _file_key(f.name, section)
        if si_key(file_key) != f.name:  # a kind's section may name its file keys wrongly
            raise ValueError(
                f"[{section}] field {f.name!r}: its file key {file_key!r} reads as "
                f"{si_key(file_key)!r} in SI; name the field for its SI unit, or give its file "
                "key in Section.file_keys"
            )
        out[file_key] = replace(spec, scale=_SCALE.get(_unit_of(file_key) or "", 1.0))
    return out


SCHEMA: dict[str, dict[str, Key]] = {name: _schema_of(cls, name) for name, cls in SECTIONS.items()}

DEFAULT_SECTIONS: dict[str, dict[str, Any]] = {
    "robot": {"kind": "fivebar"},
    "workcell": {"kind": "conveyor_tube"},
    "effector": {"kind": "parallel_jaw"},
    "motion": {"planner": "lines", "ee_accel_limit_mm_s2": 8830.0},
    "gripper": {"carry_accel_limit_mm_s2": 4500.0},  # docs/planner.md, The five-bar
    "drives": {  # the five-bar's bspline5 limits (machine.kinematics.fivebar, docs/planner.md)
        "arm_speed_limit_deg_s": 712.5,
        "arm_accel_limit_deg_s2": 25000.0,
        "arm_torque_limit_nm": 0.225,
        "z_speed_limit_mm_s": 47.5,
        "z_accel_limit_mm_s2": 25000.0,
    },
    "plugs": {
        "moisture_pct": 65.0,
        "age_d": 25.0,
        "surface_below_top_mm": 3.0,
        "clearance_mm": 0.3,
        "core_top_depth_mm": 20.0,
        "adhesion_onset_speed_mm_s": 1.0,
        "dry_bulk_density_kg_m3": 160.0,
        "porosity_pct": 90.0,
        "cohesion_kpa": 0.55,
        "reference_moisture_pct": 65.0,
        "cohesion_moisture_scale_pct": 25.0,
        "root_onset_d": 12.0,
        "root_time_d": 10.0,
        "root_cohesion_gain": 3.0,
        "wall_adhesion_kpa": 0.05,
        "wall_adhesion_moisture_scale_pct": 40.0,
        "root_wall_gain": 2.0,
        "loose_fraction_pct": 40.0,
        "root_loose_reduction_pct": 75.0,
        "weibull_modulus": 2.0,
        "bearing_factor": 9.0,
        "pin_bearing_mm2": 200.0,
        "pin_friction": 0.7,
        "pin_friction_per_pct": 0.01,
        "wall_friction": 0.4,
        "substrate_timeconst_ms": 12.0,
        "substrate_stiffening": 1.0,
        "reference_mass_g": 11.0,
    },
    "serial_arm": {
        "target_speed_mm_s": 50.0,
        "target_settle_ms": 1500.0,
        "travel_speed_mm_s": 120.0,
        "approach_speed_mm_s": 40.0,
        "path_accel_mm_s2": 600.0,
        "segment_mm": 0.5,
        "point_time_us": 4027.0,
        "hover_mm": 40.0,
        "grip_settle_ms": 400.0,
        "release_settle_ms": 400.0,
        "sensor_resolution_mm": 0.0,
        "bruise_force_n": 20.0,
        "bench_radius_mm": 80.0,
        "bench_height_mm": 80.0,
    },
    "costs": {"drives_usd": 0.0},
}
"""Sections a file may leave out, with their values then: the paper's machine and job, and
the delta's and serial arm's estimated defaults (a file's or --set's keys of such a section
replace these one by one). The kinds are checked against the registries when the scenario is
assembled (an unknown kind is refused there with the known ones)."""
PICKUP_SCHEMA: dict[str, Key] = _schema_of(TaughtPickup)

SHARED_SECTIONS: tuple[str, ...] = tuple(SECTIONS)
"""The loader's own sections; every other one is a kind's (KIND_SECTIONS)."""
KIND_SECTIONS: dict[str, tuple[str, Section]] = {}
"""{section: (its owner, 'the gantry robot'; its Section)}: the sections the registered kinds
declare (`transplanter.kinds.sections`), taken into SECTIONS, SCHEMA and DEFAULT_SECTIONS."""


def add_kind_sections() -> None:
    """Take every registered kind's own sections into the schema (again: a kind registered at
    run time brings its own); ValueError for a section that clashes with a shared one or
    another kind's, a field whose file key does not read as it, a default for no key."""
    declared = kinds.own_sections()
    for name, (owner, _) in declared.items():
        if name in SHARED_SECTIONS:
            raise ValueError(
                f"{owner} declares the [{name}] section, one of the loader's shared sections; "
                "rename it"
            )
    built: dict[str, tuple[type, dict[str, Key]]] = {}
    for name, (owner, section) in declared.items():
        for field_name, file_key in section.file_keys.items():
            _SECTION_FILE_KEYS[name, field_name] = file_key
        keys = _schema_of(section.fields, name)
        stray = sorted(set(section.defaults) - set(keys))
        if stray:
            raise ValueError(f"{owner}'s [{name}] defaults name no key of it: {', '.join(stray)}")
        built[name] = (section.fields, keys)
    for name in KIND_SECTIONS:
        SECTIONS.pop(name, None)
        SCHEMA.pop(name, None)
        DEFAULT_SECTIONS.pop(name, None)
    KIND_SECTIONS.clear()
    for name, (owner, section) in declared.items():
        SECTIONS[name], SCHEMA[name] = built[name]
        if section.defaults:
            DEFAULT_SECTIONS[name] = dict(section.defaults)
        KIND_SECTIONS[name] = (owner, section)


add_kind_sections()


@dataclass(frozen=True)
class Scenario:
    """A validated scenario: one typed, frozen section per table, values in SI."""

    path: Path | None
    meta: MetaSection
    robot: RobotSection
    workcell: WorkcellSection
    effector: EffectorSection
    arm: ArmSection
    plugs: PlugsSection
    limits: LimitsSection
    drives: DrivesSection
    motion: MotionSection
    bus: BusSection
    gripper: GripperSection
    conveyor: ConveyorSection
    pots: PotsSection
    drop_tube: DropTubeSection
    metrics: MetricsSection
    physics: PhysicsSection
    recovery: RecoverySection
    faults: FaultsSection
    taught: TaughtSection
    serial_arm: SerialArmSection
    costs: CostsSection
    overrides: tuple[tuple[str, Any], ...] = ()
    """The 'section.key' = value overrides applied on top of the file, as given."""
    kind_sections: tuple[tuple[str, Any], ...] = ()
    """(name, section) of the kinds' own sections this scenario holds (KIND_SECTIONS: every
    one its kinds read, and every one with a default for each key), read as attributes
    (`scenario.gantry`)."""

    def __getattr__(self, name: str) -> Any:
        for section, values in self.__dict__.get("kind_sections", ()):
            if section == name:
                return values
        if name in KIND_SECTIONS:
            raise AttributeError(
                f"this scenario has no [{name}] section: no kind of it reads it and it is "
                f"{KIND_SECTIONS[name][0]}'s, without a default for every key"
            )
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def has_section(self, section: str) -> bool:
        """Whether the scenario holds `section` (a shared one always; a kind's, see above)."""
        return section in SHARED_SECTIONS or any(n == section for n, _ in self.kind_sections)

    def get(self, dotted: str) -> Any:
        """The SI value of a file key given as 'section.key' (`taught.s_high_mm_s`)."""
        section, _, name = dotted.partition(".")
        if section not in SECTIONS or name not in SCHEMA[section]:
            raise ScenarioError(f"{dotted!r} is not a scenario key ('section.key').")
        attr = "meta" if section == "scenario" else section
        return getattr(getattr(self, attr), si_key(name))

    @property
    def name(self) -> str:
        return self.meta.name

    @property
    def seed(self) -> int:
        return self.meta.seed


REMOVED_KEYS = {
    "pots.friction_min": "frictions are drawn from a gamma distribution with pots.friction "
    "as mean and pots.friction_sd as sd, never below 0, so no floor is needed; delete the key",
}
"""Keys that were in the schema once, with what to do instead."""


def _unknown_key_error(where: str, key: str, known: Mapping[str, Key]) -> ScenarioError:
    if f"{where}.{key}" in REMOVED_KEYS:
        return ScenarioError(f"{where}.{key} was removed: {REMOVED_KEYS[f'{where}.{key}']}.")
    stem = _stem(key)
    same_stem = [k for k in known if _stem(k) == stem and k != key]
    if same_stem:
        return ScenarioError(
            f"{where}.{key}: wrong unit; this value must be given as '{same_stem[0]}' "
            f"(unit {_unit_of(same_stem[0]) or 'none'}). Rename the key and convert the value."
        )
    return ScenarioError(
        f"{where}.{key}: unknown key{_did_you_mean(key, known, where.split('.')[0] + '.') or '.'}"
        f" Known keys in [{where.split('.')[0]}]: {', '.join(sorted(known))}."
    )


def _did_you_mean(name: Any, known: Any, prefix: str = "", suffix: str = "") -> str:
    """'; did you mean NEAREST?' for the known name nearest a mistyped one (difflib's
    closest match, as Python's own messages pick it), '' when none is near."""
    near = difflib.get_close_matches(str(name), [str(k) for k in known], n=1)
    return f"; did you mean {prefix}{near[0]}{suffix}?" if near else ""


def _unknown_section_error(source: str, section: Any) -> ScenarioError:
    """The refusal of a section the schema does not have, with the nearest known one."""
    return ScenarioError(
        f"{source}: unknown section [{section}]{_did_you_mean(section, SCHEMA, '[', ']') or '.'}"
        f" Known sections: {', '.join(SCHEMA)}."
    )


def _convert(where: str, key: str, spec: Key, raw: Any) -> Any:
    name = f"{where}.{key}"
    if spec.kind == "str":
        if not isinstance(raw, str):
            raise ScenarioError(f"{name}: expected a string, got {_shown(raw)}.")
        if spec.choices and raw not in spec.choices:
            raise ScenarioError(f"{name}: {_shown(raw)} is not one of {', '.join(spec.choices)}.")
        return raw
    if spec.kind == "bool":
        if not isinstance(raw, bool):
            raise ScenarioError(f"{name}: expected true or false, got {_shown(raw)}.")
        return raw
    if spec.kind == "int":
        if isinstance(raw, bool) or not isinstance(raw, int):
            raise ScenarioError(f"{name}: expected a whole number, got {_shown(raw)}.")
        _check_range(name, spec, raw)
        return raw
    if spec.kind == "float":
        return _number(name, spec, raw)
    if spec.kind == "xy":
        if not isinstance(raw, list) or len(raw) != 2:
            raise ScenarioError(f"{name}: expected a pair [x, y], got {_shown(raw)}.")
        return tuple(_number(f"{name}[{i}]", spec, v) for i, v in enumerate(raw))
    raise AssertionError(spec.kind)


def _number(name: str, spec: Key, raw: Any) -> float:
    if isinstance(raw, bool) or not isinstance(raw, int | float):
        raise ScenarioError(f"{name}: expected a number, got {_shown(raw)}.")
    value = float(raw)
    if not math.isfinite(value):
        raise ScenarioError(f"{name}: {_shown(raw)} is not a finite number.")
    _check_range(name, spec, value)
    if spec.quantum is not None and 0 < abs(value) < spec.quantum:
        raise ScenarioError(
            f"{name}: {_shown(value)} is finer than the firmware carries out "
            f"({spec.quantum:g}); "
            f"use 0 or at least {spec.quantum:g}."
        )
    return value * spec.scale


def _check_range(name: str, spec: Key, value: float) -> None:
    if spec.lo is not None and value < spec.lo or spec.hi is not None and value > spec.hi:
        lo, hi = _bound(spec, spec.lo), _bound(spec, spec.hi)
        if spec.hi is None:
            allowed = f"must be at least {lo}"
        elif spec.lo is None:
            allowed = f"must be at most {hi}"
        else:
            allowed = f"is outside the allowed range [{lo}, {hi}]"
        raise ScenarioError(f"{name}: {_shown(value)} {allowed}.")


def _bound(spec: Key, bound: float | None) -> str:
    """A bound of a key's range as a message shows it: an integer with all its digits
    (scenario.seed's 9223372036854775807, not 9.22337e+18), other numbers as %g."""
    if isinstance(bound, int) or (spec.kind == "int" and bound is not None):
        return str(int(bound))
    return f"{bound:g}"


def _merge(base: dict, over: Mapping) -> dict:
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in base.items()}
    for section, table in over.items():
        if isinstance(table, dict) and isinstance(out.get(section), dict):
            out[section].update(table)
        else:
            out[section] = table
    return out


# A scenario is a short text file; anything bigger is not one (and is never read whole).
MAX_SCENARIO_BYTES = 1 << 20


def _read_toml(path: Path) -> dict:
    """A scenario file's TOML, read as an input (bounded, a regular file); ScenarioError for
    a file refused, not TOML, or nested beyond Python's recursion limit. Every reading of a
    scenario's text goes through here (load_scenario's and scenario_files')."""
    try:
        text = fileio.read_text_input(path, MAX_SCENARIO_BYTES, "scenario")
        return tomllib.loads(text)
    except fileio.FileRefused as exc:
        raise ScenarioError(str(exc)) from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}.") from None
    except RecursionError:
        raise ScenarioError(
            f"{path}: nested too deeply for a scenario (arrays or tables within each other "
            "beyond Python's recursion limit); a scenario holds numbers, pairs and tables."
        ) from None


def _read_raw(path: Path, seen: tuple[Path, ...] = ()) -> dict:
    path = path.resolve()
    if path in seen:
        raise ScenarioError(f"{path}: 'base' files form a cycle: {' -> '.join(map(str, seen))}.")
    raw = _read_toml(path)
    for section, table in raw.items():
        if not isinstance(table, dict):
            raise ScenarioError(
                f"{path}: [{section}] must be a table of keys, got {_shown(table)}."
            )
    base = raw.get("scenario", {}).pop("base", None)
    if base is None:
        return raw
    return _merge(_read_raw(_base_path(path, base), (*seen, path)), raw)


def file_keys(scenario: Scenario, section: str) -> list[str]:
    """The keys of `section` that the scenario's own file writes (not its `base` files: a
    packaged job's base carries sections that job documents as unread), sorted; [] for a
    scenario without a file. What a job that does not read a section refuses."""
    if scenario.path is None:
        return []
    path = Path(scenario.path)
    try:
        raw = tomllib.loads(fileio.read_text_input(path, MAX_SCENARIO_BYTES, "scenario"))
    except (fileio.FileRefused, tomllib.TOMLDecodeError) as exc:
        raise ScenarioError(f"{path}: {exc}") from None
    table = raw.get(section, {})
    return sorted(table) if isinstance(table, dict) else []


def _base_path(path: Path, base: Any) -> Path:
    """The file a `base = ...` names: a file in the scenario's own directory (or below it),
    an absolute path (as `transplanter tune` writes for a scenario kept elsewhere), else a
    packaged scenario by name or a packaged part by its path (`parts/pot_line.toml`: a copy
    of paper.toml elsewhere still finds its pot line); never a relative path out of the
    directory ('../x.toml')."""
    if not isinstance(base, str) or not base:
        raise ScenarioError(f"{path}: scenario.base must be a file name, got {_shown(base)}.")
    if "\0" in base:
        raise ScenarioError(
            f"{path}: scenario.base = {_shown(base)} holds a NUL byte, which no file name "
            "can; name a file beside the scenario, an absolute path or a packaged scenario."
        )
    if Path(base).is_absolute():
        return Path(base)
    candidate = (path.parent / base).resolve()
    if not candidate.is_relative_to(path.parent):
        raise ScenarioError(
            f"{path}: scenario.base = {_shown(base)} points outside the scenario's directory; "
            "name a file beside it, an absolute path or a packaged scenario (e.g. 'paper.toml')."
        )
    if candidate.exists():
        return candidate
    if len(Path(base).parts) != 1:  # a packaged part (parts/pot_line.toml) if none is here
        packaged = Path(str(importlib.resources.files("transplanter.scenarios"))) / base
        return packaged if packaged.is_file() else candidate
    return resolve_scenario_path(base)  # a packaged scenario by name


def _apply_overrides(raw: dict, overrides: Mapping[str, Any]) -> dict:
    raw = _merge(raw, {})
    for dotted, value in overrides.items():
        section, _, key = dotted.partition(".")
        if not key:
            raise ScenarioError(f"override {dotted!r}: use 'section.key'.")
        table = raw.setdefault(section, {})
        if not isinstance(table, dict):
            raise ScenarioError(f"override {dotted!r}: [{section}] is not a table.")
        table[key] = value
    return raw


def parse_value(text: str) -> Any:
    """A value as `--set` and `--vary` take it: a TOML value (30, 1.5, true, [0, 140],
    "scurve"), else the bare text as a string (scurve)."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()
    except RecursionError:
        raise ScenarioError(
            f"{_shown(text)}: nested too deeply to be a scenario value (a number, a pair "
            "[x, y], true/false or a string)."
        ) from None


def key_spec(dotted: str) -> Key:
    """The schema entry of a file key given as 'section.key'; ScenarioError naming an
    unknown section or key (with the known ones, or the right unit)."""
    section, _, name = dotted.partition(".")
    if not name:
        raise ScenarioError(f"{dotted!r}: write SECTION.KEY (e.g. taught.z_low_mm).")
    if section not in SCHEMA:
        raise _unknown_section_error(dotted, section)
    if name not in SCHEMA[section]:
        raise _unknown_key_error(section, name, SCHEMA[section])
    return SCHEMA[section][name]


def check_value(dotted: str, raw: Any) -> Any:
    """One key's value in its file unit checked on its own (kind, range, choices), returned
    in SI; ScenarioError naming the key. Checks between keys (z_up above z_low, reach) need
    the whole scenario: load_scenario."""
    spec = key_spec(dotted)
    section, _, name = dotted.partition(".")
    if spec.kind == "list":
        return _pickups(section, name, raw)
    return _convert(section, name, spec, raw)


def validate(
    raw: Mapping[str, Any], source: str = "<scenario>", unread: frozenset[str] = frozenset()
) -> dict[str, dict[str, Any]]:
    """Check a raw TOML mapping against SCHEMA and convert it to SI: {section: {field: value}}.
    A kind's section in `unread` (its kinds do not read it) that `raw` leaves out and whose
    defaults do not give every key is left out."""
    values: dict[str, dict[str, Any]] = {}
    for section in raw:
        if section not in SCHEMA:
            raise _unknown_section_error(source, section)
    for section, keys in SCHEMA.items():
        table = raw.get(section)
        if (
            table is None
            and section in unread
            and section in KIND_SECTIONS
            and not set(keys) <= set(DEFAULT_SECTIONS.get(section, {}))
        ):
            continue
        if section in DEFAULT_SECTIONS and (table is None or isinstance(table, dict)):
            table = {**DEFAULT_SECTIONS[section], **(table or {})}  # the keys left out
        if table is None:
            raise ScenarioError(f"{source}: missing section [{section}].")
        if not isinstance(table, dict):
            raise ScenarioError(
                f"{source}: [{section}] must be a table of keys, got {_shown(table)}."
            )
        for key_name in table:
            if key_name not in keys:
                raise _unknown_key_error(section, key_name, keys)
        out: dict[str, Any] = {}
        for key_name, spec in keys.items():
            if key_name not in table:
                hint = spec.doc or spec.kind
                raise ScenarioError(
                    f"{source}: {section}.{key_name} is missing; give a value ({hint})."
                )
            if spec.kind == "list":
                out[si_key(key_name)] = _pickups(section, key_name, table[key_name])
            else:
                out[si_key(key_name)] = _convert(section, key_name, spec, table[key_name])
        values[section] = out
    _cross_checks(values)
    for section, (_, declared) in KIND_SECTIONS.items():
        if section in values and declared.check is not None:
            problem = declared.check(dict(values[section]))
            if problem:
                raise ScenarioError(problem)
    return values


def _pickups(section: str, key: str, raw: Any) -> tuple[TaughtPickup, ...]:
    if not isinstance(raw, list) or not raw:
        raise ScenarioError(f"{section}.{key}: give at least one [[{section}.{key}]] table.")
    out = []
    for i, item in enumerate(raw):
        where = f"{section}.{key}[{i}]"
        if not isinstance(item, dict):
            raise ScenarioError(f"{where}: expected a table with {', '.join(PICKUP_SCHEMA)}.")
        for k in item:
            if k not in PICKUP_SCHEMA:
                raise _unknown_key_error(where, k, PICKUP_SCHEMA)
        entry = {}
        for k, spec in PICKUP_SCHEMA.items():
            if k not in item:
                raise ScenarioError(f"{where}.{k} is missing; give a value ({spec.doc}).")
            entry[si_key(k)] = _convert(where, k, spec, item[k])
        out.append(TaughtPickup(**entry))
    return tuple(out)


def pullout_torque_nm(drv: Mapping[str, Any], speed_rad_s: float) -> float:
    """The arm motor's pull-out torque (N m at its shaft) at an arm speed: the holding torque
    up to the corner speed, falling as corner / speed above it (docs/drives.md)."""
    rev_s = speed_rad_s * drv["arm_belt_ratio"] / (2.0 * math.pi)
    return drv["holding_torque_nm"] * min(1.0, drv["pullout_corner_rev_s"] / max(rev_s, 1e-12))


def _check_arm_torque_limit(drv: Mapping[str, Any]) -> None:
    """With `motion.planner = "bspline5"`, the planner's arm torque limit is a torque the
    stepper gives: at most its pull-out torque at the arms' speed limit (above it the rotor
    slips before the limit binds). The lines planner does not read it."""
    limit = drv["arm_torque_limit_nm"]
    pullout = pullout_torque_nm(drv, drv["arm_speed_limit_rad_s"])
    if limit > pullout:
        raise ScenarioError(
            f"drives.arm_torque_limit_nm = {limit:g} N m is above what the arm motor can give: "
            f"its pull-out torque at the arms' speed limit (drives.arm_speed_limit_deg_s = "
            f"{math.degrees(drv['arm_speed_limit_rad_s']):g}) is {pullout:.4g} N m "
            f"(drives.holding_torque_nm = {drv['holding_torque_nm']:g}, falling above "
            f"drives.pullout_corner_rev_s = {drv['pullout_corner_rev_s']:g} rev/s at the "
            "motor); a planned torque above it would make the rotor slip. Set "
            f"drives.arm_torque_limit_nm to at most {pullout:.4g} (the default is half the "
            "pull-out torque: a load angle of a third of a full step, docs/planner.md)."
        )


def _cross_checks(v: dict[str, dict[str, Any]]) -> None:
    lim, taught = v["limits"], v["taught"]
    for lo, hi in (
        ("motor1_min_deg", "motor1_max_deg"),
        ("motor2_min_deg", "motor2_max_deg"),
        ("elbow_min_deg", "elbow_max_deg"),
        ("transmission_min_deg", "transmission_max_deg"),
        ("z_min_mm", "z_max_mm"),
    ):
        if lim[si_key(lo)] >= lim[si_key(hi)]:
            raise ScenarioError(f"limits.{lo} must be below limits.{hi}.")
    z_min, z_max = lim["z_min_m"], lim["z_max_m"]
    for key in ("z_up_mm", "z_low_mm"):
        if not z_min <= taught[si_key(key)] <= z_max:
            raise ScenarioError(
                f"taught.{key} = {taught[si_key(key)] * 1e3:g} mm is outside "
                f"[limits.z_min_mm, limits.z_max_mm] = [{z_min * 1e3:g}, {z_max * 1e3:g}] mm."
            )
    if taught["z_up_m"] <= taught["z_low_m"]:
        raise ScenarioError("taught.z_up_mm must be above taught.z_low_mm.")
    if len(taught["pickup"]) > MAX_PICKUPS:
        raise ScenarioError(
            f"taught.pickup: the EEPROM holds at most {MAX_PICKUPS} pickup points, "
            f"got {len(taught['pickup'])}."
        )
    if v["arm"]["working_mode"] != "+-":
        raise ScenarioError(
            f"arm.working_mode = {v['arm']['working_mode']!r}: the MJCF model is assembled in the "
            "paper's working mode '+-' (elbows out, eqs 6-7); the five-bar kinematics solves "
            "all four modes, but the twin can only run '+-'."
        )
    drv = v["drives"]
    for key, lo, hi, window in (
        ("switch1_theta1_deg", "motor1_min_deg", "motor1_max_deg", "limits"),
        ("switch2_theta2_deg", "motor2_min_deg", "motor2_max_deg", "limits"),
    ):
        if not lim[si_key(lo)] <= drv[si_key(key)] <= lim[si_key(hi)]:
            raise ScenarioError(
                f"drives.{key} (a limit switch) must lie inside {window}.{lo}..{hi}."
            )
    if v["motion"]["planner"] == "bspline5":  # the limit is the spline planner's alone
        _check_arm_torque_limit(drv)
    if not z_min < drv["switch3_z_m"] <= z_max:
        raise ScenarioError(
            "drives.switch3_z_mm (limit switch 3) must lie in (limits.z_min_mm, limits.z_max_mm]."
        )
    pots = v["pots"]
    if pots["mass_min_kg"] > pots["mass_kg"] or pots["mass_kg"] > pots["mass_max_kg"]:
        raise ScenarioError("pots.mass_g must lie within [pots.mass_min_g, pots.mass_max_g].")
    if pots["friction"] == 0 and pots["friction_sd"] > 0:
        raise ScenarioError(
            "pots.friction_sd > 0 with pots.friction = 0: frictions are drawn from a gamma "
            "distribution (never below 0) with that mean and sd; a mean of 0 has no spread. "
            "Set friction_sd = 0 (frictionless pots) or raise friction."
        )
    conv = v["conveyor"]
    cells = conv["rows"] * conv["cols"]
    on_conveyor = v["workcell"]["kind"] == "conveyor_tube"  # the plug jobs have no conveyor
    if on_conveyor and v["scenario"]["seedlings"] > cells:
        raise ScenarioError(
            f"scenario.seedlings = {v['scenario']['seedlings']} is more than the conveyor holds "
            f"(conveyor.rows x conveyor.cols = {cells} pots)."
        )
    if conv["live_rows"] < conv["rows"]:
        from transplanter.scene.config import min_live_rows, settle_pushes

        least, pushes = min_live_rows(pots["feet"]), settle_pushes(pots["feet"])
        if conv["live_rows"] < least:
            stand = f"on {pots['feet']} feet (pots.feet)" if pots["feet"] else "on their cylinders"
            raise ScenarioError(
                f"conveyor.live_rows = {conv['live_rows']} is below the minimum of {least} for "
                f"conveyor.rows = {conv['rows']} with pots {stand}: the pickup row, the row "
                f"just picked and enough rows upstream that every pot gets {pushes} index "
                f"pushes before its pickup. Set live_rows >= {least}, or >= rows (every pot a "
                "body)."
            )
        if pots["bond_share"] > 0 or pots["crooked_share"] > 0 or pots["canopy_contact"]:
            raise ScenarioError(
                f"conveyor.live_rows = {conv['live_rows']} < conveyor.rows = {conv['rows']} "
                "reuses pot bodies, which holds only straight, unbonded pots without canopy "
                "contact; with pots.bond_share > 0, pots.crooked_share > 0 or "
                "pots.canopy_contact, set conveyor.live_rows >= conveyor.rows."
            )
    if pots["feet"] in (1, 2):
        raise ScenarioError(
            f"pots.feet = {pots['feet']}: a pot does not stand on fewer than 3 feet. Set 0 (its "
            "cylinder stands on the table) or 3 to 16."
        )
    if conv["index_time_s"] < 0.2:
        raise ScenarioError("conveyor.index_time_s must be at least 0.2 s (push and settle).")
    grip = v["gripper"]
    if grip["close_rad"] >= grip["open_rad"]:
        raise ScenarioError("gripper.close_deg must be below gripper.open_deg (smaller opening).")
    _check_faults(v["faults"])
    _check_plugs(v["plugs"], v.get("plug_claws"))
    bench = v.get("plug_bench")
    band = bench["moisture_band_pct"] / 2 if bench else 0.0
    moisture = v["plugs"]["moisture_pct"]
    if v["workcell"]["kind"] == "plug_bench" and not 0 < moisture - band <= moisture + band < 100:
        raise ScenarioError(
            f"plugs.moisture_pct +- plug_bench.moisture_band_pct / 2 = "
            f"{v['plugs']['moisture_pct']:g} +- {band:g} % leaves (0, 100) %: a plug's "
            "moisture is drawn in that band; narrow it."
        )


CELL_DEPTH_M = 0.042
"""Depth of a cell of the paper's 128-cell tray (`PlugsConfig.depth_mm`; not a key)."""


def _check_plugs(plugs: dict[str, Any], claws: dict[str, Any] | None) -> None:
    """The plugs in their cells, and the claws' tips in the plugs (the claws' section where a
    scenario holds it)."""
    tips = claws["tray_substrate_below_top_m"] + claws["insertion_depth_m"] if claws else 0.0
    if tips >= CELL_DEPTH_M:
        raise ScenarioError(
            f"plug_claws.tray_substrate_below_top_mm + plug_claws.insertion_depth_mm = "
            f"{tips * 1e3:g} mm: the claws' tips would reach the floor of the "
            f"{CELL_DEPTH_M * 1e3:g} mm deep cell; make them shallower."
        )
    height = CELL_DEPTH_M - plugs["surface_below_top_m"]
    if plugs["core_top_depth_m"] >= height:
        raise ScenarioError(
            f"plugs.core_top_depth_mm = {plugs['core_top_depth_m'] * 1e3:g} mm is below the "
            f"plug's bottom ({height * 1e3:g} mm: the {CELL_DEPTH_M * 1e3:g} mm cell less "
            "plugs.surface_below_top_mm); the pin socket must lie inside the plug."
        )


def _check_faults(f: dict[str, Any]) -> None:
    if f["switch_dead"] == 4:
        raise ScenarioError(
            "faults.switch_dead = 4: limit switch 4 (Z down) is not used in homing, so a dead "
            "switch 4 would change nothing; choose a homing switch 1-3, or 0 for none (a stuck "
            "closed switch 4 is faults.switch_stuck_closed = 4)."
        )
    if f["switch_dead"] and f["switch_dead"] == f["switch_stuck_closed"]:
        raise ScenarioError(
            f"faults.switch_dead and faults.switch_stuck_closed both name limit switch "
            f"{f['switch_dead']}: a switch cannot be dead and stuck closed; set one to 0."
        )
    jam = (f["jam_torque_nm"], f["jam_duration_s"])
    if f["jam_motor"] and not all(v > 0 for v in jam):
        raise ScenarioError(
            f"faults.jam_motor = {f['jam_motor']} needs faults.jam_torque_nm > 0 and "
            "faults.jam_duration_s > 0 to jam anything; give both, or set jam_motor = 0."
        )
    if not f["jam_motor"] and any(v > 0 for v in jam):
        raise ScenarioError(
            "faults.jam_torque_nm or faults.jam_duration_s is set but faults.jam_motor = 0 "
            "(no jam): name the motor that jams (1 arm 1, 2 arm 2, 3 Z) or set both to 0."
        )


def packaged_scenarios() -> list[str]:
    """Names of the scenarios shipped with the package (`paper`, ...)."""
    root = importlib.resources.files("transplanter.scenarios")
    return sorted(p.name[: -len(".toml")] for p in root.iterdir() if p.name.endswith(".toml"))


def resolve_scenario_path(name: str | Path) -> Path:
    """A scenario file: the path as given if it exists, else a packaged scenario by name
    (`paper` or `paper.toml`)."""
    if "\0" in str(name):
        raise ScenarioError(
            f"{_shown(str(name))}: a scenario's name holds a NUL byte, which no file name "
            "can; give a scenario file or a packaged scenario's name (transplanter scenarios)."
        )
    path = Path(name)
    if path.exists() or len(path.parts) != 1:
        return path
    stem = path.name[: -len(".toml")] if path.name.endswith(".toml") else path.name
    packaged = importlib.resources.files("transplanter.scenarios") / f"{stem}.toml"
    if packaged.is_file():
        return Path(str(packaged))
    known = packaged_scenarios()
    raise ScenarioError(
        f"{name}: no such scenario file, and no packaged scenario of that name"
        f"{_did_you_mean(stem, known)} (packaged: {', '.join(known)})."
    )


def scenario_files(name: str | Path) -> list[Path]:
    """The files a scenario is read from: its own and its `base` chain's, in that order (the
    files no command may write over). Stops quietly where the chain cannot be followed:
    load_scenario says why."""
    files: list[Path] = []
    try:
        path = resolve_scenario_path(name)
        while path.resolve() not in files:
            files.append(path.resolve())
            base = _read_toml(path).get("scenario", {}).get("base")  # load_scenario's guards
            if base is None:
                break
            path = _base_path(path.resolve(), base)
    except (ScenarioError, AttributeError):
        pass
    return files


REFERENCE_SCENARIO = "paper"
"""The packaged scenario whose values fill a section that a scenario neither gives nor reads
(the five-bar's [arm], [taught], ... in a delta's scenario): a Scenario has every section,
and one its kinds do not read is never used (`transplanter.kinds`)."""


def _kinds_of(raw: Mapping[str, Any], source: str) -> tuple[str, str, str]:
    """The robot, effector and job kinds a raw scenario names (defaults where it names
    none); ScenarioError for a kind no registry knows, with the nearest known name."""
    out = []
    for section in ("robot", "effector", "workcell"):
        table = raw.get(section, {})
        value = table.get("kind", DEFAULT_SECTIONS[section]["kind"])
        name = _convert(section, "kind", SCHEMA[section]["kind"], value)
        category = "job" if section == "workcell" else section
        try:
            kinds.get(category, name)
        except kinds.UnknownKind as exc:
            raise ScenarioError(f"{source}: {exc}.") from None
        out.append(name)
    return out[0], out[1], out[2]


def _refuse_unread(
    raw: Mapping[str, Any], overrides: Mapping[str, Any], source: str
) -> tuple[str, str, str]:
    """Refuse a key that no kind of the scenario reads (a value the run would ignore), naming
    who reads it; the scenario's kinds otherwise. Unknown sections and keys are refused first,
    with their own messages."""
    for section, table in raw.items():
        if section not in SCHEMA:
            raise _unknown_section_error(source, section)
        if isinstance(table, dict):
            for key_name in table:
                if key_name not in SCHEMA[section]:
                    raise _unknown_key_error(section, key_name, SCHEMA[section])
    robot, effector, job = _kinds_of(raw, source)
    if kinds.job(job).refusal(robot, effector) is not None:
        # a combination the job cannot run: what it would read is undefined, and the trial
        # refuses it with the job's reason before any step (`ik` and `plan` need only the
        # robot's kinematics)
        return robot, effector, job
    given = {s: list(t) for s, t in raw.items() if isinstance(t, dict)}
    unread = kinds.unread_keys(given, robot, effector, job)
    if unread:
        n = len(unread)
        by_set = [u for u in unread if f"{u[0]}.{u[1]}" in overrides]
        where = "given by --set" if len(by_set) == n else (
            "given in the scenario file or its base chain" if not by_set
            else "given in the scenario file, its base chain or by --set"
        )  # fmt: skip
        them = "them" if n > 1 else "it"
        raise ScenarioError(
            f"{source}: {n} key{'s' if n > 1 else ''} {where} that no kind of this scenario "
            f"reads (robot {robot}, effector {effector}, workcell {job}), so the run would "
            f"ignore {them}: {kinds.describe_unread(unread)}. Remove {them}, or run a "
            f"scenario of the kinds that read {them} (`transplanter scenarios` lists them)."
        )
    return robot, effector, job


_REFERENCE_RAW: dict[str, Any] | None = None


def _with_unread_sections(raw: dict, robot: str, effector: str, job: str) -> dict:
    """`raw` with every key it lacks that its kinds do not read (whole sections, or the rest
    of a section they read in part: the five-bar's [arm] and [taught] in a delta's scenario,
    [bus] line_numbers beside its baud_bps) filled from the reference scenario
    (REFERENCE_SCENARIO): present, valid and never used. A key its kinds read must be given
    (or have a default)."""
    global _REFERENCE_RAW
    runs = kinds.job(job).refusal(robot, effector) is None
    # a combination the job cannot run reads nothing: filled whole, its trial refuses it
    table = kinds.reads(robot, effector, job) if runs else {}
    out = dict(raw)
    for section, keys in SCHEMA.items():
        read = table.get(section, ())
        if read == kinds.ALL or section in KIND_SECTIONS:
            continue  # a kind's own section: its defaults fill it, or it is left out
        have = out.get(section)
        if have is not None and not isinstance(have, dict):
            continue  # validate says why
        defaults = DEFAULT_SECTIONS.get(section, {})
        lacking = [k for k in keys if k not in (have or {}) and k not in defaults and k not in read]
        if not lacking:
            continue
        if _REFERENCE_RAW is None:
            _REFERENCE_RAW = _read_raw(resolve_scenario_path(REFERENCE_SCENARIO))
        reference = _REFERENCE_RAW.get(section, {})
        out[section] = {**{k: reference[k] for k in lacking if k in reference}, **(have or {})}
    return out


def units_key(path: str | Path, overrides: Mapping[str, Any] | None = None) -> str:
    """The key that `--seedlings N` sets for the scenario's job: how many units a run does
    (`scenario.seedlings` for the pot line and the claws' bench, `delta_refill.max_cells`
    for the trays, `pool_to_belt.count` for the tomatoes); from the kinds the file (and
    `overrides`) name, before the scenario is validated (ScenarioError for a file that does
    not load or an unknown kind)."""
    path = resolve_scenario_path(path)
    raw = _read_raw(path)
    if overrides:
        raw = _apply_overrides(raw, {k: v for k, v in overrides.items() if k.endswith(".kind")})
    job = _kinds_of(raw, str(path))[2]
    return kinds.job(job).UNITS_KEY


def with_units(
    path: str | Path,
    overrides: Mapping[str, Any] | None,
    units: int | None,
    keep_given: bool = False,
) -> dict[str, Any]:
    """`overrides` with `units` (None: the scenario's own) as the job's unit count
    (`units_key`). The key given in `overrides` too is refused (ScenarioError: two values
    for one count), or with `keep_given` kept (a comparison's --set for one job is more
    particular than its --seedlings for all)."""
    out = dict(overrides or {})
    if units is not None:
        key = units_key(path, out)
        if key in out and not keep_given:
            if out[key] != units:
                raise ScenarioError(
                    f"--seedlings {units} and {key} = {out[key]} both give how many units "
                    "the job does: give one"
                )
        elif key not in out:
            out[key] = units
    return out


def read_overrides(path: str | Path, overrides: Mapping[str, Any]) -> dict[str, Any]:
    """The overrides of `overrides` that the scenario's kinds read (`transplanter kinds`):
    what a `--set` given to several scenarios at once (`transplanter compare`) means for
    this one; the kinds from the file and the overrides' `*.kind` keys."""
    path = resolve_scenario_path(path)
    raw = _read_raw(path)
    raw = _apply_overrides(raw, {k: v for k, v in overrides.items() if k.endswith(".kind")})
    robot, effector, job = _kinds_of(raw, str(path))
    if kinds.job(job).refusal(robot, effector) is not None:
        return dict(overrides)  # the scenario's own refusal says why it cannot run
    table = kinds.reads(robot, effector, job)
    out = {}
    for dotted, value in overrides.items():
        section, _, key = dotted.partition(".")
        keys = table.get(section, ())
        if keys == kinds.ALL or key in keys:
            out[dotted] = value
    return out


IDENTITY_SKIP = {"scenario": ("name", "description", "seed", "seedlings"), "costs": kinds.ALL}
"""What a study's identity leaves out of the keys a scenario reads: its name, description,
seed and unit count (a study sets or reports them itself) and what the drives cost (not
physics: no result depends on it)."""


def read_values(scenario: Scenario) -> tuple[tuple[str, Any], ...]:
    """('section.key', SI value) of every key the scenario's kinds read (`transplanter.kinds`),
    in the schema's order, less IDENTITY_SKIP: what its results depend on. A combination its
    job refuses reads nothing defined: every key then."""
    robot, effector, job = scenario.robot.kind, scenario.effector.kind, scenario.workcell.kind
    runs = kinds.job(job).refusal(robot, effector) is None
    table = kinds.reads(robot, effector, job) if runs else {s: kinds.ALL for s in SCHEMA}
    out = []
    for section, keys in SCHEMA.items():
        read = table.get(section)
        skip = IDENTITY_SKIP.get(section, ())
        if read is None or skip == kinds.ALL or not scenario.has_section(section):
            continue
        for name in keys if read == kinds.ALL else read:
            if name not in skip:
                out.append((f"{section}.{name}", scenario.get(f"{section}.{name}")))
    return tuple(out)


def scenario_digest(scenario: Scenario) -> str:
    """A digest of `read_values`: two scenarios with the same digest run the same physics
    (what a resumed sweep, tune or calibration must share)."""
    import hashlib

    return hashlib.sha256(repr(read_values(scenario)).encode()).hexdigest()


def units_of(scenario: Scenario) -> int:
    """How many units the scenario's job does in a run, as its `units_key` holds it (the
    trays' `max_cells` 0: every cell the grading finds)."""
    return int(scenario.get(kinds.job(scenario.workcell.kind).UNITS_KEY))


def load_scenario(path: str | Path, overrides: Mapping[str, Any] | None = None) -> Scenario:
    """Read, merge (`base`), override (`{"taught.s_high_mm_s": 200}`, file units) and
    validate a scenario file, or a packaged scenario by name (`paper`). A key that no kind of
    the scenario (`[robot]`, `[effector]`, `[workcell]`; `transplanter.kinds`) reads is
    refused, naming who reads it; a section it neither gives nor reads is filled with the
    reference scenario's values, never used."""
    path = resolve_scenario_path(path)
    raw = _read_raw(path)
    if overrides:
        raw = _apply_overrides(raw, overrides)
    robot, effector, job = _refuse_unread(raw, overrides or {}, str(path))
    raw = _with_unread_sections(raw, robot, effector, job)
    runs = kinds.job(job).refusal(robot, effector) is None
    table = kinds.reads(robot, effector, job) if runs else {}
    values = validate(raw, str(path), frozenset(s for s in KIND_SECTIONS if s not in table))
    sections = {
        ("meta" if k == "scenario" else k): SECTIONS[k](**v)
        for k, v in values.items()
        if k not in KIND_SECTIONS
    }
    own = tuple((k, SECTIONS[k](**v)) for k, v in values.items() if k in KIND_SECTIONS)
    return Scenario(
        path=path, overrides=tuple((overrides or {}).items()), kind_sections=own, **sections
    )
