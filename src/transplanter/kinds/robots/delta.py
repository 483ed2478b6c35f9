"""The rotary delta of seed 002 (Zhao, Cheng, Dong, Ma, Xiong and Tong 2022): three
reducer-geared servo arms, pulse-train drives, the controller's B-spline transfers."""

from dataclasses import dataclass

from transplanter.kinds.interfaces import ALL
from transplanter.kinds.sections import Section, key

NAME = "delta"
SUMMARY = "rotary delta on pulse-train AC servos with quintic B-spline transfers (seed 002)"
KINEMATICS = "transplanter.machine.kinematics.delta:DeltaKinematics"
SCENE = "transplanter.scene.robots.delta"
MODEL = "delta"
CONTROLLER = "delta"
READS = {
    "delta": ALL,  # geometry, joint window, drives
    # the controller's planner and end-effector limit; its lines' grid, acceleration and
    # point time are the job's (the job section's segment_mm, path_accel_mm_s2, point_time_us)
    "motion": ("planner", "ee_accel_limit_mm_s2"),
}


@dataclass(frozen=True)
class DeltaSection:
    """[delta]: the rotary delta's geometry, joint window and servo drives (`[robot] kind =
    "delta"`; read only by its kinematics). Optional: the defaults are estimates for the robot
    of Zhao et al. 2022, whose text gives no dimensions (docs/delta.md)."""

    base_radius_m: float = key("float", 1, 2000, doc="R: base centre to each arm's joint")
    platform_radius_m: float = key("float", 1, 2000, doc="r: platform centre to each follower")
    upper_arm_m: float = key("float", 1, 3000, doc="l1: active arm")
    forearm_m: float = key("float", 1, 5000, doc="l2: follower parallelogram")
    q_min_rad: float = key("float", -90, 90, doc="lowest arm angle (below the base positive)")
    q_max_rad: float = key("float", -90, 90, doc="highest arm angle")
    max_condition: float = key("float", 1, 1e6, doc="largest Jacobian condition number")
    z_min_m: float = key("float", -10000, 0, doc="lowest platform Z a move may target")
    z_max_m: float = key("float", -10000, 0, doc="highest platform Z a move may target")
    home_q_rad: float = key("float", -90, 90, doc="arm angle at which each homing switch trips")
    gear_ratio: float = key("float", 0.01, 1000, doc="motor revolutions per arm revolution")
    pulses_per_rev: int = key("int", lo=1, hi=10**7, doc="command pulses per motor revolution")
    max_joint_speed_rad_s: float = key("float", 1, 1e5, doc="V_max at the joint")
    max_joint_accel_rad_s2: float = key("float", 1, 1e7, doc="A_max at the joint")
    joint_torque_limit_nm: float = key("float", 0.01, 10000, doc="tau_max at the joint")
    rotor_inertia_kgm2: float = key("float", 1e-9, 1, doc="servo motor rotor inertia")
    upper_arm_mass_kg: float = key("float", 1e-4, 100, doc="m_a: one active arm")
    elbow_mass_kg: float = key("float", 1e-4, 100, doc="m_b: one elbow's spherical hinges")
    forearm_mass_kg: float = key("float", 1e-4, 100, doc="m_c: one follower parallelogram")
    platform_mass_kg: float = key("float", 1e-4, 100, doc="m_move: platform and effector")
    homing_rate_hz: float = key("float", 1, 1e7, doc="pulse rate while seeking the switches")
    homing_locate_rate_hz: float = key("float", 1, 1e7, doc="slow second homing pass")


_DELTA_DEFAULTS = {
    "base_radius_mm": 200.0,
    "platform_radius_mm": 50.0,
    "upper_arm_mm": 350.0,
    "forearm_mm": 800.0,
    "q_min_deg": -40.0,
    "q_max_deg": 80.0,
    "max_condition": 20.0,
    "z_min_mm": -1050.0,
    "z_max_mm": -500.0,
    "home_q_deg": -30.0,
    "gear_ratio": 25.0,
    "pulses_per_rev": 2000,
    "max_joint_speed_deg_s": 720.0,
    "max_joint_accel_deg_s2": 2500.0,
    "joint_torque_limit_nm": 12.0,
    "rotor_inertia_kgm2": 1.5e-4,
    "upper_arm_mass_kg": 0.30,
    "elbow_mass_kg": 0.05,
    "forearm_mass_kg": 0.20,
    "platform_mass_kg": 1.00,
    "homing_rate_hz": 5000.0,
    "homing_locate_rate_hz": 500.0,
}


SECTIONS = {
    "delta": Section(DeltaSection, defaults=_DELTA_DEFAULTS),
}
"""Its own sections (transplanter.kinds.sections)."""
