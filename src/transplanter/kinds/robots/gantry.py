"""A Cartesian gantry of catalogue linear modules: belt-driven X and Y, a lead-screw Z, three
NEMA17 steppers on the five-bar's controller (the SGF's Bresenham lines with the identity as
its IK, the same torque law, homing switches). The commonest low-cost design of greenhouse
transplanting research; its numbers are estimates (docs/gantry.md)."""

from dataclasses import dataclass

from transplanter.kinds.interfaces import ALL
from transplanter.kinds.sections import Section, key

NAME = "gantry"
SUMMARY = "Cartesian gantry: belt X and Y, lead-screw Z, stepper-driven (estimates)"
KINEMATICS = "transplanter.machine.kinematics.gantry:GantryKinematics"
SCENE = "transplanter.scene.robots.gantry"
MODEL = "gantry"
CONTROLLER = "sgf"
READS = {
    "gantry": ALL,  # travel, belts, moving masses, guides, homing rates
    # the steppers of [drives] (the five-bar's arm keys are not the gantry's)
    "drives": (
        "steps_per_rev",
        "microsteps",
        "z_lead_mm",
        "max_step_rate_hz",
        "holding_torque_nm",
        "rotor_inertia_kgm2",
        "detent_torque_nm",
        "pullout_corner_rev_s",
        "rotor_damping_ratio",
        "screw_efficiency",
        "homing_debounce_ms",
    ),
    # the SGF's lines: Bresenham grid, profile, IK time per point
    "motion": ("resolution_mm", "accel_mm_s2", "profile", "compute_time_per_point_us"),
    "recovery": ALL,  # the drivers' stall detection, the PGF's re-homes
    "faults": ALL,  # faults injected into its switches, motors and bus
}


@dataclass(frozen=True)
class GantrySection:
    """[gantry]: the Cartesian gantry of linear modules (`[robot] kind = "gantry"`): belt X
    and Y, lead-screw Z, read by its kinematics and its scene; its motors are [drives]'
    (docs/gantry.md gives each number's source). Optional: default a catalogue build."""

    x_min_m: float = key("float", -2000, 2000, doc="X travel's low end: X's homing switch")
    x_max_m: float = key("float", -2000, 2000, doc="X travel's high end (the grip centre's x)")
    y_min_m: float = key("float", -2000, 2000, doc="Y travel's low end: Y's homing switch")
    y_max_m: float = key("float", -2000, 2000, doc="Y travel's high end (the grip centre's y)")
    z_min_m: float = key("float", 0, 2000, doc="Z's lowest grip height: limit switch 4 (Z down)")
    z_max_m: float = key("float", 0, 2000, doc="Z's highest grip height: Z's homing switch")
    belt_lead_m: float = key(
        "float", 1, 1000, doc="X and Y belt travel per motor revolution (GT2, 20 teeth: 40 mm)"
    )
    belt_microsteps: int = key("int", lo=1, hi=256, doc="the X and Y drivers' microsteps")
    bridge_mass_kg: float = key(
        "float", 0.01, 100, doc="what X moves besides Y's load: the Y module, its motor, belt"
    )
    carriage_mass_kg: float = key(
        "float", 0.01, 100, doc="what Y moves besides Z's load: the carriage and the Z module"
    )
    ram_mass_kg: float = key("float", 0.01, 100, doc="the Z slide that carries the effector")
    guide_friction_n: float = key(
        "float", 0, 1000, doc="each X and Y guide's friction (Coulomb, at the carriage)"
    )
    beam_height_m: float = key(
        "float", 10, 5000, doc="the Y beam above the belt's top (the portal's height)"
    )
    homing_rate_xy_hz: float = key(
        "float", 1, 1e6, doc="X and Y step rate while G28 seeks their switches and pulls off"
    )
    homing_rate_z_hz: float = key("float", 1, 1e6, doc="Z step rate while G28 seeks switch 3")
    homing_locate_rate_xy_hz: float = key(
        "float", 1, 1e6, doc="X and Y step rate in the slow second homing pass"
    )
    homing_locate_rate_z_hz: float = key(
        "float", 1, 1e6, doc="Z step rate in the slow second homing pass"
    )


def _check(g: dict) -> str | None:
    for axis in "xyz":
        if g[f"{axis}_min_m"] >= g[f"{axis}_max_m"]:
            return f"gantry.{axis}_min_mm must be below gantry.{axis}_max_mm."
    return None


SECTIONS = {
    "gantry": Section(
        GantrySection,
        defaults={  # estimates of catalogue linear modules (docs/gantry.md)
            "x_min_mm": -150.0,
            "x_max_mm": 150.0,
            "y_min_mm": 40.0,
            "y_max_mm": 300.0,
            "z_min_mm": 5.0,
            "z_max_mm": 160.0,
            "belt_lead_mm": 40.0,
            "belt_microsteps": 8,
            "bridge_mass_kg": 1.2,
            "carriage_mass_kg": 0.6,
            "ram_mass_kg": 0.25,
            "guide_friction_n": 3.0,
            "beam_height_mm": 400.0,
            "homing_rate_xy_hz": 1600.0,  # 4000 (100 mm/s) slips X from rest (docs/gantry.md)
            "homing_rate_z_hz": 16000.0,
            "homing_locate_rate_xy_hz": 160.0,
            "homing_locate_rate_z_hz": 1600.0,
        },
        check=_check,
    )
}
"""Its own section, `[gantry]`: every key has a default (a catalogue build)."""
