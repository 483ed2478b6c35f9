"""The plugs of a 128-cell tray as physics, for any scene that carries the plug-in claws
(the standalone bench `transplanter.scene.plug_bench`, the delta's job): the cells (tapered
collision walls), the plugs (free bodies: an outer frustum of substrate and an inner pin
socket, the only geom the claws meet), their leaves, and the per-step laws of the substrate
(`transplanter.scene.plug_substrate`) that a job applies round `mj_step`:

- `PlugPhysics.before_step`: the cell's adhesion on a plug rising over its own cell;
- `PlugPhysics.after_step`: while the plug is carried, the pins' net load on it (the vector
  sum of the claws' contact forces on its socket, the downward part left out), its running
  peak cutting the plug's mass (`Substrate.lost_fraction`), and the shear of the substrate
  round the pins when it exceeds `Substrate.pin_capacity_n` (the socket stops colliding: the
  plug falls);
- `LeafWatch.after_step`: a claw or the stripper pressing a leaf harder than the threshold
  tears it (it stops colliding) and is recorded by name.

Collision bits: tray and plugs' outer shapes 1, claws 4 (the sockets' conaffinity), leaves 8,
stripper 16 (the outer shapes' conaffinity). No weld and no equality: the claws hold a plug by
contact only (docs/plug_claws.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from transplanter.scene.effectors.plug_claws import (
    BIT_CANOPY,
    BIT_PIN,
    BIT_STRIPPER,
    CLAWS,
    STRIPPERS,
    PlugClawsConfig,
)
from transplanter.scene.plug_substrate import Substrate
from transplanter.scene.plug_tray import Seedling

__all__ = [
    "BIT_TRAY",
    "LeafDamage",
    "LeafWatch",
    "PlugPhysics",
    "add_cell",
    "add_leaves",
    "add_plug",
    "stripper_push",
]

BIT_TRAY = 1
TRAY_SOLREF = [0.004, 1.0]  # the tray's plastic: stiffer than MuJoCo's default contact


def _frustum_vertices(top: float, bottom: float, height: float) -> list[float]:
    out = []
    for z, side in ((0.0, top), (-height, bottom)):
        for sx in (-1, 1):
            for sy in (-1, 1):
                out += [sx * side / 2, sy * side / 2, z]
    return out


def add_cell(
    spec: mujoco.MjSpec, name: str, cx: float, cy: float, tray_top_m: float, sub: Substrate
) -> None:
    """A cell of the tray at (cx, cy) with its top at `tray_top_m` (world, m): four tapered
    walls (1 mm thick boxes on the cell's inner faces) and a floor, static collision geoms."""
    c = sub.cfg
    top, bottom, depth = c.top_mm * 1e-3, c.bottom_mm * 1e-3, c.depth_mm * 1e-3
    lean = math.atan2((top - bottom) / 2, depth)
    slant = math.hypot(depth, (top - bottom) / 2)
    t = 0.001
    mid = (top + bottom) / 4  # the inner face's distance from the centre at mid-depth
    off = mid + t * math.cos(lean)
    zc = tray_top_m - depth / 2 - t * math.sin(lean)
    world = spec.worldbody
    for k, (ax, sx) in enumerate((("x", 1), ("x", -1), ("y", 1), ("y", -1))):
        if ax == "x":
            pos = [cx + sx * off, cy, zc]
            quat = [math.cos(sx * lean / 2), 0, math.sin(sx * lean / 2), 0]
            size = [t, top / 2 + 2 * t, slant / 2]
        else:
            pos = [cx, cy + sx * off, zc]
            quat = [math.cos(-sx * lean / 2), math.sin(-sx * lean / 2), 0, 0]
            size = [top / 2 + 2 * t, t, slant / 2]
        world.add_geom(
            name=f"{name}_wall{k}",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=size,
            pos=pos,
            quat=quat,
            contype=BIT_TRAY,
            conaffinity=BIT_TRAY,
            friction=[c.wall_friction, 0.005, 0.0001],
            solref=TRAY_SOLREF,
            rgba=[0.8, 0.8, 0.78, 0.35],
        )
    world.add_geom(
        name=f"{name}_floor",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[bottom / 2 + t, bottom / 2 + t, t],
        pos=[cx, cy, tray_top_m - depth - t],
        contype=BIT_TRAY,
        conaffinity=BIT_TRAY,
        solref=TRAY_SOLREF,
        rgba=[0.8, 0.8, 0.78, 1.0],
    )


def add_plug(
    spec: mujoco.MjSpec,
    name: str,
    cx: float,
    cy: float,
    tray_top_m: float,
    sub: Substrate,
    claws: PlugClawsConfig,
    seedling: Seedling | None = None,
) -> None:
    """A free plug `name` seated in the cell at (cx, cy): its outer frustum
    (`<name>_substrate`), its pin socket (`<name>_socket`) and, with a seedling (mm, about the
    cell's centre), its leaves (`<name>_leaf_<k>`, `<name>_petiole_<k>`)."""
    c = sub.cfg
    clr = c.clearance_mm * 1e-3
    h = sub.height_m
    top, bottom = sub.plug_top_m - 2 * clr, c.bottom_mm * 1e-3 - 2 * clr
    spec.add_mesh(name=f"{name}_frustum", uservert=_frustum_vertices(top, bottom, h))
    body = spec.worldbody.add_body(
        name=name, pos=[cx, cy, tray_top_m - c.surface_below_top_mm * 1e-3]
    )
    body.add_freejoint(name=name)
    a1, a2 = top * top, bottom * bottom
    zc = h * (a1 + 2 * math.sqrt(a1 * a2) + 3 * a2) / (4 * (a1 + math.sqrt(a1 * a2) + a2))
    m, s = sub.mass_kg, (top + bottom) / 2
    body.mass = m
    body.ipos = [0, 0, -zc]
    body.inertia = [m * (s * s + h * h) / 12, m * (s * s + h * h) / 12, m * s * s / 6]
    body.explicitinertial = True
    body.add_geom(
        name=f"{name}_substrate",
        type=mujoco.mjtGeom.mjGEOM_MESH,
        meshname=f"{name}_frustum",
        contype=BIT_TRAY,
        conaffinity=BIT_TRAY | BIT_STRIPPER,
        friction=[c.wall_friction, 0.005, 0.0001],
        density=0,
        rgba=[0.36, 0.25, 0.16, 1.0],
    )
    # the pin socket: the core the pins press into at full stroke, overlapping each tip's
    # surface by the interference (the substrate the pin displaces sideways)
    core = (claws.tip_offset_mm - claws.claw_radius_mm + claws.pin_interference_mm) * 1e-3
    z_top = c.core_top_depth_mm * 1e-3
    body.add_geom(
        name=f"{name}_socket",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[core, core, (h - 0.001 - z_top) / 2],
        pos=[0, 0, -(z_top + h - 0.001) / 2],
        contype=0,
        conaffinity=BIT_PIN,
        condim=4,
        friction=[sub.pin_friction, 0.005, 0.0001],
        solref=[sub.contact_timeconst_s, 1.0],
        solimp=[0.9, 0.95, 0.002, 0.5, 2],
        solmix=1.0,
        density=0,
        group=3,
        rgba=[0.5, 0.35, 0.2, 0.3],
    )
    if seedling is None:
        return
    add_leaves(body, name, seedling, c.surface_below_top_mm * 1e-3)  # heights: above the top


def add_leaves(body: mujoco.MjsBody, name: str, seedling: Seedling, z0_m: float) -> None:
    """A seedling's leaves on `body` (its frame's origin under the stem, mm in the draw):
    each a petiole capsule and an ellipsoid blade at its height + `z0_m`, collision geoms of
    the canopy bit (they stop the claws and the stripper, which `LeafWatch` records), named
    `{name}_petiole_{k}` and `{name}_leaf_{k}`."""
    leaf = {"contype": BIT_CANOPY, "conaffinity": 0, "density": 0, "group": 1}
    green = [0.35, 0.6, 0.25, 1.0]
    sx, sy = seedling.stem
    for k, lf in enumerate(seedling.leaves):
        z = lf.height_mm * 1e-3 + z0_m
        body.add_geom(
            name=f"{name}_petiole_{k}",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[sx * 1e-3, sy * 1e-3, z, lf.base[0] * 1e-3, lf.base[1] * 1e-3, z],
            size=[lf.petiole_radius_mm * 1e-3, 0, 0],
            rgba=green,
            **leaf,
        )
        body.add_geom(
            name=f"{name}_leaf_{k}",
            type=mujoco.mjtGeom.mjGEOM_ELLIPSOID,
            size=[lf.radial_mm * 1e-3, lf.tangential_mm * 1e-3, 0.25e-3],
            pos=[lf.cx * 1e-3, lf.cy * 1e-3, z],
            quat=[math.cos(lf.angle_rad / 2), 0, 0, math.sin(lf.angle_rad / 2)],
            rgba=green,
            **leaf,
        )


def _world_force(model: mujoco.MjModel, data: mujoco.MjData, i: int, out: np.ndarray) -> np.ndarray:
    mujoco.mj_contactForce(model, data, i, out)
    return data.contact[i].frame.reshape(3, 3).T @ out[:3]


class PlugPhysics:
    """The substrate's laws on one plug of a running model (module docstring). Make it after
    `mj_forward` with the plug in its seat; call `before_step(data)` and
    `after_step(data, t, carried)` round every `mj_step`. `carried`: the job's phase in which
    the claws hold the plug (from the lift until they start to retract)."""

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, name: str, sub: Substrate
    ) -> None:
        self.model, self.sub, self.name = model, sub, name
        self.body = model.body(name).id
        self.socket = model.geom(f"{name}_socket").id
        self.pins = {model.geom(n).id for n in CLAWS}
        joint = model.joint(name).id
        self.qadr, self.vadr = model.jnt_qposadr[joint], model.jnt_dofadr[joint]
        self.seat = data.qpos[self.qadr : self.qadr + 3].copy()
        self.mass0 = float(model.body_mass[self.body])
        self.inertia0 = model.body_inertia[self.body].copy()
        self.capacity_n = sub.pin_capacity_n
        self.peak_load_n = 0.0
        self.dropped_at_s: float | None = None
        self._f = np.zeros(6)

    def pin_load(self, data: mujoco.MjData) -> float:
        """The load the pins carry (N): the sum of their contact forces on the socket, its
        downward part (the pins pressing the plug onto its seat) left out."""
        total = np.zeros(3)
        for i in range(data.ncon):
            con = data.contact[i]
            g1, g2 = int(con.geom1), int(con.geom2)
            if self.socket in (g1, g2) and ({g1, g2} & self.pins):
                f = _world_force(self.model, data, i, self._f)
                total += f if g2 == self.socket else -f
        return float(math.hypot(max(total[2], 0.0), total[0], total[1]))

    def before_step(self, data: mujoco.MjData) -> None:
        """The cell's adhesion: a downward force while the plug rises over its own cell
        (full from `adhesion_onset_speed_mm_s` up, a regularised one-way friction)."""
        xyz = data.qpos[self.qadr : self.qadr + 3]
        vz = float(data.qvel[self.vadr + 2])
        half = 0.5 * self.sub.cfg.top_mm * 1e-3
        over_seat = (
            abs(float(xyz[0] - self.seat[0])) < half and abs(float(xyz[1] - self.seat[1])) < half
        )
        force = 0.0
        if self.dropped_at_s is None and vz > 0.0 and over_seat:
            rise = max(float(xyz[2] - self.seat[2]), 0.0)
            onset = self.sub.cfg.adhesion_onset_speed_mm_s * 1e-3
            force = self.sub.cell_adhesion_n(rise) * min(vz / onset, 1.0)
        data.xfrc_applied[self.body, 2] = -force

    def after_step(self, data: mujoco.MjData, t: float, carried: bool) -> None:
        """While carried: the pins' load, the substrate it breaks away, the shear that drops
        the plug."""
        if not carried or self.dropped_at_s is not None:
            return
        load = self.pin_load(data)
        if load > self.capacity_n:
            self.dropped_at_s = t
            self.model.geom_conaffinity[self.socket] = 0  # the substrate round the pins sheared
        elif load > self.peak_load_n:
            self.peak_load_n = load
            scale = 1.0 - self.sub.lost_fraction(load)
            self._set_mass(self.mass0 * scale)
            self.model.body_inertia[self.body] = self.inertia0 * scale

    def _set_mass(self, mass: float) -> None:
        """The plug's mass, and the subtree masses of it and its ancestors: MuJoCo's
        centre-of-mass pass divides by `body_subtreemass`, which only compiling (or
        `mj_setConst`) computes. Left stale, the tree's centre of mass is off the body's, and
        a free plug tumbling after a drop spun up with no force on it until the state blew up
        (`implicitfast`, seed 8's tray: docs/delta.md)."""
        m = self.model
        change = mass - float(m.body_mass[self.body])
        m.body_mass[self.body] = mass
        b = self.body
        while True:
            m.body_subtreemass[b] += change
            if b == 0:
                break
            b = int(m.body_parentid[b])

    @property
    def mass_kg(self) -> float:
        return float(self.model.body_mass[self.body])

    def seated_in(self, data: mujoco.MjData, xy: tuple[float, float], tol_m: float) -> bool:
        """The plug stands in the cell centred at `xy` (world, m), at its seat's height."""
        x, y, z = (float(v) for v in data.qpos[self.qadr : self.qadr + 3])
        return math.hypot(x - xy[0], y - xy[1]) < tol_m and abs(z - float(self.seat[2])) < tol_m


@dataclass(frozen=True)
class LeafDamage:
    """A leaf torn: its geom, the geom that pressed it, the force and when."""

    leaf: str
    by: str
    force_n: float
    time_s: float


class LeafWatch:
    """Leaf strikes on the plugs whose names start with one of `plugs`: a contact of a claw or
    the stripper with a leaf or petiole geom whose normal force exceeds `threshold_n` tears it
    (it stops colliding) and is recorded once."""

    def __init__(self, model: mujoco.MjModel, plugs: tuple[str, ...], threshold_n: float) -> None:
        self.model, self.threshold_n = model, threshold_n
        prefixes = tuple(f"{p}_{part}_" for p in plugs for part in ("leaf", "petiole"))
        self.leaves = {
            i for i in range(model.ngeom) if (model.geom(i).name or "").startswith(prefixes)
        }
        self.pressers = {model.geom(n).id for n in (*CLAWS, *STRIPPERS)}
        self.damage: list[LeafDamage] = []
        self._torn: set[int] = set()
        self._f = np.zeros(6)
        # per geom: a leaf / a presser (the step's contacts are screened with these at once)
        self._is_leaf = np.zeros(model.ngeom, dtype=bool)
        self._is_leaf[list(self.leaves)] = True
        self._is_presser = np.zeros(model.ngeom, dtype=bool)
        self._is_presser[list(self.pressers)] = True

    def after_step(self, data: mujoco.MjData, t: float) -> None:
        if data.ncon == 0:
            return
        g1s, g2s = data.contact.geom1, data.contact.geom2
        hits = (self._is_leaf[g1s] & self._is_presser[g2s]) | (
            self._is_leaf[g2s] & self._is_presser[g1s]
        )
        for i in np.flatnonzero(hits).tolist():
            g1, g2 = int(g1s[i]), int(g2s[i])
            leaf, by = (g1, g2) if self._is_leaf[g1] else (g2, g1)
            mujoco.mj_contactForce(self.model, data, i, self._f)
            force = float(self._f[0])
            if force > self.threshold_n and leaf not in self._torn:
                self._torn.add(leaf)
                name, presser = self.model.geom(leaf).name, self.model.geom(by).name
                self.damage.append(LeafDamage(name, presser, force, t))
                self.model.geom_contype[leaf] = 0  # torn: it no longer stops anything


def stripper_push(model: mujoco.MjModel, data: mujoco.MjData, plug: str) -> float:
    """Sum of the stripper's normal forces on a plug's outer shape (N)."""
    substrate = model.geom(f"{plug}_substrate").id
    strippers = {model.geom(n).id for n in STRIPPERS}
    f = np.zeros(6)
    total = 0.0
    for i in range(data.ncon):
        con = data.contact[i]
        pair = {int(con.geom1), int(con.geom2)}
        if substrate in pair and pair & strippers:
            mujoco.mj_contactForce(model, data, i, f)
            total += float(f[0])
    return total
