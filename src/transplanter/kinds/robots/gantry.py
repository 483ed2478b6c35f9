"""A Cartesian gantry of catalogue linear modules: belt-driven X and Y, a lead-screw Z, three
NEMA17 steppers on the five-bar's controller (the SGF's Bresenham lines with the identity as
its IK, the same torque law, homing switches). The commonest low-cost design of greenhouse
transplanting research; its numbers are estimates (docs/gantry.md)."""

from transplanter.kinds.interfaces import ALL

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
