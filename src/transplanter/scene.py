"""The physical half of the twin: build the MuJoCo scene (arm, conveyor, pots, drop tube).

`build_scene(config, seed)` loads models/scene.xml with MjSpec, applies every number of
`SceneConfig` (link lengths, stepper drives, gripper, solver), adds the conveyor ribs and
rows x cols paper pots with seedlings drawn from `np.random.default_rng(seed)`, and compiles.
The returned `Scene` offers cheap per-step accessors (precomputed index arrays).

Frames and joint conventions: docs/architecture.md and the header of models/transplanter.xml.

Conveyor: the belt table is static (it ends at the front edge of the pickup row); the pots
stand on it and are pushed by 3 mm ribs on the `conveyor` carriage, an UNACTUATED slide (so
it sleeps with its resting pots). `start_conveyor_index(data, now, total_s)` arms a smooth
profile followed by a short hold, all within total_s (the carriage is at rest and released by
now + total_s, when the firmware acknowledges M710), and
`apply_conveyor` (call it before every physics step) writes a PD force following it into
`qfrc_applied` of the conveyor dof; a non-zero applied force is MuJoCo's documented way to
wake a sleeping tree, and writing back an exact 0.0 at the end lets it fall asleep again.
The profile overshoots by the cell clearance and comes back, so the ribs push every pot to
its new cell centre and then leave it free (no rib contact at rest, so the pots and the
carriage do not form one big island). Each row's ribs collide only with that row's pots
(collision bits 8..31), so ribs of emptied rows, which travel on past the front edge, never
touch the arm, the gripper, the drop tube or pots of other rows.

Leaves: a capsule proxy per leaf on each pot body, outside collision detection (leaves are
a few grams of soft tissue: they must not push the gripper, and colliding them every step
tripled the narrowphase). `leaf_hit_pots` tests them against the gripper's boxes
geometrically, only for the pots near the gripper, when the trial asks.
"""

from __future__ import annotations

import importlib.resources
import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from transplanter import kinematics
from transplanter.kinematics import FiveBarGeometry

# The conveyor index state lives in data.userdata[0:USERDATA_CONVEYOR] (so it is part of the
# MjData and copies with it): active flag, start time (s), profile duration (s), end time (s:
# at rest and released), start position (m).
USERDATA_CONVEYOR = 5
_U_ACTIVE, _U_T0, _U_PROFILE, _U_END, _U_Q0 = range(USERDATA_CONVEYOR)

# Collision bits (contype/conaffinity).
BIT_WORLD = 1
BIT_POT = 2
BIT_GRIPPER = 4
ROW_BIT_FIRST = 8
ROW_BITS = 24
PASSIVE_DROP = 0.015  # passive links run this far below the active ones (visual only)
# Gripper layout of models/transplanter.xml (m): it is drawn for a column height of
# XML_COLUMN_HEIGHT; the column runs from just under the wrist servo (WRIST_SERVO_BOTTOM
# below C) down to the top of the palm, which sits PALM_HEIGHT above the jaws' top edge
# (JAW_HALF_HEIGHT above the grip centre). The jaws start JAW_HALF_THICKNESS off the centre.
XML_COLUMN_HEIGHT = 0.120
WRIST_SERVO_BOTTOM = 0.042
JAW_HALF_HEIGHT = 0.0225
PALM_HEIGHT = 0.025
JAW_HALF_THICKNESS = 0.0015
# Quaternion turning a capsule's axis (local z) onto local x.
_CAPSULE_Z_TO_X = np.array([np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0])
LEAF_SAMPLES = 5  # points along each leaf capsule's axis tested against the gripper boxes
LEAF_NEAR_M = 0.09  # only pots this close (xy) to the grip centre can touch the gripper


def models_dir() -> Path:
    """The MJCF models shipped with the package (models/ of the repository)."""
    return Path(str(importlib.resources.files("transplanter.models")))


@dataclass(frozen=True)
class SceneConfig:
    """Every physical number of the scene, SI units, DESIGN.md defaults."""

    # --- five-bar geometry (m): motors at (-l0, 0) and (+l0, 0); active l1, passive l2.
    l0: float = 0.050
    l1: float = 0.120
    l2: float = 0.200
    # Vertical distance from the arm plane (C) down to the grip centre (m).
    column_height: float = 0.120

    # --- stepper drives. Torque of a NEMA17 held at standstill (N*m), rotor inertia
    # (kg*m^2), motor speed (rev/s) at which the pull-out torque reaches zero.
    holding_torque: float = 0.45
    rotor_inertia: float = 5.4e-6
    # Full steps per motor revolution (200 for a 1.8 deg stepper): the torque of a stepper
    # peaks about one full step of error, so it sets the position stiffness.
    steps_per_rev: int = 200
    pullout_zero_speed_rev_s: float = 15.0
    arm_belt_ratio: float = 3.0
    screw_lead: float = 0.008
    # Fraction of the motor torque that reaches the Z slide through the T8 lead screw.
    screw_efficiency: float = 0.35
    # kp = holding torque / full_step_rad, times this factor (1 for the arms; the Z drive is
    # stable at 1 too with the 1 ms step and its large reflected rotor inertia).
    arm_stiffness_scale: float = 1.0
    z_stiffness_scale: float = 1.0
    # Damping ratio of the position loop (MuJoCo dampratio: kv from the reflected inertia);
    # it damps the ringing about the commanded step without touching the torque limit.
    stepper_dampratio: float = 0.5
    # Mass of the Z carriage with motors and belts (kg), masses of active/passive links (kg).
    platform_mass: float = 1.0
    active_link_mass: float = 0.06
    passive_link_mass: float = 0.06

    # --- gripper: jaw opening range (m), servo force limit = grip force per jaw (N),
    # servo stiffness on the opening (N/m), jaw slide damping (N*s/m).
    gripper_max_opening: float = 0.050
    grip_force: float = 6.0
    gripper_kp: float = 3000.0
    jaw_damping: float = 2.0
    jaw_friction: float = 0.8
    # Wrist (elbow) servo: stiffness (N*m/rad), torque limit (N*m).
    wrist_kp: float = 3.0
    wrist_torque: float = 0.25

    # --- active joint travel (rad): the elbows-out workspace needs theta1 in [95, 219] deg
    # and theta2 in [-39, 85] deg; the hard stops sit beyond the limit switches.
    theta1_range: tuple[float, float] = (math.radians(75.0), math.radians(240.0))
    theta2_range: tuple[float, float] = (math.radians(-60.0), math.radians(105.0))
    # Z slide travel (m) of the grip centre above the belt; its ends are the hard stops.
    z_range: tuple[float, float] = (0.0, 0.165)

    # --- limit switches (firmware homing positions; rad, rad, m, m): the arms fold back.
    switch1_theta1_min: float = math.radians(200.0)
    switch2_theta2_max: float = math.radians(-20.0)
    switch3_z_min: float = 0.160
    switch4_z_max: float = 0.005

    # --- home keyframe (power-on pose): active angles (rad), Z (m), a little short of the
    # limit switches; the gripper is fully open.
    home_theta1: float = math.radians(195.0)
    home_theta2: float = math.radians(-15.0)
    home_z: float = 0.150

    # --- conveyor layout: rows x cols cells, cell pitch in x, row pitch in y (m); the pickup
    # row (row 0) is centred at pickup_row_y; rows further back at + row_pitch each.
    rows: int = 8
    cols: int = 5
    cell_pitch: float = 0.045
    row_pitch: float = 0.045
    pickup_row_y: float = 0.215
    rib_height: float = 0.005
    rib_thickness: float = 0.002
    # Sliding friction of the ribs' smooth plastic on a paper pot; the ribs' contact priority
    # wins over the pots', so this, not the pot's friction with the jaws, acts at the ribs.
    rib_friction: float = 0.2
    # Conveyor carriage: mass (kg), dry friction of its slide (N), PD gains of the index drive
    # (N/m, N*s/m), settle time held after the profile before the force is released (s; at
    # most a quarter of the index time, see Scene.conveyor_index_phases), the share of the
    # profile spent pushing (the rest returns by the overshoot: 4 mm, no pot contact). With
    # the paper's 0.6 s index that is a 0.425 s push; a 0.34 s push (settle 0.15 s, share
    # 0.75) tipped 1-8 back-row pots per 40-pot trial onto the ribs. Last, the
    # overshoot (m) past one row pitch before coming back; None: the cell clearance
    # (SceneConfig.cell_clearance), which leaves every nominal pot centred in its new cell.
    conveyor_mass: float = 1.0
    conveyor_frictionloss: float = 5.0
    conveyor_kp: float = 20000.0
    conveyor_kd: float = 400.0
    conveyor_settle_s: float = 0.10
    conveyor_push_share: float = 0.85
    conveyor_overshoot: float | None = None

    # --- paper pots: nominal size (m), mass (kg) and their spreads (normal sd, clipped),
    # placement offset sd in the cell (m, clipped to +-pot_offset_max), friction of the
    # paper against jaws and belt (mean, sd, clipped to >= pot_friction_min).
    pot_diameter: float = 0.035
    pot_diameter_sd: float = 0.0003
    pot_height: float = 0.052
    pot_height_sd: float = 0.0008
    pot_mass: float = 0.047
    pot_mass_sd: float = 0.006
    pot_mass_range: tuple[float, float] = (0.040, 0.080)
    pot_offset_sd: float = 0.001
    pot_offset_max: float = 0.003
    pot_friction: float = 0.6
    pot_friction_sd: float = 0.05
    pot_friction_min: float = 0.05
    # Seedling: stem length above the pot (m, uniform range), leaves per seedling (range),
    # seedling mass (kg) added to the pot.
    stem_length_range: tuple[float, float] = (0.035, 0.045)
    leaves_range: tuple[int, int] = (2, 3)
    seedling_mass: float = 0.003

    # --- drop tube: funnel centre (x, y), funnel top height, top and throat diameters,
    # funnel height, tube length below the throat, wall thickness (m), segments per ring.
    drop_tube_xy: tuple[float, float] = (0.0, 0.140)
    funnel_top_z: float = 0.010
    funnel_top_diameter: float = 0.060
    funnel_throat_diameter: float = 0.042
    funnel_height: float = 0.020
    tube_length: float = 0.140
    tube_wall: float = 0.003
    tube_segments: int = 12

    # --- simulation: timestep (s), solver settings, sleeping.
    timestep: float = 0.001
    impratio: float = 10.0
    solver_iterations: int = 50
    solver_tolerance: float = 1e-8
    jacobian: str = "auto"  # "auto", "dense" or "sparse"
    sleep: bool = True
    sleep_tolerance: float = 1e-3  # m/s
    contact_solref: tuple[float, float] = (0.004, 1.0)
    contact_solimp: tuple[float, float, float, float, float] = (0.95, 0.99, 0.0005, 0.5, 2.0)

    def __post_init__(self) -> None:
        positive = (
            "l0 l1 l2 column_height holding_torque rotor_inertia pullout_zero_speed_rev_s "
            "arm_belt_ratio screw_lead screw_efficiency gripper_max_opening grip_force "
            "cell_pitch row_pitch pot_diameter pot_height pot_mass timestep"
        ).split()
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"SceneConfig.{name} must be > 0, got {getattr(self, name)}")
        if not (isinstance(self.steps_per_rev, (int, np.integer)) and self.steps_per_rev >= 1):
            raise ValueError(
                f"SceneConfig.steps_per_rev must be a positive integer, got {self.steps_per_rev!r}"
            )
        if self.rows < 1 or self.cols < 1:
            raise ValueError(
                f"SceneConfig needs rows >= 1 and cols >= 1, got {self.rows}x{self.cols}"
            )
        if self.pot_diameter + 2 * self.pot_offset_max + self.rib_thickness >= min(
            self.cell_pitch, self.row_pitch
        ):
            raise ValueError(
                "pots do not fit their cells: pot_diameter + 2*pot_offset_max + rib_thickness "
                "must be below cell_pitch and row_pitch"
            )
        if not 0 < self.conveyor_push_share < 1:
            raise ValueError(
                f"SceneConfig.conveyor_push_share must be in (0, 1), got {self.conveyor_push_share}"
            )
        if not self.conveyor_settle_s >= 0:
            raise ValueError(
                f"SceneConfig.conveyor_settle_s must be >= 0 s, got {self.conveyor_settle_s}"
            )
        if self.conveyor_overshoot is not None and not self.conveyor_overshoot >= 0:
            raise ValueError(
                "SceneConfig.conveyor_overshoot must be >= 0 m (or None for the cell "
                f"clearance), got {self.conveyor_overshoot}"
            )
        if self.jacobian not in ("auto", "dense", "sparse"):
            raise ValueError(
                f"SceneConfig.jacobian must be auto, dense or sparse, got {self.jacobian!r}"
            )
        if self.l1 + self.l2 <= self.l0:
            raise ValueError("five-bar links too short: need l1 + l2 > l0")
        self._check_joint_positions()

    def _check_joint_positions(self) -> None:
        """Limit switches and the home keyframe must lie inside the joint travel."""
        for range_name in ("theta1_range", "theta2_range", "z_range"):
            lo, hi = getattr(self, range_name)
            if not lo < hi:
                raise ValueError(f"SceneConfig.{range_name} must be (low, high), got {(lo, hi)}")
        for name, range_name in (
            ("switch1_theta1_min", "theta1_range"),
            ("switch2_theta2_max", "theta2_range"),
            ("switch3_z_min", "z_range"),
            ("switch4_z_max", "z_range"),
            ("home_theta1", "theta1_range"),
            ("home_theta2", "theta2_range"),
            ("home_z", "z_range"),
        ):
            lo, hi = getattr(self, range_name)
            value = getattr(self, name)
            if not lo <= value <= hi:
                raise ValueError(
                    f"SceneConfig.{name} = {value:.6g} lies outside {range_name} = "
                    f"[{lo:.6g}, {hi:.6g}]: the joint could never reach it; move it inside "
                    f"or widen {range_name}"
                )

    def geometry(self) -> FiveBarGeometry:
        """The five-bar's link lengths for the pure-numpy kinematics."""
        return FiveBarGeometry(l0_m=self.l0, l1_m=self.l1, l2_m=self.l2)

    # Derived drive numbers (documented in models/transplanter.xml).
    @property
    def screw_gear(self) -> float:
        """Motor radians per metre of Z travel."""
        return 2.0 * math.pi / self.screw_lead

    @property
    def cell_clearance(self) -> float:
        """Gap (m) along y between a centred nominal pot and each cross rib of its cell.

        The cross ribs of a row sit at +-row_pitch/2 from the cell centre, rib_thickness thick.
        """
        return (self.row_pitch - self.rib_thickness - self.pot_diameter) / 2

    @property
    def index_overshoot(self) -> float:
        """Overshoot (m) of the conveyor index: conveyor_overshoot, or the cell clearance.

        The back rib pushes each pot row_pitch + overshoot - clearance - its offset, so with
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
        if self.conveyor_overshoot is not None:
            return self.conveyor_overshoot
        return self.cell_clearance

    @property
    def full_step_rad(self) -> float:
        """One full step of the motor shaft (rad)."""
        return 2.0 * math.pi / self.steps_per_rev

    @property
    def pullout_zero_speed(self) -> float:
        """Motor speed (rad/s) where the pull-out torque reaches zero."""
        return 2.0 * math.pi * self.pullout_zero_speed_rev_s


def five_bar_forward(config: SceneConfig, theta1: float, theta2: float) -> tuple[float, float]:
    """Passive joint angles (phi1, phi2) of the elbows-out closed chain at (theta1, theta2).

    phi_i = direction of passive link i (elbow -> C, with C from kinematics.fk's 'up'
    assembly) minus theta_i, wrapped to (-pi, pi].
    """
    geom = config.geometry()
    x, y = kinematics.fk(geom, theta1, theta2, "up")
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(
            f"five-bar cannot close at theta=({theta1}, {theta2}) rad: the elbows are more "
            f"than 2*l2 = {2 * config.l2} m apart (or coincide)"
        )
    b, d = kinematics.elbow_points(geom, theta1, theta2)
    psi1 = math.atan2(y - b[1], x - b[0])
    psi2 = math.atan2(y - d[1], x - d[0])
    return _wrap_angle(psi1 - theta1), _wrap_angle(psi2 - theta2)


def _wrap_angle(angle: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    return math.pi - (math.pi - angle) % (2.0 * math.pi)


def ring_boxes(
    radius_top: float,
    z_top: float,
    radius_bottom: float,
    z_bottom: float,
    wall: float,
    segments: int,
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Convex boxes (half sizes, pos, quat) forming a conical/cylindrical wall of revolution.

    The inner faces lie on the surface from (radius_top, z_top) to (radius_bottom,
    z_bottom); boxes overlap slightly so nothing slips through the seams.
    """
    dr, dz = radius_bottom - radius_top, z_bottom - z_top
    slant = math.hypot(dr, dz)
    boxes = []
    half_width = (max(radius_top, radius_bottom) + wall) * math.tan(math.pi / segments) * 1.05
    for k in range(segments):
        a = 2 * math.pi * k / segments
        e_r = np.array([math.cos(a), math.sin(a), 0.0])
        e_t = np.array([-math.sin(a), math.cos(a), 0.0])
        e_z = np.array([0.0, 0.0, 1.0])
        up_slant = -(dr * e_r + dz * e_z) / slant
        normal = (-dz * e_r + dr * e_z) / slant
        mid = ((radius_top + radius_bottom) / 2) * e_r + ((z_top + z_bottom) / 2) * e_z
        pos = mid + normal * wall / 2
        rot = np.column_stack([normal, e_t, up_slant])
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, rot.flatten())
        boxes.append((np.array([wall / 2, half_width, slant / 2]), pos, quat))
    return boxes


def drop_tube_boxes(config: SceneConfig) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Funnel and tube collision boxes in the drop_tube body frame (origin at the funnel top)."""
    r_top = config.funnel_top_diameter / 2
    r_throat = config.funnel_throat_diameter / 2
    funnel = ring_boxes(
        r_top, 0.0, r_throat, -config.funnel_height, config.tube_wall, config.tube_segments
    )
    z_throat = -config.funnel_height
    tube = ring_boxes(
        r_throat,
        z_throat,
        r_throat,
        z_throat - config.tube_length,
        config.tube_wall,
        config.tube_segments,
    )
    return funnel + tube


def _pot_inertia(mass: float, radius: float, height: float) -> np.ndarray:
    ixx = mass * (3 * radius**2 + height**2) / 12
    return np.array([ixx, ixx, mass * radius**2 / 2])


class Scene:
    """A compiled scene with precomputed index arrays and per-step helpers."""

    def __init__(self, model: mujoco.MjModel, config: SceneConfig, pot_params: dict):
        self.model = model
        self.config = config
        self.pot_params = pot_params
        m = model
        name = lambda kind, n: mujoco.mj_name2id(m, kind, n)  # noqa: E731
        self.motor_actuators = np.array(
            [name(mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in ("theta1", "theta2", "z")]
        )
        self.motor_gears = m.actuator_gear[self.motor_actuators, 0].copy()
        motor_joints = [name(mujoco.mjtObj.mjOBJ_JOINT, n) for n in ("theta1", "theta2", "z")]
        self.motor_qpos_adr = m.jnt_qposadr[motor_joints].copy()
        self.gripper_actuator = name(mujoco.mjtObj.mjOBJ_ACTUATOR, "gripper")
        self.wrist_actuator = name(mujoco.mjtObj.mjOBJ_ACTUATOR, "wrist")
        self.wrist_qpos_adr = m.jnt_qposadr[name(mujoco.mjtObj.mjOBJ_JOINT, "wrist")]
        self.jaw_tendon = name(mujoco.mjtObj.mjOBJ_TENDON, "jaw_opening")
        self.grip_site = name(mujoco.mjtObj.mjOBJ_SITE, "grip_center")
        self.c1_site = name(mujoco.mjtObj.mjOBJ_SITE, "c1")
        self.c2_site = name(mujoco.mjtObj.mjOBJ_SITE, "c2")
        conveyor_joint = name(mujoco.mjtObj.mjOBJ_JOINT, "conveyor")
        self.conveyor_qpos_adr = int(m.jnt_qposadr[conveyor_joint])
        self.conveyor_dof_adr = int(m.jnt_dofadr[conveyor_joint])
        self.home_key = name(mujoco.mjtObj.mjOBJ_KEY, "home")
        if m.nuserdata < USERDATA_CONVEYOR:
            raise ValueError(
                f"the model has nuserdata={m.nuserdata}; the conveyor needs "
                f"{USERDATA_CONVEYOR} (<size nuserdata=...> in models/transplanter.xml)"
            )

        trip_adr = m.numeric_adr[name(mujoco.mjtObj.mjOBJ_NUMERIC, "limit_switch_trip")]
        sense_adr = m.numeric_adr[name(mujoco.mjtObj.mjOBJ_NUMERIC, "limit_switch_sense")]
        self.switch_trip = m.numeric_data[trip_adr : trip_adr + 4].copy()
        self.switch_sense = m.numeric_data[sense_adr : sense_adr + 4].copy()
        self.switch_qpos_adr = self.motor_qpos_adr[[0, 1, 2, 2]]

        rows, cols = config.rows, config.cols
        self.pot_bodies = np.array(
            [
                [name(mujoco.mjtObj.mjOBJ_BODY, f"pot_{r}_{c}") for c in range(cols)]
                for r in range(rows)
            ]
        )
        flat = self.pot_bodies.ravel()
        self._rib_geoms_by_row = [
            np.array([g for g in range(m.ngeom) if (m.geom(g).name or "").startswith(f"rib_{r}_")])
            for r in range(rows)
        ]
        self._row_y = config.pickup_row_y + np.arange(rows) * config.row_pitch
        self.pot_geoms = np.array(
            [
                name(mujoco.mjtObj.mjOBJ_GEOM, f"pot_{r}_{c}")
                for r in range(rows)
                for c in range(cols)
            ]
        )
        self.pot_qpos_adr = m.jnt_qposadr[m.body_jntadr[flat]].copy()
        self.pot_dof_adr = m.jnt_dofadr[m.body_jntadr[flat]].copy()

        ngeom = m.ngeom
        self.jaw_geoms = np.array(
            [name(mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("jaw_left", "jaw_right")]
        )
        self._is_jaw = np.zeros(ngeom, bool)
        self._is_jaw[self.jaw_geoms] = True
        self._pot_of_geom = np.full(ngeom, -1)
        self._pot_of_geom[self.pot_geoms] = np.arange(flat.size)
        gripper_body = name(mujoco.mjtObj.mjOBJ_BODY, "gripper")
        gripper_bodies = {gripper_body} | {
            b for b in range(m.nbody) if m.body_parentid[b] == gripper_body
        }
        self._is_gripper = np.isin(m.geom_bodyid, list(gripper_bodies)) & (m.geom_contype > 0)
        self._gripper_boxes = np.flatnonzero(
            self._is_gripper & (m.geom_type == mujoco.mjtGeom.mjGEOM_BOX)
        )
        self._gripper_half = m.geom_size[self._gripper_boxes].copy()
        self._leaf_geoms = np.array(
            [g for g in range(ngeom) if (m.geom(g).name or "").startswith("leaf_")], dtype=int
        )
        body_to_pot = np.full(m.nbody, -1)
        body_to_pot[flat] = np.arange(flat.size)
        self._leaf_pot = body_to_pot[m.geom_bodyid[self._leaf_geoms]]
        self._leaf_radius = m.geom_size[self._leaf_geoms, 0].copy()
        self._leaf_axis_t = (
            np.linspace(-1.0, 1.0, LEAF_SAMPLES)[None, :, None]
            * (m.geom_size[self._leaf_geoms, 1][:, None, None])
        )

        tube_x, tube_y = config.drop_tube_xy
        self._tube_xy = np.array([tube_x, tube_y])
        self._tube_inner_radius = config.funnel_throat_diameter / 2
        self._throat_z = config.funnel_top_z - config.funnel_height
        self._last_conveyor_data: mujoco.MjData | None = None

    # ----- state -----
    def make_data(self) -> mujoco.MjData:
        """New MjData at the home keyframe, forward-ed."""
        data = mujoco.MjData(self.model)
        mujoco.mj_resetDataKeyframe(self.model, data, self.home_key)
        mujoco.mj_forward(self.model, data)
        return data

    # ----- drives -----
    def set_motor_targets(self, data: mujoco.MjData, joint_positions) -> None:
        """Command theta1, theta2 (rad) and Z (m): ctrl = gear * position (motor radians)."""
        data.ctrl[self.motor_actuators] = self.motor_gears * np.asarray(joint_positions, float)

    def joint_positions(self, data: mujoco.MjData) -> np.ndarray:
        """Actual theta1, theta2 (rad), Z (m)."""
        return data.qpos[self.motor_qpos_adr].copy()

    def set_gripper_opening(self, data: mujoco.MjData, opening_m: float) -> None:
        """Servo target for the jaw opening (m), clipped to [0, gripper_max_opening]."""
        data.ctrl[self.gripper_actuator] = min(max(opening_m, 0.0), self.config.gripper_max_opening)

    def gripper_opening(self, data: mujoco.MjData) -> float:
        return float(data.ten_length[self.jaw_tendon])

    def set_wrist_angle(self, data: mujoco.MjData, angle_rad: float) -> None:
        """Wrist servo target (rad); gripper approach axis in the world = psi1 + wrist."""
        data.ctrl[self.wrist_actuator] = angle_rad

    def limit_switches(self, data: mujoco.MjData) -> np.ndarray:
        """Switches 1-4 (bool): theta1 >= trip1, theta2 <= trip2, z >= trip3, z <= trip4."""
        q = data.qpos[self.switch_qpos_adr]
        return self.switch_sense * (q - self.switch_trip) >= 0

    # ----- pots -----
    def pot_positions(self, data: mujoco.MjData) -> np.ndarray:
        """(rows*cols, 3) pot centres (geometric centre of the cylinder), row-major."""
        return data.xpos[self.pot_bodies.ravel()].copy()

    def pot_in_tube(self, data: mujoco.MjData) -> np.ndarray:
        """Pots whose centre is inside the tube radius and below the funnel throat."""
        p = data.xpos[self.pot_bodies.ravel()]
        radial = np.hypot(p[:, 0] - self._tube_xy[0], p[:, 1] - self._tube_xy[1])
        return (radial < self._tube_inner_radius) & (p[:, 2] < self._throat_z)

    def _contact_pairs(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        n = data.ncon
        if n == 0:
            empty = np.zeros(0, int)
            return empty, empty
        return data.contact.geom1[:n], data.contact.geom2[:n]

    def _jaw_pot_contacts(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        g1, g2 = self._contact_pairs(data)
        p1, p2 = self._pot_of_geom[g1], self._pot_of_geom[g2]
        mask = (self._is_jaw[g1] & (p2 >= 0)) | (self._is_jaw[g2] & (p1 >= 0))
        idx = np.flatnonzero(mask)
        return idx, np.maximum(p1, p2)[idx]

    def grip_force(self, data: mujoco.MjData) -> float:
        """Sum of the normal forces between the jaws and any pot (N)."""
        idx, _ = self._jaw_pot_contacts(data)
        total = 0.0
        wrench = np.zeros(6)
        for i in idx:
            mujoco.mj_contactForce(self.model, data, int(i), wrench)
            total += wrench[0]
        return total

    def pots_touching_jaws(self, data: mujoco.MjData) -> np.ndarray:
        """Flat indices (row-major) of the pots in contact with a jaw, sorted."""
        _, pots = self._jaw_pot_contacts(data)
        return np.unique(pots)

    def leaf_hit_pots(self, data: mujoco.MjData) -> np.ndarray:
        """Flat indices of the pots whose seedling leaves touch the gripper, sorted.

        A leaf touches when a point of its capsule axis lies within the capsule radius of
        the palm or a jaw (LEAF_SAMPLES points per leaf, so accurate to a few mm).
        """
        grip = data.site_xpos[self.grip_site, :2]
        pot_xy = data.xpos[self.pot_bodies.ravel(), :2]
        near = np.hypot(*(pot_xy - grip).T) < LEAF_NEAR_M
        leaves = np.flatnonzero(near[self._leaf_pot])
        if leaves.size == 0:
            return np.zeros(0, dtype=int)
        geoms = self._leaf_geoms[leaves]
        axis = data.geom_xmat[geoms].reshape(-1, 3, 3)[:, :, 2]
        points = data.geom_xpos[geoms][:, None, :] + self._leaf_axis_t[leaves] * axis[:, None, :]
        hit = np.zeros(leaves.size, dtype=bool)
        for box, half in zip(self._gripper_boxes, self._gripper_half, strict=True):
            local = (points - data.geom_xpos[box]) @ data.geom_xmat[box].reshape(3, 3)
            outside = np.maximum(np.abs(local) - half, 0.0)
            dist = np.sqrt((outside * outside).sum(axis=2)).min(axis=1)
            hit |= dist < self._leaf_radius[leaves]
        return np.unique(self._leaf_pot[leaves[hit]])

    def leaf_hits(self, data: mujoco.MjData) -> bool:
        """True when the gripper touches any seedling's leaves (its own pot's included)."""
        return self.leaf_hit_pots(data).size > 0

    # ----- conveyor -----
    def conveyor_index_phases(self, total_s: float) -> tuple[float, float]:
        """Split an index's total time (s) into (profile, settle) durations (s).

        settle = min(conveyor_settle_s, 0.25 * total_s): the PD hold at the end of the profile
        that lets the carriage and the pots come to rest before the force is released.
        """
        settle = min(self.config.conveyor_settle_s, 0.25 * total_s)
        return total_s - settle, settle

    def start_conveyor_index(self, data: mujoco.MjData, now: float, total_s: float) -> None:
        """Index the conveyor by one row (towards -y), done by `now + total_s`.

        total_s is the whole index time (the scenario's index time, after which the SGF
        acknowledges M710): the carriage follows the push-and-return profile, is held while
        it settles (conveyor_index_phases), and by now + total_s it is at rest, the drive
        force is released and a new index may start. The state lives in
        data.userdata[0:USERDATA_CONVEYOR].
        """
        if not (math.isfinite(total_s) and total_s > 0):
            raise ValueError(f"conveyor index time must be > 0 s, got {total_s}")
        u = data.userdata
        if u[_U_ACTIVE] != 0.0:
            if not self._conveyor_done(data, now):
                raise RuntimeError(
                    f"conveyor is already indexing until t = {u[_U_END]:.4f} s (now {now:.4f} "
                    "s); wait until conveyor_indexing() is False"
                )
            self._release_conveyor(data)
        profile_s, _ = self.conveyor_index_phases(total_s)
        pitch = self.config.row_pitch
        q0 = round(data.qpos[self.conveyor_qpos_adr] / pitch) * pitch
        self._drop_rows_past_the_edge(q0 - pitch)
        u[_U_ACTIVE], u[_U_T0], u[_U_PROFILE], u[_U_END], u[_U_Q0] = (
            1.0,
            now,
            profile_s,
            now + total_s,
            q0,
        )
        self._last_conveyor_data = data

    def conveyor_indexing(self, now: float, data: mujoco.MjData | None = None) -> bool:
        """True while an index (profile and settle) is under way, until start + total_s.

        It ends half a timestep early, so that rounding in data.time cannot add a step.

        `data` defaults to the MjData last passed to start_conveyor_index.
        """
        data = data if data is not None else self._last_conveyor_data
        if data is None or data.userdata[_U_ACTIVE] == 0.0:
            return False
        return not self._conveyor_done(data, now)

    def _drop_rows_past_the_edge(self, q_after: float) -> None:
        """Rows whose cells leave the belt's top run at this index go round the front drum:
        their ribs stop touching anything and are no longer drawn. Without this the ribs of
        emptied rows would sweep on through the drop tube and jam on the pot dropped last.
        (This edits the model, which a Scene shares with its MjData: one simulation each.)"""
        edge = self.config.pickup_row_y - self.config.row_pitch / 2
        for y, geoms in zip(self._row_y, self._rib_geoms_by_row, strict=True):
            if y + q_after < edge - 1e-9 and self.model.geom_conaffinity[geoms[0]] != 0:
                self.model.geom_conaffinity[geoms] = 0
                self.model.geom_rgba[geoms, 3] = 0.0

    def conveyor_armed(self, data: mujoco.MjData) -> bool:
        """True from start_conveyor_index until apply_conveyor has released the drive: as
        long as this holds, apply_conveyor must be called before every physics step."""
        return data.userdata[_U_ACTIVE] != 0.0

    def conveyor_reference(self, data: mujoco.MjData, now: float) -> tuple[float, float]:
        """Reference position (m) and velocity (m/s) of the carriage at `now`.

        Min-jerk push by row_pitch + overshoot over conveyor_push_share of the profile, then
        min-jerk return by the overshoot; after the profile it holds the end position.
        """
        u = data.userdata
        t0, duration, q0 = u[_U_T0], u[_U_PROFILE], u[_U_Q0]
        cfg = self.config
        push_share = cfg.conveyor_push_share
        t = min(max(now - t0, 0.0), duration)
        overshoot = cfg.index_overshoot
        travel = cfg.row_pitch + overshoot
        if t < push_share * duration:
            T = push_share * duration
            s, ds = _min_jerk(t / T)
            return q0 - travel * s, -travel * ds / T
        T = (1 - push_share) * duration
        s, ds = _min_jerk((t - push_share * duration) / T)
        return q0 - travel + overshoot * s, overshoot * ds / T

    def apply_conveyor(self, data: mujoco.MjData, now: float) -> None:
        """Call before every physics step: PD force along the index profile, else nothing."""
        u = data.userdata
        if u[_U_ACTIVE] == 0.0:
            return
        if self._conveyor_done(data, now):
            self._release_conveyor(data)
            return
        cfg = self.config
        q_ref, v_ref = self.conveyor_reference(data, now)
        q = data.qpos[self.conveyor_qpos_adr]
        v = data.qvel[self.conveyor_dof_adr]
        force = cfg.conveyor_kp * (q_ref - q) + cfg.conveyor_kd * (v_ref - v)
        # -0.0 would also wake the tree; an exact zero would let it sleep mid-index.
        data.qfrc_applied[self.conveyor_dof_adr] = force if force != 0.0 else 1e-12

    def _conveyor_done(self, data: mujoco.MjData, now: float) -> bool:
        # Half a timestep of slack: data.time, a sum of timesteps, drifts by rounding.
        return now >= data.userdata[_U_END] - 0.5 * self.model.opt.timestep

    def _release_conveyor(self, data: mujoco.MjData) -> None:
        # An exact 0.0 lets the carriage's tree fall asleep again.
        data.qfrc_applied[self.conveyor_dof_adr] = 0.0
        data.userdata[_U_ACTIVE] = 0.0

    def conveyor_position(self, data: mujoco.MjData) -> float:
        return float(data.qpos[self.conveyor_qpos_adr])


def _min_jerk(tau: float) -> tuple[float, float]:
    tau = min(max(tau, 0.0), 1.0)
    s = tau**3 * (10 - 15 * tau + 6 * tau**2)
    ds = 30 * tau**2 * (1 - tau) ** 2
    return s, ds


def _apply_arm(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    spec.body("link1").pos = [-cfg.l0, 0, 0]
    spec.body("link2").pos = [cfg.l0, 0, 0]
    spec.geom("motor1").pos = [-cfg.l0, 0, spec.geom("motor1").pos[2]]
    spec.geom("motor2").pos = [cfg.l0, 0, spec.geom("motor2").pos[2]]
    for i in (1, 2):
        spec.geom(f"link{i}").fromto = [0, 0, 0, cfg.l1, 0, 0]
        spec.geom(f"link{i}").mass = cfg.active_link_mass
        spec.body(f"passive{i}").pos = [cfg.l1, 0, -PASSIVE_DROP]
        spec.geom(f"passive{i}").fromto = [0, 0, 0, cfg.l2, 0, 0]
        spec.geom(f"passive{i}").mass = cfg.passive_link_mass
        spec.site(f"c{i}").pos = [cfg.l2, 0, 0]
    spec.body("gripper").pos = [cfg.l2, 0, PASSIVE_DROP]
    spec.geom("platform").mass = cfg.platform_mass
    # Column: arm plane at column_height above the grip centre (the gripper's parts below C
    # are laid out relative to the grip centre).
    shift = cfg.column_height - XML_COLUMN_HEIGHT
    spec.body("platform").pos = [0, 0, cfg.column_height]
    for geom_name in ("palm", "palm_visual"):
        g = spec.geom(geom_name)
        g.pos = [g.pos[0], g.pos[1], g.pos[2] - shift]
    column = spec.geom("column")
    column_top = -WRIST_SERVO_BOTTOM
    column_bottom = -(cfg.column_height - JAW_HALF_HEIGHT - PALM_HEIGHT)
    if column_bottom >= column_top:
        raise ValueError("SceneConfig.column_height too small for the wrist servo and palm")
    column.size = [column.size[0], (column_top - column_bottom) / 2, 0]
    column.pos = [0, 0, (column_top + column_bottom) / 2]
    spec.site("grip_center").pos = [0, 0, -cfg.column_height]
    spec.body("jaw_left").pos = [-JAW_HALF_THICKNESS, 0, -cfg.column_height]
    spec.body("jaw_right").pos = [JAW_HALF_THICKNESS, 0, -cfg.column_height]

    # Stepper drives.
    arm_gear, screw_gear = cfg.arm_belt_ratio, cfg.screw_gear
    screw_torque = cfg.holding_torque * cfg.screw_efficiency
    for joint_name, gear, torque, scale in (
        ("theta1", arm_gear, cfg.holding_torque, cfg.arm_stiffness_scale),
        ("theta2", arm_gear, cfg.holding_torque, cfg.arm_stiffness_scale),
        ("z", screw_gear, screw_torque, cfg.z_stiffness_scale),
    ):
        act = spec.actuator(joint_name)
        kp = scale * torque / cfg.full_step_rad
        act.gear = [gear, 0, 0, 0, 0, 0]
        act.gainprm = [kp] + [0] * 9
        act.biasprm = [0, -kp, cfg.stepper_dampratio] + [0] * 7
        act.forcerange = [-torque, torque]
        joint = spec.joint(joint_name)
        joint.range = list(getattr(cfg, f"{joint_name}_range"))
        joint.damping = [torque / cfg.pullout_zero_speed * gear**2, 0, 0]
        joint.armature = cfg.rotor_inertia * gear**2

    grip = spec.actuator("gripper")
    grip.gainprm = [cfg.gripper_kp] + [0] * 9
    grip.biasprm = [0, -cfg.gripper_kp, 0] + [0] * 7
    grip.forcerange = [-cfg.grip_force, cfg.grip_force]
    grip.ctrlrange = [0, cfg.gripper_max_opening]
    for jaw in ("jaw_left", "jaw_right"):
        spec.joint(jaw).range = [0, cfg.gripper_max_opening / 2]
        spec.joint(jaw).damping = [cfg.jaw_damping, 0, 0]
        spec.geom(jaw).friction = [cfg.jaw_friction, 0.005, 0.0001]
    wrist = spec.actuator("wrist")
    wrist.gainprm = [cfg.wrist_kp] + [0] * 9
    wrist.biasprm = [0, -cfg.wrist_kp, 0] + [0] * 7
    wrist.forcerange = [-cfg.wrist_torque, cfg.wrist_torque]

    spec.numeric("limit_switch_trip").data = [
        cfg.switch1_theta1_min,
        cfg.switch2_theta2_max,
        cfg.switch3_z_min,
        cfg.switch4_z_max,
    ]


def _apply_options(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    opt = spec.option
    opt.timestep = cfg.timestep
    opt.impratio = cfg.impratio
    opt.iterations = cfg.solver_iterations
    opt.tolerance = cfg.solver_tolerance
    opt.jacobian = {
        "auto": mujoco.mjtJacobian.mjJAC_AUTO,
        "dense": mujoco.mjtJacobian.mjJAC_DENSE,
        "sparse": mujoco.mjtJacobian.mjJAC_SPARSE,
    }[cfg.jacobian]
    opt.sleep_tolerance = cfg.sleep_tolerance
    bit = int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    opt.enableflags = (opt.enableflags | bit) if cfg.sleep else (opt.enableflags & ~bit)


def _apply_drop_tube(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    body = spec.body("drop_tube")
    x, y = cfg.drop_tube_xy
    body.pos = [x, y, cfg.funnel_top_z]
    for geom in list(body.geoms):
        if geom.name.startswith("tube_wall_"):
            spec.delete(geom)
    for k, (half, pos, quat) in enumerate(drop_tube_boxes(cfg)):
        _add_static_box(body, f"tube_wall_{k}", half, pos, quat)
    bottom_z = -cfg.funnel_height - cfg.tube_length
    plate = spec.geom("planting_plate")
    plate.pos = [0, 0, bottom_z - plate.size[2]]


def _add_static_box(body, name, half, pos, quat) -> None:
    geom = body.add_geom()
    geom.name = name
    geom.type = mujoco.mjtGeom.mjGEOM_BOX
    geom.size = half
    geom.pos = pos
    geom.quat = quat
    geom.contype = BIT_WORLD
    geom.conaffinity = BIT_POT | BIT_GRIPPER
    geom.group = 3
    geom.rgba = [0.5, 0.5, 0.55, 0.3]


def build_scene(config: SceneConfig | None = None, seed: int = 0) -> Scene:
    """Build and compile the full scene: machine, conveyor with ribs, pots, drop tube."""
    cfg = config if config is not None else SceneConfig()
    spec = mujoco.MjSpec.from_file(str(models_dir() / "scene.xml"))
    _apply_options(spec, cfg)
    _apply_arm(spec, cfg)
    _apply_drop_tube(spec, cfg)
    rng = np.random.default_rng(seed)
    pot_params = _add_conveyor_and_pots(spec, cfg, rng)

    # Home keyframe for the full state.
    phi1, phi2 = five_bar_forward(cfg, cfg.home_theta1, cfg.home_theta2)
    model0 = spec.compile()
    qpos = model0.qpos0.copy()
    named = {
        "z": cfg.home_z,
        "theta1": cfg.home_theta1,
        "theta2": cfg.home_theta2,
        "phi1": phi1,
        "phi2": phi2,
        "wrist": 0.0,
        "jaw_left": cfg.gripper_max_opening / 2,
        "jaw_right": cfg.gripper_max_opening / 2,
        "conveyor": 0.0,
    }
    for joint_name, value in named.items():
        qpos[model0.joint(joint_name).qposadr[0]] = value
    key = spec.key("home")
    key.qpos = qpos
    key.ctrl = [
        cfg.arm_belt_ratio * cfg.home_theta1,
        cfg.arm_belt_ratio * cfg.home_theta2,
        cfg.screw_gear * cfg.home_z,
        cfg.gripper_max_opening,
        0.0,
    ]
    model = spec.compile()
    return Scene(model, cfg, pot_params)


def _add_conveyor_and_pots(spec: mujoco.MjSpec, cfg: SceneConfig, rng) -> dict:
    conveyor = spec.body("conveyor")
    joint = spec.joint("conveyor")
    joint.frictionloss = cfg.conveyor_frictionloss
    conveyor.mass = cfg.conveyor_mass
    rows, cols = cfg.rows, cfg.cols
    half_width = cols * cfg.cell_pitch / 2
    xs = (np.arange(cols) - (cols - 1) / 2) * cfg.cell_pitch
    ys = cfg.pickup_row_y + np.arange(rows) * cfg.row_pitch

    # Belt table: static, from the front edge of the pickup row to behind the last row.
    table = spec.geom("belt_table")
    front = cfg.pickup_row_y - cfg.row_pitch / 2
    back = ys[-1] + cfg.row_pitch
    table.size = [half_width + 0.02, (back - front) / 2, table.size[2]]
    table.pos = [0, (front + back) / 2, -table.size[2]]

    rib_half_h = cfg.rib_height / 2
    rib_half_t = cfg.rib_thickness / 2
    for r in range(rows):
        bit = 1 << (ROW_BIT_FIRST + r % ROW_BITS)
        ribs = [
            (
                [half_width, rib_half_t, rib_half_h],
                [0, ys[r] + side * cfg.row_pitch / 2, rib_half_h],
            )
            for side in (-1, 1)
        ]
        ribs += [
            ([rib_half_t, cfg.row_pitch / 2, rib_half_h], [x, ys[r], rib_half_h])
            for x in (np.arange(cols + 1) - cols / 2) * cfg.cell_pitch
        ]
        for k, (size, pos) in enumerate(ribs):
            g = conveyor.add_geom()
            g.name = f"rib_{r}_{k}"
            g.type = mujoco.mjtGeom.mjGEOM_BOX
            g.size = size
            g.pos = pos
            g.contype = 0
            g.conaffinity = bit
            g.priority = 2
            g.friction = [cfg.rib_friction, 0.005, 0.0001]
            g.mass = 0
            g.rgba = [0.2, 0.2, 0.2, 1]

    n = rows * cols
    diam = cfg.pot_diameter + cfg.pot_diameter_sd * rng.standard_normal(n)
    height = cfg.pot_height + cfg.pot_height_sd * rng.standard_normal(n)
    mass = np.clip(cfg.pot_mass + cfg.pot_mass_sd * rng.standard_normal(n), *cfg.pot_mass_range)
    friction = np.maximum(
        cfg.pot_friction + cfg.pot_friction_sd * rng.standard_normal(n), cfg.pot_friction_min
    )
    offset = np.clip(
        cfg.pot_offset_sd * rng.standard_normal((n, 2)), -cfg.pot_offset_max, cfg.pot_offset_max
    )
    stem = rng.uniform(*cfg.stem_length_range, n)
    n_leaves = rng.integers(cfg.leaves_range[0], cfg.leaves_range[1] + 1, n)
    leaf_yaw0 = rng.uniform(0, 2 * np.pi, n)

    for i in range(n):
        r, c = divmod(i, cols)
        radius, h = diam[i] / 2, height[i]
        body = spec.worldbody.add_body()
        body.name = f"pot_{r}_{c}"
        body.pos = [xs[c] + offset[i, 0], ys[r] + offset[i, 1], h / 2]
        body.add_freejoint()
        total_mass = mass[i] + cfg.seedling_mass
        body.mass = total_mass
        body.ipos = [0, 0, 0]
        body.inertia = _pot_inertia(total_mass, radius, h)
        body.explicitinertial = True
        g = body.add_geom()
        g.name = f"pot_{r}_{c}"
        g.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        g.size = [radius, h / 2, 0]
        g.contype = BIT_POT | (1 << (ROW_BIT_FIRST + r % ROW_BITS))
        g.conaffinity = BIT_WORLD | BIT_POT | BIT_GRIPPER
        g.condim = 4
        g.priority = 1
        g.friction = [friction[i], 0.005, 0.0001]
        g.solref = list(cfg.contact_solref)
        g.solimp = list(cfg.contact_solimp)
        g.group = 3
        g.rgba = [0.55, 0.4, 0.25, 0.5]
        vis = body.add_geom()
        vis.type = mujoco.mjtGeom.mjGEOM_MESH
        vis.meshname = "paper_pot"
        vis.pos = [0, 0, -h / 2]
        vis.contype = vis.conaffinity = 0
        vis.group = 2
        vis.mass = 0
        vis.material = "paper"
        top = h / 2
        stem_geom = body.add_geom()
        stem_geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE
        stem_geom.fromto = [0, 0, top, 0, 0, top + stem[i]]
        stem_geom.size = [0.0015, 0, 0]
        stem_geom.contype = stem_geom.conaffinity = 0
        stem_geom.group = 2
        stem_geom.mass = 0
        stem_geom.material = "leaf"
        for k in range(n_leaves[i]):
            yaw = leaf_yaw0[i] + 2 * np.pi * k / n_leaves[i]
            base = np.array([0, 0, top + stem[i] * (0.7 + 0.3 * (k % 2))])
            quat = np.zeros(4)
            mujoco.mju_euler2Quat(quat, np.array([0.0, -0.35, yaw]), "xyz")
            leaf_vis = body.add_geom()
            leaf_vis.type = mujoco.mjtGeom.mjGEOM_MESH
            leaf_vis.meshname = "seedling_leaf"
            leaf_vis.pos = base
            leaf_vis.quat = quat
            leaf_vis.contype = leaf_vis.conaffinity = 0
            leaf_vis.group = 2
            leaf_vis.mass = 0
            leaf_vis.material = "leaf"
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, quat)
            centre = base + rot.reshape(3, 3) @ np.array([0.0225, 0.0, 0.004])
            proxy = body.add_geom()
            proxy.name = f"leaf_{r}_{c}_{k}"
            # A capsule along the leaf's length: capsule-box contacts with the gripper are
            # analytic, ellipsoids would take the general convex solver (3x the narrowphase).
            proxy.type = mujoco.mjtGeom.mjGEOM_CAPSULE
            proxy.size = [0.006, 0.0165, 0]
            proxy.pos = centre
            along_x = np.zeros(4)
            mujoco.mju_mulQuat(along_x, quat, _CAPSULE_Z_TO_X)
            proxy.quat = along_x
            proxy.contype = proxy.conaffinity = 0  # tested geometrically: leaf_hit_pots
            proxy.group = 4
            proxy.mass = 0
            proxy.rgba = [0.2, 0.8, 0.2, 0.3]
    return {
        "diameter": diam,
        "height": height,
        "mass": mass,
        "friction": friction,
        "offset": offset,
        "cell_xy": np.array([[xs[c], ys[r]] for r in range(rows) for c in range(cols)]),
    }
