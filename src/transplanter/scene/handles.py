"""The compiled scene's handles: index arrays, per-step accessors, contact sensing, leaves.

A `Scene` (returned by build_scene) looks every name up once and offers cheap per-step
accessors on an MjData: motor targets and positions, gripper and wrist, limit switches,
pot positions, jaw contacts and grip force, seedling leaf hits. The conveyor's drive is a
separate controller (transplanter.scene.conveyor.ConveyorDrive).

Leaves: a capsule proxy per leaf in each pot's frame, outside the physics model (leaves are
a few grams of soft tissue: they must not push the gripper, and colliding them every step
tripled the narrowphase). `leaf_hit_pots` tests them against the gripper's boxes
geometrically, only for the pots near the gripper, when the trial asks.

Drawing: the physics model has no pot decor (build_scene); `render_model` is the decorated
model with the same bodies and joints, `render_data` mirrors a physics state onto it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from transplanter.scene import kinds
from transplanter.scene.config import SceneConfig
from transplanter.scene.conveyor import conveyor_armed
from transplanter.scene.live_rows import LiveRows
from transplanter.scene.pots import PotBatch
from transplanter.scene.stepper import StepperDrives

LEAF_SAMPLES = 5  # points along each leaf capsule's axis tested against the gripper boxes
LEAF_NEAR_M = 0.09  # only pots this close (xy) to the grip centre can touch the gripper


@dataclass(frozen=True)
class LeafProxies:
    """Every seedling leaf as a capsule in its pot's frame: pot (flat index), centre (n, 3)
    and axis (n, 3, unit) in the pot body's frame, radius and half length (m)."""

    pot: np.ndarray
    centre: np.ndarray
    axis: np.ndarray
    radius: float
    half_length: float


@dataclass(frozen=True)
class GripperParts:
    """The names of an effector's parts the pot line's handles need: its root body (the
    gripper's boxes under it and its direct children are what leaves can touch), the geoms
    that grip a pot (jaws, pads), its grip-centre site and the bridge over the grip (the geom a
    shoot under the gripper meets first)."""

    root: str
    pads: tuple[str, ...]
    site: str
    bridge: str


class PotLine:
    """The pot line's handles on a compiled scene, whatever robot works it: the pots (bodies,
    addresses, the tube, the window of live rows), the conveyor's slide, the seedlings' leaves
    and the effector's contacts with them (`gripper`: its parts' names)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        config: SceneConfig,
        pots: PotBatch,
        leaves: LeafProxies,
        gripper: GripperParts,
        decorated: Callable[[], mujoco.MjModel] | None = None,
    ):
        self.model = model
        self.config = config
        self.pots = pots  # the PotBatch the scene was built with
        self.leaves = leaves
        self._decorated = decorated
        self._render_model: mujoco.MjModel | None = None
        self._render_data: mujoco.MjData | None = None
        m = model
        name = lambda kind, n: mujoco.mj_name2id(m, kind, n)  # noqa: E731
        self.grip_site = name(mujoco.mjtObj.mjOBJ_SITE, gripper.site)
        conveyor_joint = name(mujoco.mjtObj.mjOBJ_JOINT, "conveyor")
        self.conveyor_qpos_adr = int(m.jnt_qposadr[conveyor_joint])
        self.conveyor_dof_adr = int(m.jnt_dofadr[conveyor_joint])
        # bonded pots' adhesion (build._add_bond): actuator ids and their pots' flat indices
        bonds = [a for a in range(m.nu) if (m.actuator(a).name or "").startswith("bond_")]
        self.bond_actuators = np.array(bonds, dtype=int)
        self.bond_pots = np.array(
            [
                int(r) * config.cols + int(c)
                for r, c in (m.actuator(a).name.split("_")[1:3] for a in bonds)
            ],
            dtype=int,
        )
        rows, cols = config.rows, config.cols
        # a pot's body, geom and addresses; -1 for a pot that is not a body now (a windowed
        # scene, config.live_rows < rows: scene.live_rows moves pots in and out)
        self.pot_bodies = np.array(
            [
                [name(mujoco.mjtObj.mjOBJ_BODY, f"pot_{r}_{c}") for c in range(cols)]
                for r in range(rows)
            ]
        )
        flat = self.pot_bodies.ravel()
        self.pot_live = flat >= 0
        self.pot_geoms = np.array(
            [
                name(mujoco.mjtObj.mjOBJ_GEOM, f"pot_{r}_{c}")
                for r in range(rows)
                for c in range(cols)
            ]
        )
        live = self.pot_live
        self.pot_qpos_adr = np.full(flat.size, -1)
        self.pot_dof_adr = np.full(flat.size, -1)
        self.pot_qpos_adr[live] = m.jnt_qposadr[m.body_jntadr[flat[live]]]
        self.pot_dof_adr[live] = m.jnt_dofadr[m.body_jntadr[flat[live]]]

        ngeom = m.ngeom
        self.palm_geom = name(mujoco.mjtObj.mjOBJ_GEOM, gripper.bridge)  # over the grip
        self.jaw_geoms = np.array([name(mujoco.mjtObj.mjOBJ_GEOM, n) for n in gripper.pads])
        self._is_jaw = np.zeros(ngeom, bool)
        self._is_jaw[self.jaw_geoms] = True
        self._pot_of_geom = np.full(ngeom, -1)
        self._pot_of_geom[self.pot_geoms[live]] = np.flatnonzero(live)
        for g in range(ngeom):  # crooked pots' feet (workcells.conveyor_tube.add_pots)
            if (m.geom(g).name or "").startswith("pot_foot_"):
                r, c = (int(x) for x in m.geom(g).name.split("_")[2:4])
                self._pot_of_geom[g] = r * config.cols + c
        self._pot_of_geom_list = self._pot_of_geom.tolist()
        # leaf proxies in the physics model (pots.canopy_contact): their pot, else -1
        leaf_pot = np.full(ngeom, -1)
        for g in range(ngeom):
            geom_name = m.geom(g).name or ""
            if geom_name.startswith("leaf_"):
                r, c = (int(x) for x in geom_name.split("_")[1:3])
                leaf_pot[g] = r * config.cols + c
        self.has_canopy_contact = bool((leaf_pot >= 0).any())
        self._leaf_pot_of_geom_list = leaf_pot.tolist()
        self._is_jaw_list = self._is_jaw.tolist()
        gripper_body = name(mujoco.mjtObj.mjOBJ_BODY, gripper.root)
        gripper_bodies = {gripper_body} | {
            b for b in range(m.nbody) if m.body_parentid[b] == gripper_body
        }
        self._is_gripper = np.isin(m.geom_bodyid, list(gripper_bodies)) & (m.geom_contype > 0)
        self._gripper_boxes = np.flatnonzero(
            self._is_gripper & (m.geom_type == mujoco.mjtGeom.mjGEOM_BOX)
        )
        self._gripper_half = m.geom_size[self._gripper_boxes].copy()
        self._pot_bodies_flat = flat  # a view: set_pot_body updates it
        # a pot's leaves lie within this of its centre; a gripper box within its half
        # diagonal of its own (m): a leaf can touch a box only if the spheres overlap
        reach = np.zeros(flat.size)
        np.maximum.at(
            reach,
            leaves.pot,
            np.linalg.norm(leaves.centre, axis=1) + leaves.half_length + leaves.radius,
        )
        box_radius = np.linalg.norm(self._gripper_half, axis=1)
        self._leaf_reach_sq = (reach[:, None] + box_radius[None, :]) ** 2
        # each pot's leaves: self.leaves[first[p]:first[p + 1]] (built in pot order)
        self._leaf_first = np.searchsorted(leaves.pot, np.arange(flat.size + 1))
        self._leaf_axis_t = np.linspace(-1.0, 1.0, LEAF_SAMPLES)[None, :, None] * (
            leaves.half_length
        )

        tube_x, tube_y = config.drop_tube_xy_m
        self._tube_xy = np.array([tube_x, tube_y])
        self._tube_inner_radius = config.funnel_throat_diameter_m / 2
        self._throat_z = config.funnel_top_z_m - config.funnel_height_m
        self._funnel_top_z = config.funnel_top_z_m
        self._funnel_top_radius = config.funnel_top_diameter_m / 2
        self._pot_height = config.pot_height_m
        self.window: LiveRows | None = LiveRows(self) if config.windowed else None

    def set_pot_body(self, pot: int, body: int, geom: int, qpos_adr: int, dof_adr: int) -> None:
        """Pot `pot` is now this body (scene.live_rows), or no body (all -1)."""
        old = self.pot_geoms[pot]
        if old >= 0:
            self._pot_of_geom_list[old] = -1
        self.pot_bodies.ravel()[pot] = body
        self.pot_geoms[pot] = geom
        self.pot_qpos_adr[pot], self.pot_dof_adr[pot] = qpos_adr, dof_adr
        self.pot_live[pot] = body >= 0
        if geom >= 0:
            self._pot_of_geom_list[geom] = pot

    # ----- drawing -----
    @property
    def render_model(self) -> mujoco.MjModel:
        """The decorated model (pot meshes, stems, leaves, leaf proxies in group 4) with the
        physics model's bodies, joints and actuators, built on first use; the physics model
        itself when the scene was made without one."""
        if self._render_model is None:
            self._render_model = self.model if self._decorated is None else self._decorated()
        return self._render_model

    def render_data(self, data: mujoco.MjData) -> mujoco.MjData:
        """The physics state `data` on the render model: poses, cameras and lights (one
        reused MjData; contacts and forces are not carried). A windowed scene's render
        model has a body per pot: each stands where `LiveRows.poses` puts it."""
        model = self.render_model
        if model is self.model:
            return data
        if self._render_data is None:
            self._render_data = mujoco.MjData(model)
        mirror = self._render_data
        mirror.time = data.time
        if self.window is None:
            mirror.qpos[:] = data.qpos
            mirror.qvel[:] = data.qvel
        else:  # the machine's joints come first in both; then a pose per pot
            nq, nv = self.window.machine_nq, self.window.machine_nv
            mirror.qpos[:nq] = data.qpos[:nq]
            mirror.qvel[:nv] = data.qvel[:nv]
            mirror.qpos[nq:] = self.window.poses(data).ravel()
            mirror.qvel[nv:] = 0.0
        mirror.ctrl[:] = data.ctrl
        mujoco.mj_kinematics(model, mirror)
        mujoco.mj_comPos(model, mirror)
        mujoco.mj_camlight(model, mirror)
        return mirror

    # ----- pots -----
    def pot_positions(self, data: mujoco.MjData) -> np.ndarray:
        """(rows*cols, 3) pot centres (geometric centre of the cylinder), row-major; in a
        windowed scene, a pot that is not a body where it rides or lies (scene.live_rows)."""
        if self.window is not None:
            return self.window.positions(data)
        return data.xpos[self.pot_bodies.ravel()].copy()

    def pot_in_tube(self, data: mujoco.MjData) -> np.ndarray:
        """Pots whose centre is inside the tube radius and below the funnel throat."""
        p = (
            self.pot_positions(data)
            if self.window is not None
            else data.xpos[self.pot_bodies.ravel()]
        )
        radial = np.hypot(p[:, 0] - self._tube_xy[0], p[:, 1] - self._tube_xy[1])
        return (radial < self._tube_inner_radius) & (p[:, 2] < self._throat_z)

    def pot_in_funnel(self, data: mujoco.MjData) -> np.ndarray:
        """Pots caught in the funnel: the centre inside its mouth's radius, above its throat
        and no more than a pot's height over its top (a pot wedged on the rim included)."""
        p = self.pot_positions(data)
        radial = np.hypot(p[:, 0] - self._tube_xy[0], p[:, 1] - self._tube_xy[1])
        z = p[:, 2]
        return (
            (radial < self._funnel_top_radius)
            & (z >= self._throat_z)
            & (z <= self._funnel_top_z + self._pot_height)
        )

    def funnel_place(self, data: mujoco.MjData, pot: int) -> dict[str, float | None]:
        """Where a pot sits in the funnel: its centre under the funnel's top and off the
        tube's axis (mm), its axis from upright (deg; None when it is not a body now)."""
        p = self.pot_positions(data)[pot]
        body = int(self.pot_bodies.ravel()[pot])
        tilt = None
        if body >= 0:
            zz = float(np.clip(data.xmat[body][8], -1.0, 1.0))
            tilt = round(math.degrees(math.acos(zz)), 1)
        return {
            "below_top_mm": round(1000 * (self._funnel_top_z - float(p[2])), 1),
            "off_axis_mm": round(
                1000 * math.hypot(p[0] - self._tube_xy[0], p[1] - self._tube_xy[1]), 1
            ),
            "tilt_deg": tilt,
        }

    def _jaw_pot_contacts(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        n = data.ncon
        idx, pots = [], []
        if n:  # a handful of contacts: plain Python beats numpy's per-call cost here
            pot_of, is_jaw = self._pot_of_geom_list, self._is_jaw_list
            for i, (g1, g2) in enumerate(data.contact.geom[:n].tolist()):
                if (is_jaw[g1] and pot_of[g2] >= 0) or (is_jaw[g2] and pot_of[g1] >= 0):
                    idx.append(i)
                    pots.append(max(pot_of[g1], pot_of[g2]))
        return np.array(idx, dtype=int), np.array(pots, dtype=int)

    def grip_force(self, data: mujoco.MjData) -> float:
        """Sum of the normal forces between the jaws and any pot (N), as mj_contactForce
        reports them (the solver's normal force less any adhesion)."""
        idx, _ = self._jaw_pot_contacts(data)
        total = 0.0
        if self.model.opt.cone != mujoco.mjtCone.mjCONE_ELLIPTIC:
            wrench = np.zeros(6)
            for i in idx:
                mujoco.mj_contactForce(self.model, data, int(i), wrench)
                total += wrench[0]
            return total
        # elliptic cones: a contact's normal force is its first constraint row
        contact, efc_force = data.contact, data.efc_force
        rows, adhesion = contact.efc_address[idx].tolist(), contact.adhesion[idx].tolist()
        for row, pull in zip(rows, adhesion, strict=True):
            if row >= 0:
                total += efc_force[row] - pull
        return total

    def pots_with_leaves_on_jaws(self, data: mujoco.MjData) -> list[int]:
        """Pots (flat indices) whose leaf proxies touch a jaw now (only with canopy contact)."""
        if not self.has_canopy_contact:
            return []
        leaf_pot, is_jaw = self._leaf_pot_of_geom_list, self._is_jaw_list
        out = []
        for g1, g2 in data.contact.geom[: data.ncon].tolist():
            if is_jaw[g1] and leaf_pot[g2] >= 0:
                out.append(leaf_pot[g2])
            elif is_jaw[g2] and leaf_pot[g1] >= 0:
                out.append(leaf_pot[g1])
        return out

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
        if self.window is not None:
            return self._leaf_hit_live_pots(data, grip)
        pot_xyz = data.xpos[self._pot_bodies_flat]
        near = np.hypot(*(pot_xyz[:, :2] - grip).T) < LEAF_NEAR_M
        # only pots whose leaves' bounding sphere reaches a gripper box's (the gripper
        # passes high above most pots): the same hits, most calls stop here
        gap = pot_xyz[:, None, :] - data.geom_xpos[self._gripper_boxes][None, :, :]
        near &= ((gap * gap).sum(axis=2) <= self._leaf_reach_sq).any(axis=1)
        pot = self.leaves.pot
        leaves = np.flatnonzero(near[pot])
        return self._leaf_hits_of(data, leaves)

    def _leaf_hit_live_pots(self, data: mujoco.MjData, grip: np.ndarray) -> np.ndarray:
        """leaf_hit_pots of a windowed scene: the same tests over the pots that are bodies
        only, so its cost does not grow with the belt's length."""
        live = np.flatnonzero(self.pot_live)
        pot_xyz = data.xpos[self._pot_bodies_flat[live]]
        near = np.hypot(*(pot_xyz[:, :2] - grip).T) < LEAF_NEAR_M
        gap = pot_xyz[:, None, :] - data.geom_xpos[self._gripper_boxes][None, :, :]
        near &= ((gap * gap).sum(axis=2) <= self._leaf_reach_sq[live]).any(axis=1)
        first = self._leaf_first
        leaves = [np.arange(first[p], first[p + 1]) for p in live[near].tolist()]
        return self._leaf_hits_of(data, np.concatenate(leaves) if leaves else np.zeros(0, int))

    def _leaf_hits_of(self, data: mujoco.MjData, leaves: np.ndarray) -> np.ndarray:
        """The pots (sorted) of these leaves (indices into self.leaves) that touch a box."""
        pot = self.leaves.pot
        if leaves.size == 0:
            return np.zeros(0, dtype=int)
        bodies = self._pot_bodies_flat[pot[leaves]]
        rot = data.xmat[bodies].reshape(-1, 3, 3)
        centre = data.xpos[bodies] + np.einsum("nij,nj->ni", rot, self.leaves.centre[leaves])
        axis = np.einsum("nij,nj->ni", rot, self.leaves.axis[leaves])
        points = centre[:, None, :] + self._leaf_axis_t * axis[:, None, :]
        boxes = self._gripper_boxes
        # every sample point in every gripper box's frame: (boxes, leaves, samples, 3)
        rel = points[None, :, :, :] - data.geom_xpos[boxes][:, None, None, :]
        local = rel @ data.geom_xmat[boxes].reshape(-1, 1, 3, 3)
        outside = np.maximum(np.abs(local) - self._gripper_half[:, None, None, :], 0.0)
        dist = np.sqrt((outside * outside).sum(axis=3)).min(axis=2)
        hit = (dist < self.leaves.radius).any(axis=0)
        return np.unique(pot[leaves[hit]])

    def leaf_hits(self, data: mujoco.MjData) -> bool:
        """True when the gripper touches any seedling's leaves (its own pot's included)."""
        return self.leaf_hit_pots(data).size > 0

    # ----- conveyor (read only; ConveyorDrive drives it) -----
    def conveyor_position(self, data: mujoco.MjData) -> float:
        """Carriage position (m; 0 at build, -row_pitch_m after one index)."""
        return float(data.qpos[self.conveyor_qpos_adr])

    def conveyor_armed(self, data: mujoco.MjData) -> bool:
        """True while a ConveyorDrive index is armed in this MjData (until it is released)."""
        return conveyor_armed(data)


JAW_PARTS = GripperParts(root="gripper", pads=("jaw_left", "jaw_right"), site="grip_center",
                         bridge="palm")  # fmt: skip
"""The parallel jaws' parts (models/effectors/parallel_jaw) as the five-bar's scene names them."""


class Scene(PotLine):
    """The scene of a stepper robot on the pot line (the five-bar, the gantry): the line's
    handles (`PotLine`), the steppers' drives (the robot's scene module names its `MOTORS`,
    `ROOT`, `SWITCH_MOTORS` and `power_on`), the gripper's and wrist's servos, the limit
    switches and the home keyframe."""

    def __init__(
        self,
        model: mujoco.MjModel,
        config: SceneConfig,
        pots: PotBatch,
        leaves: LeafProxies,
        decorated: Callable[[], mujoco.MjModel] | None = None,
    ):
        super().__init__(model, config, pots, leaves, JAW_PARTS, decorated)
        m = model
        name = lambda kind, n: mujoco.mj_name2id(m, kind, n)  # noqa: E731
        robot = kinds.robot(config.robot_kind)
        self.robot_root = name(mujoco.mjtObj.mjOBJ_BODY, robot.ROOT)
        self.motor_actuators = np.array(
            [name(mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in robot.MOTORS]
        )
        self.motor_gears = m.actuator_gear[self.motor_actuators, 0].copy()
        motor_joints = [name(mujoco.mjtObj.mjOBJ_JOINT, n) for n in robot.MOTORS]
        self.motor_qpos_adr = m.jnt_qposadr[motor_joints].copy()
        # the steppers' torque laws; the detent's zero where they were energised at power-on
        self.drives = StepperDrives(
            list(config.stepper_params()),
            self.motor_actuators,
            self.motor_qpos_adr,
            self.motor_gears,
            robot.power_on(config),
        )
        self.gripper_actuator = name(mujoco.mjtObj.mjOBJ_ACTUATOR, "gripper")
        self.wrist_actuator = name(mujoco.mjtObj.mjOBJ_ACTUATOR, "wrist")
        self.wrist_qpos_adr = m.jnt_qposadr[name(mujoco.mjtObj.mjOBJ_JOINT, "wrist")]
        self.jaw_tendon = name(mujoco.mjtObj.mjOBJ_TENDON, "jaw_opening")
        self.c1_site = name(mujoco.mjtObj.mjOBJ_SITE, "c1")
        self.c2_site = name(mujoco.mjtObj.mjOBJ_SITE, "c2")
        self.home_key = name(mujoco.mjtObj.mjOBJ_KEY, "home")
        trip_adr = m.numeric_adr[name(mujoco.mjtObj.mjOBJ_NUMERIC, "limit_switch_trip")]
        sense_adr = m.numeric_adr[name(mujoco.mjtObj.mjOBJ_NUMERIC, "limit_switch_sense")]
        self.switch_trip = m.numeric_data[trip_adr : trip_adr + 4].copy()
        self.switch_sense = m.numeric_data[sense_adr : sense_adr + 4].copy()
        self.switch_qpos_adr = self.motor_qpos_adr[list(robot.SWITCH_MOTORS)]

    # ----- state -----
    def make_data(self) -> mujoco.MjData:
        """New MjData at the home keyframe, forward-ed."""
        data = mujoco.MjData(self.model)
        mujoco.mj_resetDataKeyframe(self.model, data, self.home_key)
        mujoco.mj_forward(self.model, data)
        return data

    # ----- drives -----
    def hold_motors(self, data: mujoco.MjData, joint_positions, joint_speeds=None) -> None:
        """The steppers' torques for the next physics step with their fields at theta1,
        theta2 (rad) and Z (m), moving at joint_speeds (default: at rest): call it before
        every step (transplanter.scene.stepper)."""
        self.drives.hold(data, joint_positions, joint_speeds)

    def joint_positions(self, data: mujoco.MjData) -> np.ndarray:
        """Actual theta1, theta2 (rad), Z (m)."""
        return data.qpos[self.motor_qpos_adr].copy()

    def set_gripper_opening(self, data: mujoco.MjData, opening_m: float) -> None:
        """Servo target for the jaw opening (m), clipped to [0, gripper_max_opening_m]."""
        data.ctrl[self.gripper_actuator] = min(
            max(opening_m, 0.0), self.config.gripper_max_opening_m
        )

    def gripper_opening(self, data: mujoco.MjData) -> float:
        return float(data.ten_length[self.jaw_tendon])

    def set_wrist_angle(self, data: mujoco.MjData, angle_rad: float) -> None:
        """Wrist servo target (rad); gripper approach axis in the world = psi1 + wrist."""
        data.ctrl[self.wrist_actuator] = angle_rad

    def limit_switches(self, data: mujoco.MjData) -> np.ndarray:
        """Switches 1-4 (bool): theta1 >= trip1, theta2 <= trip2, z >= trip3, z <= trip4."""
        q = data.qpos[self.switch_qpos_adr]
        return self.switch_sense * (q - self.switch_trip) >= 0
