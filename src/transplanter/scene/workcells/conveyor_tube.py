"""The conveyor_tube workcell's part of the scene (models/workcells/conveyor_tube/): the belt
table and the conveyor carriage sized for rows x cols, the drop tube, the ribs of every row and
the paper pots with their seedlings (a PotBatch drawn from the seed), each a free body.
"""

from __future__ import annotations

import mujoco
import numpy as np

from transplanter.scene.config import (
    BIT_CANOPY,
    BIT_FOOT,
    BIT_GRIPPER,
    BIT_POT,
    BIT_WORLD,
    CROOKED_FOOT_HEIGHT,
    LEAF_BASE_LOW,
    LEAF_BASE_STEP,
    LEAF_PITCH_RAD,
    LEAF_PROXY_CENTRE,
    LEAF_PROXY_RGBA,
    POT_COLLISION_RGBA,
    POT_FOOT_RADIUS,
    RIB_RGBA,
    ROLLING_FRICTION,
    SOFT_WALL_IMPEDANCE,
    STATIC_COLLISION_RGBA,
    TORSIONAL_FRICTION,
    SceneConfig,
    row_bit,
)
from transplanter.scene.geometry import (
    belt_table,
    cell_columns_x,
    drop_tube_boxes,
    pot_inertia,
    rib_boxes,
    row_y,
)
from transplanter.scene.handles import LeafProxies
from transplanter.scene.pots import PotBatch

MODEL = "conveyor_tube"
"""The workcell's folder: models/workcells/conveyor_tube/conveyor_tube.xml."""
JUDGE = "transplanter.twin.judge:Judge"
"""The judge of this job ("module:Class"): it follows the trial and names every seedling's
outcome."""

BOND_PAD_HALF_THICKNESS = 0.0005  # m: the bonding pad at a bonded pot's base
BOND_PAD_RADIUS_SHARE = 0.7  # of the pot's radius: the pad stays inside the pot's footprint
BOND_REACH = 0.001  # m: how far a bond stretches before it tears (estimate: paper fibres, roots)
# Quaternion turning a capsule's axis (local z) onto local x.
_CAPSULE_Z_TO_X = np.array([np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0])


def apply(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """The drop tube and the conveyor layout from the config, and the line's sleep (resting
    pots and the idle carriage sleep with `cfg.sleep`), whatever robot works the line."""
    from transplanter.scene.build import apply_sleep

    apply_drop_tube(spec, cfg)
    apply_conveyor_layout(spec, cfg)
    apply_sleep(spec, cfg)


def populate(spec: mujoco.MjSpec, cfg: SceneConfig, seed: int, decor: bool) -> PotBatch:
    """The ribs and the pots of a seed (without `decor`, only the pots' collision geoms)."""
    pots = PotBatch.draw(cfg, seed)
    if cfg.windowed:  # scene.live_rows: the bodies of the first live_rows rows, reused
        add_rib_slots(spec, cfg)
        add_pots(spec, cfg, pots, decor, count=cfg.body_rows * cfg.cols)
    else:
        add_ribs(spec, cfg)
        add_pots(spec, cfg, pots, decor)
    return pots


def home_joints(cfg: SceneConfig) -> dict[str, float]:
    """The conveyor at 0 (the pots' free joints start where they are built)."""
    return {"conveyor": 0.0}


def apply_drop_tube(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """Funnel position, its tube walls (regenerated: drop_tube_boxes) and the plate."""
    body = spec.body("drop_tube")
    x, y = cfg.drop_tube_xy_m
    body.pos = [x, y, cfg.funnel_top_z_m]
    for geom in list(body.geoms):
        if geom.name.startswith("tube_wall_"):
            spec.delete(geom)
    for k, (half, pos, quat) in enumerate(drop_tube_boxes(cfg)):
        _add_static_box(body, f"tube_wall_{k}", half, pos, quat)
    bottom_z = -cfg.funnel_height_m - cfg.tube_length_m
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
    geom.rgba = list(STATIC_COLLISION_RGBA)


def apply_conveyor_layout(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """Carriage mass, slide friction and drive hold, and the belt table sized for rows x cols."""
    joint = spec.joint("conveyor")
    joint.frictionloss = cfg.conveyor_frictionloss_n
    joint.stiffness = [
        cfg.conveyor_hold_stiffness_n_m,
        0.0,
        0.0,
    ]  # held by its drive at springref 0
    joint.damping = [cfg.conveyor_hold_damping_n_s_m, 0.0, 0.0]
    spec.body("conveyor").mass = cfg.conveyor_mass_kg
    table = spec.geom("belt_table")
    table.size, table.pos = belt_table(cfg, table.size[2])
    if cfg.pot_feet:  # the table meets the pots' feet, not their cylinders (config.BIT_FOOT)
        table.conaffinity = (table.conaffinity & ~BIT_POT) | BIT_FOOT


def add_ribs(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """The ribs of every row on the conveyor carriage (they push only their row's pots)."""
    conveyor = spec.body("conveyor")
    for r in range(cfg.rows):
        bit = row_bit(r)
        for k, (size, pos) in enumerate(rib_boxes(cfg, r)):
            g = conveyor.add_geom()
            g.name = f"rib_{r}_{k}"
            g.type = mujoco.mjtGeom.mjGEOM_BOX
            g.size = size
            g.pos = pos
            g.contype = 0
            g.conaffinity = bit
            g.priority = 2
            g.friction = [cfg.rib_friction, TORSIONAL_FRICTION, ROLLING_FRICTION]
            g.mass = 0
            g.rgba = list(RIB_RGBA)


def add_rib_slots(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    """A windowed scene's ribs (scene.live_rows): cfg.rib_slot_rows rows of ribs, each row a
    massless body on the carriage (`ribs_{k}`, its geoms `rib_{k}_{j}` in the row's frame)
    that the conveyor's drive moves to the row it serves (ConveyorDrive); built on rows
    0..cfg.rib_slot_rows - 1, as add_ribs places them."""
    conveyor = spec.body("conveyor")
    ys = row_y(cfg)
    for r in range(cfg.rib_slot_rows):  # rib_slot_rows <= rows in a windowed scene
        body = conveyor.add_body()
        body.name = f"ribs_{r}"
        body.pos = [0.0, ys[r], 0.0]
        for k, (size, pos) in enumerate(rib_boxes(cfg, r)):
            g = body.add_geom()
            g.name = f"rib_{r}_{k}"
            g.type = mujoco.mjtGeom.mjGEOM_BOX
            g.size = size
            g.pos = [pos[0], pos[1] - ys[r], pos[2]]
            g.contype = 0
            g.conaffinity = row_bit(r)
            g.priority = 2
            g.friction = [cfg.rib_friction, TORSIONAL_FRICTION, ROLLING_FRICTION]
            g.mass = 0
            g.rgba = list(RIB_RGBA)


def add_pots(
    spec: mujoco.MjSpec,
    cfg: SceneConfig,
    pots: PotBatch,
    decor: bool = True,
    count: int | None = None,
    first: int = 0,
) -> None:
    """A free body per pot (pots first .. first + count - 1; default all): collision
    cylinder and (decor) visual mesh, stem, leaves and leaf proxies."""
    xs, ys = cell_columns_x(cfg), row_y(cfg)
    for i in range(first, first + (len(pots) - first if count is None else count)):
        r, c = divmod(i, cfg.cols)
        radius, h = pots.diameter[i] / 2, pots.height[i]
        body = spec.worldbody.add_body()
        body.name = f"pot_{r}_{c}"
        body.pos = [xs[c] + pots.offset[i, 0], ys[r] + pots.offset[i, 1], h / 2]
        body.add_freejoint()
        total_mass = pots.mass[i] + cfg.shoot_mass_kg
        body.mass = total_mass
        body.ipos = [0, 0, 0.0 - pots.fill_gap[i] / 2]  # the soil sits below the gap
        body.inertia = pot_inertia(total_mass, radius, h)
        body.explicitinertial = True
        crook = pots.wall_frame(i)
        soil = pots.soil_z(i)  # the seedling stands on the soil (pot frame)
        if crook is None:
            _add_pot_geom(body, cfg, pots, i, f"pot_{r}_{c}", [0, 0, 0], h / 2)
            _add_feet(body, cfg, pots, i, f"foot_{r}_{c}", [0, 0, -h / 2])
        else:  # a flat foot, the wall leaning over it; the wall's mass leans with it
            pivot, rot, quat = crook
            foot = CROOKED_FOOT_HEIGHT
            _add_pot_geom(body, cfg, pots, i, f"pot_foot_{r}_{c}", pivot - [0, 0, foot / 2],
                          foot / 2)  # fmt: skip
            _add_feet(body, cfg, pots, i, f"foot_{r}_{c}", pivot - [0, 0, foot])
            wall_half = (h - foot) / 2
            centre = pivot + rot @ [0, 0, wall_half]
            wall = _add_pot_geom(body, cfg, pots, i, f"pot_{r}_{c}", centre, wall_half)
            wall.quat = quat
            body.ipos += (h - foot) / h * (centre - (pivot + [0, 0, wall_half]))
        if decor:
            vis = body.add_geom()
            vis.type = mujoco.mjtGeom.mjGEOM_MESH
            vis.meshname = "paper_pot"
            vis.pos, vis.quat = _crooked([0, 0, -h / 2], [1, 0, 0, 0], crook)
            vis.contype = vis.conaffinity = 0
            vis.group = 2
            vis.mass = 0
            vis.material = "paper"
            _add_seedling(body, cfg, r, c, soil, pots.stem_length[i], pots.n_leaves[i],
                          pots.leaf_yaw0[i], crook)  # fmt: skip
        elif cfg.canopy_contact:  # the physics keeps the proxies that touch the jaws
            frames = _leaf_frames(
                soil, pots.stem_length[i], pots.n_leaves[i], pots.leaf_yaw0[i], crook
            )
            for k, (_, _, centre, along_x) in enumerate(frames):
                _add_leaf_proxy(body, cfg, f"leaf_{r}_{c}_{k}", centre, along_x)
        if pots.bond_force[i] > 0:
            _add_bond(spec, cfg, body, r, c, radius, h, pots.bond_force[i])


def _add_pot_geom(body, cfg: SceneConfig, pots: PotBatch, i: int, name, pos, half_height):
    """A collision cylinder of pot i (its radius, friction and wall softness)."""
    r = i // cfg.cols
    g = body.add_geom()
    g.name = name
    g.type = mujoco.mjtGeom.mjGEOM_CYLINDER
    g.size = [pots.diameter[i] / 2, half_height, 0]
    g.pos = list(pos)
    if cfg.pot_feet:  # everything it met before but the table (config.BIT_FOOT)
        g.contype = BIT_WORLD | BIT_POT | row_bit(r)
        g.conaffinity = BIT_POT | BIT_GRIPPER
    else:
        g.contype = BIT_POT | row_bit(r)
        g.conaffinity = BIT_WORLD | BIT_POT | BIT_GRIPPER
    g.condim = 4
    g.priority = 1
    g.friction = [pots.friction[i], TORSIONAL_FRICTION, ROLLING_FRICTION]
    g.solref = list(cfg.contact_solref)
    g.solimp = list(cfg.contact_solimp)
    if pots.soft[i]:  # soaked: the wall gives over pot_soft_wall_m before it resists
        g.solimp = [*SOFT_WALL_IMPEDANCE, cfg.pot_soft_wall_m, *cfg.contact_solimp[3:]]
    g.group = 3
    g.rgba = list(POT_COLLISION_RGBA)
    return g


def _add_feet(body, cfg: SceneConfig, pots: PotBatch, i: int, prefix: str, base) -> None:
    """Pot i's feet (cfg.pot_feet; none at 0): spheres of POT_FOOT_RADIUS on a ring inside
    the rim of its base (centre `base`, pot frame), their lowest points on the base's plane,
    flush with the base of the pot's cylinder. They touch the belt table only (BIT_FOOT,
    which the table's conaffinity then has in place of BIT_POT: the cylinder no longer meets
    it), with the pot's friction and contact softness; massless (the pot's inertia is
    explicit)."""
    ring = pots.diameter[i] / 2 - POT_FOOT_RADIUS
    for k in range(cfg.pot_feet):
        angle = 2 * np.pi * k / cfg.pot_feet
        g = body.add_geom()
        g.name = f"{prefix}_{k}"
        g.type = mujoco.mjtGeom.mjGEOM_SPHERE
        g.size = [POT_FOOT_RADIUS, 0, 0]
        g.pos = [base[0] + ring * np.cos(angle), base[1] + ring * np.sin(angle),
                 base[2] + POT_FOOT_RADIUS]  # fmt: skip
        g.contype = BIT_FOOT
        g.conaffinity = 0
        g.condim = 4
        g.priority = 1
        g.friction = [pots.friction[i], TORSIONAL_FRICTION, ROLLING_FRICTION]
        g.solref = list(cfg.contact_solref)
        g.solimp = list(cfg.contact_solimp)
        g.mass = 0
        g.group = 3
        g.rgba = list(POT_COLLISION_RGBA)


def _crooked(pos, quat, crook):
    """A frame (pos, quat) of the straight pot above its foot, on the crooked pot."""
    if crook is None:
        return np.asarray(pos, dtype=float), np.asarray(quat, dtype=float)
    pivot, rot, q = crook
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, q, np.asarray(quat, dtype=float))
    return pivot + rot @ (np.asarray(pos, dtype=float) - pivot), out


def _add_bond(spec: mujoco.MjSpec, cfg: SceneConfig, body, r, c, radius, h, force) -> None:
    """The pot's bond to the belt: MuJoCo adhesion on a thin pad flush with the pot's base
    (a child body without a joint: part of the pot) that touches only the belt, so the bond
    pulls the pot onto the belt, never onto the jaws, and acts only while the base touches
    it. A bond carries load only when something pulls the pot, and only the jaws do: the
    twin switches the adhesion on while the jaws touch the pot (`Scene.bond_actuators`;
    switched on at rest, MuJoCo's stiff adhesion against the soft contact keeps the pot
    rocking and awake). The pot's tree may sleep (an actuated tree never would by default)."""
    body.sleep = mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED
    base = body.add_body()
    base.name = f"pot_base_{r}_{c}"
    base.pos = [0, 0, -h / 2 + BOND_PAD_HALF_THICKNESS]
    pad = base.add_geom()
    pad.name = f"pot_base_{r}_{c}"
    pad.type = mujoco.mjtGeom.mjGEOM_CYLINDER
    pad.size = [BOND_PAD_RADIUS_SHARE * radius, BOND_PAD_HALF_THICKNESS, 0]
    pad.contype = BIT_FOOT if cfg.pot_feet else BIT_POT  # the table's bit for what it meets
    pad.conaffinity = 0
    pad.mass = 0
    pad.group = 3
    pad.rgba = list(POT_COLLISION_RGBA)
    pad.solref, pad.solimp = list(cfg.contact_solref), list(cfg.contact_solimp)  # as the pot's
    # contacts are kept (inactive) up to BOND_REACH above the belt, so the adhesion keeps
    # pulling while the bond stretches; beyond it the bond has torn
    pad.margin = pad.gap = BOND_REACH
    act = spec.add_actuator()
    act.name = f"bond_{r}_{c}"
    act.set_to_adhesion(gain=float(force))
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.ctrlrange = [0.0, 1.0]
    act.trntype = mujoco.mjtTrn.mjTRN_BODY
    act.target = base.name


def _add_seedling(body, cfg: SceneConfig, r, c, top, stem, n_leaves, leaf_yaw0, crook) -> None:
    """Stem and leaves (visual) and a capsule proxy per leaf (leaf_hit_pots) on a pot."""
    stem_geom = body.add_geom()
    stem_geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE
    base, _ = _crooked([0, 0, top], [1, 0, 0, 0], crook)
    tip, _ = _crooked([0, 0, top + stem], [1, 0, 0, 0], crook)
    stem_geom.fromto = [*base, *tip]
    stem_geom.size = [cfg.stem_radius_m, 0, 0]
    stem_geom.contype = stem_geom.conaffinity = 0
    stem_geom.group = 2
    stem_geom.mass = 0
    stem_geom.material = "leaf"
    frames = _leaf_frames(top, stem, n_leaves, leaf_yaw0, crook)
    for k, (base, quat, centre, along_x) in enumerate(frames):
        leaf_vis = body.add_geom()
        leaf_vis.type = mujoco.mjtGeom.mjGEOM_MESH
        leaf_vis.meshname = "seedling_leaf"
        leaf_vis.pos = base
        leaf_vis.quat = quat
        leaf_vis.contype = leaf_vis.conaffinity = 0
        leaf_vis.group = 2
        leaf_vis.mass = 0
        leaf_vis.material = "leaf"
        _add_leaf_proxy(body, cfg, f"leaf_{r}_{c}_{k}", centre, along_x)


def _add_leaf_proxy(body, cfg: SceneConfig, name: str, centre, along_x) -> None:
    """A leaf's capsule proxy: tested geometrically (leaf_hit_pots) and, with
    cfg.canopy_contact, a soft contact with the jaws and nothing else."""
    proxy = body.add_geom()
    proxy.name = name
    # A capsule along the leaf's length: capsule-box contacts with the gripper are
    # analytic, ellipsoids would take the general convex solver (3x the narrowphase).
    proxy.type = mujoco.mjtGeom.mjGEOM_CAPSULE
    proxy.size = [cfg.leaf_radius_m, cfg.leaf_half_length_m, 0]
    proxy.pos = centre
    proxy.quat = along_x
    proxy.contype = proxy.conaffinity = 0
    if cfg.canopy_contact:  # touches the jaws (their conaffinity has the bit), nothing else
        proxy.contype = BIT_CANOPY
        proxy.condim = 3
        proxy.priority = 3  # the leaf's softness and friction decide the contact
        proxy.friction = [cfg.canopy_friction, TORSIONAL_FRICTION, ROLLING_FRICTION]
        proxy.solref = [cfg.canopy_timeconst_s, 1.0]
    proxy.group = 4
    proxy.mass = 0
    proxy.rgba = list(LEAF_PROXY_RGBA)


def _leaf_frames(top: float, stem: float, n_leaves: int, leaf_yaw0: float, crook=None):
    """Per leaf of a seedling, in its pot's frame: the leaf mesh's base and quaternion and
    its capsule proxy's centre and quaternion (capsule axis along the leaf); on a crooked
    pot (crook: its crook_frame) they lean with the wall."""
    for k in range(int(n_leaves)):
        yaw = leaf_yaw0 + 2 * np.pi * k / n_leaves
        base = np.array([0, 0, top + stem * (LEAF_BASE_LOW + LEAF_BASE_STEP * (k % 2))])
        quat = np.zeros(4)
        mujoco.mju_euler2Quat(quat, np.array([0.0, LEAF_PITCH_RAD, yaw]), "xyz")
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, quat)
        centre = base + rot.reshape(3, 3) @ np.array(LEAF_PROXY_CENTRE)
        along_x = np.zeros(4)
        mujoco.mju_mulQuat(along_x, quat, _CAPSULE_Z_TO_X)
        base, quat = _crooked(base, quat, crook)
        centre, along_x = _crooked(centre, along_x, crook)
        yield base, quat, centre, along_x


def leaf_proxies(cfg: SceneConfig, pots: PotBatch) -> LeafProxies:
    """Every leaf's capsule proxy in its pot's frame, as the decorated model places it."""
    pot, centre, axis = [], [], []
    for i in range(len(pots)):
        frames = _leaf_frames(
            pots.soil_z(i), pots.stem_length[i], pots.n_leaves[i], pots.leaf_yaw0[i],
            pots.wall_frame(i),
        )  # fmt: skip
        for _, _, c, along_x in frames:
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, along_x)
            pot.append(i)
            centre.append(c)
            axis.append(rot.reshape(3, 3)[:, 2])
    return LeafProxies(
        pot=np.array(pot, dtype=int),
        centre=np.array(centre, dtype=float).reshape(-1, 3),
        axis=np.array(axis, dtype=float).reshape(-1, 3),
        radius=cfg.leaf_radius_m,
        half_length=cfg.leaf_half_length_m,
    )
