"""SceneConfig: every physical number of the scene, and the scene's named constants.

SceneConfig() holds the design defaults (docs/sources.md); the models' XML (models/fivebar/,
models/workcells/conveyor_tube/) carries exactly these defaults (scripts/make_models.py writes
them there), and build_scene applies any other config.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from transplanter.machine.kinematics.fivebar import FiveBarGeometry, FiveBarKinematics
from transplanter.scene.stepper import StepperParams

# Collision bits (contype/conaffinity): 1 world/static, 2 pots, 4 gripper; each conveyor row
# r has the bit ROW_BIT_FIRST + r % ROW_BITS (bits 8..30; bit 31 would overflow MuJoCo's
# signed 32-bit contype), shared by its ribs and pots. Rows ROW_BITS apart share a bit: they
# are ROW_BITS row pitches (over a metre) apart on the belt, so their ribs and pots never meet.
BIT_WORLD = 1
BIT_POT = 2
BIT_GRIPPER = 4
BIT_CANOPY = 8  # leaf proxies (with SceneConfig.canopy_contact): they touch the jaws only
# Pots on feet (SceneConfig.pot_feet): the feet and bond pads are BIT_FOOT, which only the belt
# table has in its conaffinity (it loses BIT_POT); the pots' cylinders then collide as
# BIT_WORLD | BIT_POT | their row's bit with conaffinity BIT_POT | BIT_GRIPPER, so they meet
# everything they met before (static geoms, pots, jaws, ribs, the other kinds' links) but
# the table (contype BIT_WORLD, as before: the serial arm's and the delta's links still meet it).
BIT_FOOT = 32
ROW_BIT_FIRST = 8
ROW_BITS = 23


# An index pushes every pot of the belt across its cell's play; the sideways spread of the
# pots' offsets grows with each push from rest and settles after about this many (a pot's
# cylinder on the table: sd 0.89, 1.31, 1.67, 1.98, 2.02, 2.05 mm after 0-5 pushes; on feet,
# SceneConfig.pot_feet, the jostle is smaller and settles later: 1.01, 1.65, 1.99, 2.10 mm
# after 1, 4, 8 and 10 pushes, 2.2 from about 15 on; docs/performance.md, "The window of
# live rows").
SETTLE_PUSHES = 4
SETTLE_PUSHES_ON_FEET = 10
# The fewest live rows of a windowed scene: a row enters when the row before the pickup row
# has left the physics, so it gets live_rows - 1 pushes before its pickup, live_rows - 2 when
# a failed pot of the row just picked still moves at that index (it waits for the next).
MIN_LIVE_ROWS = SETTLE_PUSHES + 2
MIN_LIVE_ROWS_ON_FEET = SETTLE_PUSHES_ON_FEET + 2


def settle_pushes(pot_feet: int) -> int:
    """The index pushes that settle a pot's sideways offset (on its cylinder or on feet)."""
    return SETTLE_PUSHES_ON_FEET if pot_feet else SETTLE_PUSHES


def min_live_rows(pot_feet: int) -> int:
    """The fewest live rows of a windowed scene whose pots stand on `pot_feet` feet."""
    return MIN_LIVE_ROWS_ON_FEET if pot_feet else MIN_LIVE_ROWS


def window_problem(cfg: SceneConfig) -> str:
    """Why a scene with cfg.live_rows < cfg.rows cannot be windowed ('' when it can)."""
    least, pushes = min_live_rows(cfg.pot_feet), settle_pushes(cfg.pot_feet)
    if cfg.live_rows < least:
        stand = f"on {cfg.pot_feet} feet" if cfg.pot_feet else "on their cylinders"
        return (
            f"conveyor.live_rows = {cfg.live_rows} is below the minimum of {least} for "
            f"conveyor.rows = {cfg.rows} with pots {stand}: the pickup row, the row just "
            f"picked and enough rows upstream that every pot gets {pushes} index pushes before "
            f"its pickup; set live_rows to at least {least} (or to rows: every pot a body)"
        )
    if cfg.pot_bond_share > 0 or cfg.canopy_contact or cfg.pot_crooked_share > 0:
        return (
            f"conveyor.live_rows = {cfg.live_rows} < conveyor.rows = {cfg.rows} reuses pot "
            "bodies, which holds only straight, unbonded pots without canopy contact (a bond's "
            "pad and adhesion actuator, a crooked pot's foot and the leaf proxies are bodies, "
            "geoms and actuators of their own); with pots.bond_share > 0, "
            "pots.crooked_share > 0 or pots.canopy_contact set live_rows >= rows"
        )
    return ""


def row_bit(row: int) -> int:
    """The collision bit of conveyor row `row` (its ribs' conaffinity, in its pots' contype)."""
    return 1 << (ROW_BIT_FIRST + row % ROW_BITS)


# Torsional and rolling friction of every contact pair the scene adds (ribs, pots, jaws).
TORSIONAL_FRICTION = 0.005
ROLLING_FRICTION = 0.0001

# A soaked pot's contact impedance at no penetration and once it has given
# SceneConfig.pot_soft_wall_m (MuJoCo solimp d0, dwidth; midpoint and power as the firm pots').
SOFT_WALL_IMPEDANCE = (0.05, 0.95)

# Colours (rgba) of the geoms the scene adds: ribs, pot collision cylinders (shown in group
# 3 with the other collision geoms), leaf proxies (group 4) and drop tube walls.
RIB_RGBA = (0.2, 0.2, 0.2, 1.0)
POT_COLLISION_RGBA = (0.55, 0.4, 0.25, 0.5)
LEAF_PROXY_RGBA = (0.2, 0.8, 0.2, 0.3)
STATIC_COLLISION_RGBA = (0.5, 0.5, 0.55, 0.3)

# Gripper layout of models/effectors/parallel_jaw/parallel_jaw.xml (m): the column runs from
# just under the wrist servo (WRIST_SERVO_BOTTOM below C) down to the top of the palm, a bridge
# plate BRIDGE_THICKNESS thick whose underside sits SceneConfig.bridge_clearance_m above the grip
# centre; the jaws (JAW_HALF_HEIGHT either side of the grip centre) hang from it on side
# plates, so the seedling's shoot stands free between them under the bridge. The jaws start
# JAW_HALF_THICKNESS off the centre. Passive links run PASSIVE_DROP below the active ones
# (visual only: the arm links never collide).
WRIST_SERVO_BOTTOM = 0.042
JAW_HALF_HEIGHT = 0.0225
BRIDGE_THICKNESS = 0.006
JAW_HALF_THICKNESS = 0.0015
PASSIVE_DROP = 0.015

# Seedling drawing and leaf proxies, in the pot body frame. Leaf k of a seedling sits at
# the stem height times LEAF_BASE_LOW (even k) or LEAF_BASE_LOW + LEAF_BASE_STEP (odd k),
# pitched LEAF_PITCH_RAD about its y axis (tipped up: the mesh runs along +x), yawed evenly
# around the stem. Its capsule proxy is centred LEAF_PROXY_CENTRE (leaf frame) from the leaf
# base, along the leaf (the middle of the 45 mm blade of seedling_leaf.stl, 4 mm up).
LEAF_BASE_LOW = 0.7
LEAF_BASE_STEP = 0.3
LEAF_PITCH_RAD = -0.35
LEAF_PROXY_CENTRE = (0.0225, 0.0, 0.004)
# The shoot's centre of mass sits at this share of the stem's height (the leaves' bases lie
# at 0.7 and 1.0 of it); its leaves spread over a disc of SHOOT_SPREAD diameter (m; two 45 mm
# blades tip to tip, tipped up by LEAF_PITCH_RAD).
SHOOT_COM_SHARE = 0.85
SHOOT_SPREAD = 0.085
# A crooked pot's flat foot (m): the wall above it leans (SceneConfig.pot_crooked_share).
CROOKED_FOOT_HEIGHT = 0.006
# The deepest a pot's soil may lie below its rim (m; SceneConfig.pot_fill_gap_m).
POT_FILL_GAP_MAX = 0.02
# A pot's feet (SceneConfig.pot_feet): spheres of this radius (m) on a ring inside the rim of
# its base, touching the base's plane from above (their lowest points on it).
POT_FOOT_RADIUS = 0.0015
# The most feet a pot may stand on (more cost more contacts and change nothing measured).
POT_FEET_MAX = 16
INDEX_DRIVES = ("pd", "stepper")


@dataclass(frozen=True)
class SceneConfig:
    """Every physical number of the scene, SI units, design defaults (docs/sources.md)."""

    # --- what the scene is assembled from: the kinds' scene modules (scene.kinds).
    robot_kind: str = "fivebar"
    effector_kind: str = "parallel_jaw"
    workcell_kind: str = "conveyor_tube"
    # A robot's own scene numbers where they are not this config's fields (a frozen dataclass
    # of its scene module: the gantry's GantryParams); None for the five-bar, whose numbers
    # are the fields below.
    robot_params: object = None

    # --- five-bar geometry (m): motors at (-l0, 0) and (+l0, 0); active l1, passive l2.
    l0_m: float = 0.050
    l1_m: float = 0.120
    l2_m: float = 0.200
    # Vertical distance from the arm plane (C) down to the grip centre (m).
    column_height_m: float = 0.120

    # --- stepper drives (transplanter.scene.stepper: torque against load angle). Torque of a
    # NEMA17 held at standstill (N*m), its detent torque unpowered (N*m), rotor inertia
    # (kg*m^2), full steps per revolution (200 for a 1.8 deg motor: 50 rotor teeth, one
    # electrical cycle per 4 full steps), the pull-out curve's corner speed (rev/s: the
    # holding torque below it, falling as 1/speed above) and the damping of the rotor's
    # motion relative to its field, as a damping ratio of the unloaded rotor on its
    # small-signal stiffness.
    holding_torque_nm: float = 0.45
    detent_torque_nm: float = 0.022
    rotor_inertia_kgm2: float = 5.4e-6
    steps_per_rev: int = 200
    pullout_corner_rev_s: float = 8.0
    rotor_damping_ratio: float = 0.2
    arm_belt_ratio: float = 3.0
    z_lead_m: float = 0.008
    # Efficiency of the T8 lead screw (brass nut): its friction is a Coulomb force on the Z
    # slide of weight * (1/efficiency - 1), the torque a screw loses lifting its load.
    screw_efficiency: float = 0.35
    # Mass of the Z carriage with motors and belts (kg), masses of active/passive links (kg).
    platform_mass_kg: float = 1.0
    active_link_mass_kg: float = 0.06
    passive_link_mass_kg: float = 0.06

    # --- gripper: jaw opening range (m), servo force limit = grip force per jaw (N),
    # servo stiffness on the opening (N/m), jaw slide damping (N*s/m).
    gripper_max_opening_m: float = 0.050
    grip_force_n: float = 6.0
    # Underside of the gripper's bridge (the palm joining the jaws' side plates) above the
    # grip centre (m): over the tallest shoot at Z_low (a 52 mm pot, 2.5 mm taller at most,
    # and a 45 mm shoot: 99.5 mm over the belt; the bridge at 34 + 68 = 102 mm), under the
    # wrist servo with its plate. Estimate (docs/sources.md).
    bridge_clearance_m: float = 0.068
    gripper_kp_n_m: float = 3000.0
    jaw_damping_n_s_m: float = 2.0
    # (No jaw friction: the pots' contact priority makes every jaw-pot contact take the pot's
    # friction, the scenario's pots.friction; a jaw friction would never act.)
    # Wrist (elbow) servo: stiffness (N*m/rad), torque limit (N*m).
    wrist_kp_nm_rad: float = 3.0
    wrist_torque_nm: float = 0.25

    # --- active joint travel (rad): the elbows-out workspace needs theta1 in [95, 219] deg
    # and theta2 in [-39, 85] deg; the hard stops sit beyond the limit switches.
    theta1_range_rad: tuple[float, float] = (math.radians(75.0), math.radians(240.0))
    theta2_range_rad: tuple[float, float] = (math.radians(-60.0), math.radians(105.0))
    # Z slide travel (m) of the grip centre above the belt; its ends are the hard stops.
    z_range_m: tuple[float, float] = (0.0, 0.165)

    # --- limit switches (firmware homing positions; rad, rad, m, m): the arms fold back.
    # Each trips at its position: closed at theta1 >= switch1, theta2 <= switch2, z >= switch3
    # and z <= switch4 (Scene.limit_switches).
    switch1_theta1_rad: float = math.radians(200.0)
    switch2_theta2_rad: float = math.radians(-20.0)
    switch3_z_m: float = 0.160
    switch4_z_m: float = 0.005

    # --- home keyframe (power-on pose): active angles (rad), Z (m), a little short of the
    # limit switches; the gripper is fully open.
    power_on_theta1_rad: float = math.radians(195.0)
    power_on_theta2_rad: float = math.radians(-15.0)
    power_on_z_m: float = 0.150

    # --- conveyor layout: rows x cols cells, cell pitch in x, row pitch in y (m); the pickup
    # row (row 0) is centred at pickup_row_y_m; rows further back at + row_pitch_m each.
    rows: int = 8
    cols: int = 5
    # Rows of pots that are bodies in the physics (scene.live_rows): the row just picked, the
    # pickup row and the rows upstream that the indexes push into place; the rows beyond
    # ride the belt outside the physics and enter the window as rows leave it. At least
    # rows: every pot is a body (the scene as without a window).
    live_rows: int = 8
    cell_pitch_m: float = 0.045
    row_pitch_m: float = 0.045
    pickup_row_y_m: float = 0.215
    rib_height_m: float = 0.005
    rib_thickness_m: float = 0.002
    # Sliding friction of the ribs' smooth plastic on a paper pot; the ribs' contact priority
    # wins over the pots', so this, not the pot's friction with the jaws, acts at the ribs.
    rib_friction: float = 0.2
    # The static belt table reaches this far (m) beyond the outer ribs on either side.
    table_side_margin_m: float = 0.02
    # Conveyor carriage: mass (kg), dry friction of its slide (N), PD gains of the index drive
    # (N/m, N*s/m), settle time held after the profile before the force is released (s; at
    # most a quarter of the index time, see ConveyorDrive.index_phases), the share of the
    # profile spent pushing (the rest returns by the overshoot: 4 mm, no pot contact). With
    # the paper's 0.6 s index that is a 0.425 s push; a 0.34 s push (settle 0.15 s, share
    # 0.75) tipped 1-8 back-row pots per 40-pot trial onto the ribs. Last, the
    # overshoot (m) past one row pitch before coming back; None: the cell clearance
    # (SceneConfig.cell_clearance_m), which leaves every nominal pot centred in its new cell.
    conveyor_mass_kg: float = 1.0
    conveyor_frictionloss_n: float = 5.0
    conveyor_kp_n_m: float = 20000.0
    conveyor_kd_n_s_m: float = 400.0
    # What drives the carriage along the index profile: "pd", a PD force with the gains above
    # (estimates; it lags by the friction of the pots it pushes: 1.1 mm with 8 rows of pots,
    # 2.9 mm with 24), or "stepper", the conveyor stepper's own stiffness and damping (the
    # hold below) about a set point that follows the profile, with the damping fed the
    # profile's speed (0.08 / 0.26 mm); docs/performance.md, "Why the far rows drift".
    conveyor_index_drive: str = "pd"
    conveyor_settle_s: float = 0.10
    conveyor_push_share: float = 0.85
    conveyor_overshoot_m: float | None = None
    # Between indexes the carriage is held by its drive: a NEMA17 stepper (holding torque
    # 0.40 N*m, 17HS4401 datasheet; 1.8 deg full step) through a GT2 20-tooth pulley (pitch
    # radius 6.37 mm). A hybrid stepper's torque near a detent is T_hold * sin(pi/2 * angle /
    # full step), so its stiffness is T_hold * (pi/2) / full step (20 N*m/rad), and at the
    # belt / r^2: about 493 kN/m, up to T_hold / r = 63 N. The damping ratio of that hold.
    conveyor_holding_torque_nm: float = 0.40
    conveyor_pulley_radius_m: float = 0.00637
    conveyor_hold_damping_ratio: float = 0.5

    # --- paper pots: nominal size (m), mass (kg) and their spreads (normal sd, clipped),
    # placement offset sd in the cell (m, a normal truncated to +-pot_offset_max_m), friction
    # of the paper against jaws and belt (mean and sd of a gamma distribution: never < 0).
    pot_diameter_m: float = 0.035
    pot_diameter_sd_m: float = 0.0003
    pot_height_m: float = 0.052
    pot_height_sd_m: float = 0.0008
    pot_mass_kg: float = 0.047
    pot_mass_sd_kg: float = 0.006
    pot_mass_range_kg: tuple[float, float] = (0.040, 0.080)
    pot_offset_sd_m: float = 0.001
    pot_offset_max_m: float = 0.003
    pot_friction: float = 0.6
    pot_friction_sd: float = 0.05
    # How a pot stands on the belt table: 0, its collision cylinder's base on the table's box
    # (MuJoCo's native convex collider, which pushes a pot sideways by where it stands on the
    # box at every index push), or on this many sphere feet (POT_FOOT_RADIUS) on a ring inside
    # its base, which alone touch the table (a sphere on a box is a closed-form pair, no
    # bias); the cylinder still touches everything else. docs/performance.md, "Why the far
    # rows drift".
    pot_feet: int = 0
    # Pots bonded to the belt (roots through the drainage hole, wet paper): the share of pots
    # with a bond, its median strength (N) and the spread (sd of ln strength, log-normal).
    # A bond is MuJoCo adhesion at the pot's base, acting on its contact with the belt only.
    pot_bond_share: float = 0.0
    pot_bond_force_n: float = 0.0
    pot_bond_sd_log: float = 0.0
    # Soaked pots: a share of the pots whose wall gives under the jaws: their contacts are
    # MuJoCo soft contacts whose impedance rises from SOFT_WALL_IMPEDANCE[0] to [1] over
    # pot_soft_wall_m of penetration (m; solimp width) instead of the firm pots' 0.5 mm. The
    # jaws close towards their commanded opening (25 mm) into such a pot, and once the
    # servo is near it the squeeze falls: a pot that gives more than the jaws' travel is
    # barely held. Estimates, no source.
    pot_soft_share: float = 0.0
    pot_soft_wall_m: float = 0.02
    # Crooked pots: a share of the pots whose wall is bent over its foot: the wall leans by
    # an angle drawn uniformly up to pot_crooked_max_rad (rad) towards a random side, on a flat
    # foot CROOKED_FOOT_HEIGHT tall (the pot stands flat; its top and seedling lean).
    # Estimates, no source.
    pot_crooked_share: float = 0.0
    pot_crooked_max_rad: float = 0.1
    # Uneven fill: how far below the rim a pot's soil lies (m): a normal truncated to
    # [0, POT_FILL_GAP_MAX]. The pot's centre of mass sits half of it lower and its seedling
    # stands on the soil, all of it lower. Estimates, no source.
    pot_fill_gap_m: float = 0.0
    pot_fill_gap_sd_m: float = 0.0
    # Seedling canopies touching the jaws: each leaf's capsule proxy collides with the jaws
    # only (nothing else), with a soft contact (time constant, s: leaves bend away) and its
    # own friction; a push or a drag on a leaf moves its pot. Off: leaves are only tested
    # geometrically (leaf_hit_pots). Estimates, no source.
    canopy_contact: bool = False
    canopy_timeconst_s: float = 0.8
    canopy_friction: float = 0.5
    # Where an index leaves the row along the belt: normal sd (m) of the error of each index
    # (belt stretch, rib play); the next index's ribs take it back.
    conveyor_index_error_sd_m: float = 0.0
    # Seedling: stem length above the pot (m, uniform range), leaves per seedling (range),
    # the shoot's mass (kg; on top of the pot's).
    stem_length_range_m: tuple[float, float] = (0.035, 0.045)
    leaves_range: tuple[int, int] = (2, 3)
    shoot_mass_kg: float = 0.003
    # The shoot sways on its stem (transplanter.twin.shoot: a hinge at the centre of the pot's
    # top) at this natural frequency (Hz, upright, gravity included) with this damping
    # ratio. Estimates: a 40 mm shoot flicked sideways swings a few times a second and stops
    # within a few swings.
    stem_sway_hz: float = 4.0
    stem_sway_sd_hz: float = 0.0  # spread between seedlings (gamma: never <= 0)
    stem_damping_ratio: float = 0.2
    # Stem radius (m; visual), and the capsule proxy of each leaf (radius, half length of
    # its axis, m) that leaf_hit_pots tests against the gripper.
    stem_radius_m: float = 0.0015
    leaf_radius_m: float = 0.006
    leaf_half_length_m: float = 0.0165

    # --- drop tube: funnel centre (x, y), funnel top height, top and throat diameters,
    # funnel height, tube length below the throat, wall thickness (m), segments per ring.
    drop_tube_xy_m: tuple[float, float] = (0.0, 0.140)
    funnel_top_z_m: float = 0.010
    funnel_top_diameter_m: float = 0.060
    funnel_throat_diameter_m: float = 0.042
    funnel_height_m: float = 0.020
    tube_length_m: float = 0.140
    tube_wall_m: float = 0.003
    tube_segments: int = 12

    # --- simulation: timestep (s), solver settings, sleeping.
    timestep_s: float = 0.001
    impratio: float = 10.0
    solver_iterations: int = 50
    solver_tolerance: float = 1e-8
    jacobian: str = "auto"  # "auto", "dense" or "sparse"
    sleep: bool = True
    sleep_tolerance_m_s: float = 1e-3
    contact_solref: tuple[float, float] = (0.004, 1.0)
    contact_solimp: tuple[float, float, float, float, float] = (0.95, 0.99, 0.0005, 0.5, 2.0)

    def __post_init__(self) -> None:
        positive = (
            "l0_m l1_m l2_m column_height_m holding_torque_nm rotor_inertia_kgm2 "
            "pullout_corner_rev_s arm_belt_ratio z_lead_m screw_efficiency "
            "gripper_max_opening_m grip_force_n cell_pitch_m row_pitch_m pot_diameter_m "
            "pot_height_m pot_mass_kg timestep_s"
        ).split()
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"SceneConfig.{name} must be > 0, got {getattr(self, name)}")
        bridge_top = self.column_height_m - WRIST_SERVO_BOTTOM - BRIDGE_THICKNESS
        if not JAW_HALF_HEIGHT < self.bridge_clearance_m < bridge_top:
            raise ValueError(
                "SceneConfig.bridge_clearance_m must lie above the jaws' top edge "
                f"({JAW_HALF_HEIGHT * 1e3:g} mm over the grip centre) and under the wrist servo "
                f"(below {bridge_top * 1e3:g} mm), got {self.bridge_clearance_m * 1e3:g} mm"
            )
        if not (isinstance(self.steps_per_rev, (int, np.integer)) and self.steps_per_rev >= 1):
            raise ValueError(
                f"SceneConfig.steps_per_rev must be a positive integer, got {self.steps_per_rev!r}"
            )
        for name in ("detent_torque_nm", "rotor_damping_ratio"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"SceneConfig.{name} must be >= 0, got {getattr(self, name)}")
        if not self.detent_torque_nm < self.holding_torque_nm:
            raise ValueError(
                "SceneConfig.detent_torque_nm must be below the holding torque "
                f"({self.holding_torque_nm} N m), got {self.detent_torque_nm}"
            )
        if self.conveyor_index_drive not in INDEX_DRIVES:
            raise ValueError(
                f"SceneConfig.conveyor_index_drive must be one of {', '.join(INDEX_DRIVES)}, "
                f"got {self.conveyor_index_drive!r}"
            )
        if not (
            isinstance(self.pot_feet, (int, np.integer))
            and (self.pot_feet == 0 or 3 <= self.pot_feet <= POT_FEET_MAX)
        ):
            raise ValueError(
                f"SceneConfig.pot_feet must be 0 (the pot's cylinder stands on the table) or an "
                f"integer from 3 (fewer do not stand a pot up) to {POT_FEET_MAX}, got "
                f"{self.pot_feet!r}"
            )
        if not 0 < self.funnel_throat_diameter_m < self.funnel_top_diameter_m:
            raise ValueError(
                "the drop tube's funnel narrows to its throat: funnel_throat_diameter_mm "
                f"({self.funnel_throat_diameter_m * 1e3:g}) must be below "
                f"funnel_top_diameter_mm ({self.funnel_top_diameter_m * 1e3:g})"
            )
        if not self.funnel_height_m > 0:
            raise ValueError(f"the funnel's height must be > 0, got {self.funnel_height_m}")
        if self.rows < 1 or self.cols < 1:
            raise ValueError(
                f"SceneConfig needs rows >= 1 and cols >= 1, got {self.rows}x{self.cols}"
            )
        if self.windowed:
            problem = window_problem(self)
            if problem:
                raise ValueError(f"SceneConfig.live_rows: {problem}")
        if self.pot_diameter_m + 2 * self.pot_offset_max_m + self.rib_thickness_m >= min(
            self.cell_pitch_m, self.row_pitch_m
        ):
            raise ValueError(
                "pots do not fit their cells: pot_diameter_m + 2*pot_offset_max_m + "
                "rib_thickness_m must be below cell_pitch_m and row_pitch_m"
            )
        if not 0 <= self.pot_bond_share <= 1:
            raise ValueError(
                f"SceneConfig.pot_bond_share must be in [0, 1], got {self.pot_bond_share}"
            )
        for name in ("pot_bond_force_n", "pot_bond_sd_log", "conveyor_index_error_sd_m"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"SceneConfig.{name} must be >= 0, got {getattr(self, name)}")
        if not 0 <= self.pot_soft_share <= 1:
            raise ValueError(
                f"SceneConfig.pot_soft_share must be in [0, 1], got {self.pot_soft_share}"
            )
        if not 0 <= self.pot_crooked_share <= 1:
            raise ValueError(
                f"SceneConfig.pot_crooked_share must be in [0, 1], got {self.pot_crooked_share}"
            )
        if not 0 < self.pot_crooked_max_rad < np.pi / 4:
            raise ValueError(
                "SceneConfig.pot_crooked_max_rad must be in (0, pi/4) rad (a wall bent further "
                f"would not stand), got {self.pot_crooked_max_rad}"
            )
        if not (0 <= self.pot_fill_gap_m <= POT_FILL_GAP_MAX and self.pot_fill_gap_sd_m >= 0):
            raise ValueError(
                f"SceneConfig.pot_fill_gap_m must be in [0, {POT_FILL_GAP_MAX}] m and "
                f"pot_fill_gap_sd_m >= 0, got {self.pot_fill_gap_m} and {self.pot_fill_gap_sd_m}"
            )
        if not self.pot_soft_wall_m > 0:
            raise ValueError(
                f"SceneConfig.pot_soft_wall_m must be > 0 m, got {self.pot_soft_wall_m}"
            )
        if self.canopy_contact and not self.canopy_timeconst_s >= 2 * self.timestep_s:
            raise ValueError(
                f"SceneConfig.canopy_timeconst_s must be at least twice the timestep "
                f"({2 * self.timestep_s} s; MuJoCo would silently stiffen a shorter one), got "
                f"{self.canopy_timeconst_s}"
            )
        if not self.shoot_mass_kg > 0 or not self.stem_damping_ratio >= 0:
            raise ValueError(
                "SceneConfig.shoot_mass_kg must be > 0 kg and stem_damping_ratio >= 0, got "
                f"{self.shoot_mass_kg} and {self.stem_damping_ratio}"
            )
        if not self.stem_sway_hz > 0 or not self.stem_sway_sd_hz >= 0:
            raise ValueError(
                "SceneConfig.stem_sway_hz must be > 0 Hz and stem_sway_sd_hz >= 0, got "
                f"{self.stem_sway_hz} and {self.stem_sway_sd_hz}"
            )
        if not self.canopy_friction >= 0:
            raise ValueError(
                f"SceneConfig.canopy_friction must be >= 0, got {self.canopy_friction}"
            )
        if not 0 < self.conveyor_push_share < 1:
            raise ValueError(
                f"SceneConfig.conveyor_push_share must be in (0, 1), got {self.conveyor_push_share}"
            )
        if not self.conveyor_settle_s >= 0:
            raise ValueError(
                f"SceneConfig.conveyor_settle_s must be >= 0 s, got {self.conveyor_settle_s}"
            )
        if self.conveyor_overshoot_m is not None and not self.conveyor_overshoot_m >= 0:
            raise ValueError(
                "SceneConfig.conveyor_overshoot_m must be >= 0 m (or None for the cell "
                f"clearance), got {self.conveyor_overshoot_m}"
            )
        if self.jacobian not in ("auto", "dense", "sparse"):
            raise ValueError(
                f"SceneConfig.jacobian must be auto, dense or sparse, got {self.jacobian!r}"
            )
        if self.l1_m + self.l2_m <= self.l0_m:
            raise ValueError("five-bar links too short: need l1_m + l2_m > l0_m")
        self._check_joint_positions()

    def _check_joint_positions(self) -> None:
        """Limit switches and the home keyframe must lie inside the joint travel."""
        for range_name in ("theta1_range_rad", "theta2_range_rad", "z_range_m"):
            lo, hi = getattr(self, range_name)
            if not lo < hi:
                raise ValueError(f"SceneConfig.{range_name} must be (low, high), got {(lo, hi)}")
        for name, range_name in (
            ("switch1_theta1_rad", "theta1_range_rad"),
            ("switch2_theta2_rad", "theta2_range_rad"),
            ("switch3_z_m", "z_range_m"),
            ("switch4_z_m", "z_range_m"),
            ("power_on_theta1_rad", "theta1_range_rad"),
            ("power_on_theta2_rad", "theta2_range_rad"),
            ("power_on_z_m", "z_range_m"),
        ):
            lo, hi = getattr(self, range_name)
            value = getattr(self, name)
            if not lo <= value <= hi:
                raise ValueError(
                    f"SceneConfig.{name} = {value:.6g} lies outside {range_name} = "
                    f"[{lo:.6g}, {hi:.6g}]: the joint could never reach it; move it inside "
                    f"or widen {range_name}"
                )

    def kinematics(self) -> FiveBarKinematics:
        """The five-bar's kinematics (the paper's working mode, the model's assembly)."""
        return FiveBarKinematics(self.geometry())

    def geometry(self) -> FiveBarGeometry:
        """The five-bar's link lengths for the pure-numpy kinematics."""
        return FiveBarGeometry(l0_m=self.l0_m, l1_m=self.l1_m, l2_m=self.l2_m)

    # Derived drive numbers (documented in models/fivebar/README.md).
    @property
    def screw_gear_rad_m(self) -> float:
        """Motor radians per metre of Z travel."""
        return 2.0 * math.pi / self.z_lead_m

    @property
    def cell_clearance_m(self) -> float:
        """Gap (m) along y between a centred nominal pot and each cross rib of its cell.

        The cross ribs of a row sit at +-row_pitch_m/2 from the cell centre, rib_thickness_m thick.
        """
        return (self.row_pitch_m - self.rib_thickness_m - self.pot_diameter_m) / 2

    @property
    def index_overshoot_m(self) -> float:
        """Overshoot (m) of the conveyor index: conveyor_overshoot_m, or the cell clearance.

        The back rib pushes each pot row_pitch_m + overshoot - clearance - its offset, so with
        overshoot = clearance a pot ends exactly one row pitch forward, centred in its cell;
        the carriage then comes back by the overshoot, leaving the pot clear of both ribs.
        """
        if not 0 < self.conveyor_push_share < 1:
            raise ValueError(
                f"SceneConfig.conveyor_push_share must be in (0, 1), got {self.conveyor_push_share}"
            )
        if not self.conveyor_settle_s >= 0:
            raise ValueError(
                f"SceneConfig.conveyor_settle_s must be >= 0 s, got {self.conveyor_settle_s}"
            )
        if self.conveyor_overshoot_m is not None:
            return self.conveyor_overshoot_m
        return self.cell_clearance_m

    @property
    def conveyor_hold_stiffness_n_m(self) -> float:
        """Stiffness (N/m) of the conveyor drive holding the carriage between indexes."""
        full_step = 2.0 * math.pi / 200.0  # the conveyor stepper's 1.8 deg
        return (
            self.conveyor_holding_torque_nm
            * (math.pi / 2)
            / full_step
            / self.conveyor_pulley_radius_m**2
        )

    @property
    def conveyor_hold_damping_n_s_m(self) -> float:
        """Damping (N*s/m) of that hold: the damping ratio of the carriage on it."""
        k, m = self.conveyor_hold_stiffness_n_m, self.conveyor_mass_kg
        return 2.0 * self.conveyor_hold_damping_ratio * math.sqrt(k * m)

    @property
    def full_step_rad(self) -> float:
        """One full step of the motor shaft (rad)."""
        return 2.0 * math.pi / self.steps_per_rev

    @property
    def windowed(self) -> bool:
        """True when only live_rows of the rows are bodies in the physics (scene.live_rows)."""
        return self.live_rows < self.rows

    @property
    def body_rows(self) -> int:
        """The rows of pot bodies the model holds: live_rows, or rows without a window."""
        return min(self.live_rows, self.rows)

    @property
    def rib_slot_rows(self) -> int:
        """How many rows of ribs a windowed scene carries: one more than its rows of pot
        bodies, so that every row with a pot body on the belt has its ribs."""
        return self.body_rows + 1

    def stepper_params(self) -> tuple[StepperParams, StepperParams, StepperParams]:
        """The motors' torque laws (theta1, theta2, Z; transplanter.scene.stepper): the same
        NEMA17 on every axis, its damping from the unloaded rotor's ratio."""
        stiffness = self.holding_torque_nm * self.steps_per_rev / 4.0
        damping = 2.0 * self.rotor_damping_ratio * math.sqrt(stiffness * self.rotor_inertia_kgm2)
        motor = StepperParams(
            holding_torque_nm=self.holding_torque_nm,
            detent_torque_nm=self.detent_torque_nm,
            steps_per_rev=self.steps_per_rev,
            corner_rev_s=self.pullout_corner_rev_s,
            damping_nms_rad=damping,
        )
        return (motor, motor, motor)
