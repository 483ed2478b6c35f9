"""A standalone bench for the plug-in claws: tray cells with physical plugs, the claw unit on
a three-axis carrier that stands in for the robot, and one pick run through its cycle.

The scene (built by `build_bench`): the claws' model (models/effectors/plug_claws/) with slide
joints x, y, z added to its mount (the carrier: position servos with velocity feed-forward,
following the bench's motion profile), a floor, and blocks of cells, each with four tapered
walls and a floor (collision boxes), holding plugs: free bodies whose outer shape is a convex
frustum (the substrate, `transplanter.scene.plug_substrate`) and whose inner "pin socket" is a
box in the plug's core, the only geom the claws collide with.

How the plug is held (docs/plug_claws.md): the claws pass through the plug's outer shape (their
collision bits exclude it) and press into the socket's faces; MuJoCo's soft contact there
(friction and solref from the substrate's moisture and roots) stands for the substrate's grip
and the cylinder's squeeze. There is no weld or equality anywhere in the model. The cell's
adhesion is a downward force on the plug while it is still in its cell and rising
(`Substrate.cell_adhesion_n`). While the plug is carried, the net force of the pins on it is
measured from the contacts: its running peak sets the substrate lost (`Substrate.lost_fraction`,
the plug's mass and inertia are cut as it rises), and a net load above the pins' bearing
capacity shears the substrate round the pins: the socket stops colliding and the plug falls.

Leaves (from a drawn seedling of `transplanter.scene.plug_tray`, drawn as
`transplanter.scene.tray_camera` draws them) are geoms of the plug that only the claws and the
stripper meet; a contact force above `leaf_damage_force_n` tears the leaf (it stops colliding)
and records what touched it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import mujoco
import numpy as np

from transplanter.scene.effectors import plug_claws
from transplanter.scene.effectors.plug_claws import ClawCycle, PlugClawsConfig
from transplanter.scene.plug_substrate import PlugsConfig, Substrate
from transplanter.scene.plug_tray import CellTruth, Seedling, TrayGeometry

__all__ = [
    "BenchConfig",
    "BenchResult",
    "LeafDamage",
    "build_bench",
    "centred_seedling",
    "measure_hold",
    "model_xml",
    "run_pick",
]

TRAY_TOP_M = 0.05  # the bench's tray top above its floor
BIT_TRAY = 1
TRAY_SOLREF = [0.004, 1.0]  # the tray's plastic: stiffer than MuJoCo's default contact


def model_xml(models: str | Path | None = None) -> Path:
    """models/effectors/plug_claws/plug_claws.xml."""
    if models is None:
        from transplanter.scene.build import models_dir

        models = models_dir()
    return Path(models) / "effectors" / "plug_claws" / "plug_claws.xml"


@dataclass(frozen=True)
class BenchConfig:
    """One pick on the bench (file units in the names): the rotary setting, the lift (the
    paper's extraction acceleration), the lateral move to the target cell, the release."""

    rotary_deg: float = 0.0
    """The rotary cylinder's setting for this pick (0: claws enter along x, 90: along y)."""
    extraction_accel_m_s2: float = 10.0
    """Peak acceleration of the vertical lift out of the cell (cycloidal profile)."""
    lift_mm: float = 100.0
    """Height of the lift (the paper's Q0Q1)."""
    move_mm: float = 150.0
    """Lateral move from the source to the target cell."""
    move_accel_m_s2: float = 10.0
    """Peak acceleration of the lateral move and of the descent to the target."""
    approach_mm: float = 40.0
    """The claws come down onto the cell from this far above the working height."""
    approach_speed_mm_s: float = 200.0
    """Speed of the descent onto the source cell."""
    release_above_mm: float = 8.0
    """The plug's bottom hangs this far above its seat in the target cell when stripped."""
    timestep_ms: float = 1.0
    """Physics step."""
    settle_after_ms: float = 300.0
    """Time simulated after the release before the outcome is read."""


@dataclass(frozen=True)
class LeafDamage:
    """A leaf torn: its geom, the geom that pressed it, the force and when."""

    leaf: str
    by: str
    force_n: float
    time_s: float


@dataclass
class BenchResult:
    """The outcome of one pick. `held`: the pins' substrate did not shear while the plug was
    carried; `in_target`: the plug lies seated in the target cell; `retention`: the substrate
    delivered into the target cell over the plug's initial mass (the paper's substrate
    retention; 0 for a plug that did not arrive); `mass_g`: what is left on the plug."""

    held: bool
    dropped_at_s: float | None
    retention: float
    mass0_g: float
    mass_g: float
    peak_load_n: float
    pin_capacity_n: float
    final_xyz_mm: tuple[float, float, float]
    in_target: bool
    leaf_damage: list[LeafDamage] = field(default_factory=list)
    times_s: dict[str, float] = field(default_factory=dict)
    track_mm: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    """The plug's top centre (x, y, height above the tray's top) at each of `times_s`."""
    tip_depth_mm: float = 0.0
    """How deep the claws' tips stood below the plug's top when the lift began."""
    stripper_peak_n: float = 0.0
    """The largest push of the stripper on the plug while the claws retracted."""

    def as_dict(self) -> dict:
        return {
            "held": self.held,
            "dropped_at_s": self.dropped_at_s,
            "retention": round(self.retention, 6),
            "mass0_g": round(self.mass0_g, 4),
            "mass_g": round(self.mass_g, 4),
            "peak_load_n": round(self.peak_load_n, 5),
            "pin_capacity_n": round(self.pin_capacity_n, 5),
            "in_target": self.in_target,
            "leaf_damage": [d.__dict__ for d in self.leaf_damage],
            "tip_depth_mm": round(self.tip_depth_mm, 4),
            "stripper_peak_n": round(self.stripper_peak_n, 4),
        }


def _frustum_vertices(top: float, bottom: float, height: float) -> list[float]:
    out = []
    for z, side in ((0.0, top), (-height, bottom)):
        for sx in (-1, 1):
            for sy in (-1, 1):
                out += [sx * side / 2, sy * side / 2, z]
    return out


def _add_cell(spec: mujoco.MjSpec, name: str, cx: float, cy: float, sub: Substrate) -> None:
    """Four tapered walls (2 mm boxes on the cell's inner faces) and a floor."""
    c = sub.cfg
    top, bottom, depth = c.top_mm * 1e-3, c.bottom_mm * 1e-3, c.depth_mm * 1e-3
    lean = math.atan2((top - bottom) / 2, depth)
    slant = math.hypot(depth, (top - bottom) / 2)
    t = 0.001
    mid = (top + bottom) / 4  # the inner face's distance from the centre at mid-depth
    off = mid + t * math.cos(lean)
    zc = TRAY_TOP_M - depth / 2 - t * math.sin(lean)
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
        pos=[cx, cy, TRAY_TOP_M - depth - t],
        contype=BIT_TRAY,
        conaffinity=BIT_TRAY,
        solref=TRAY_SOLREF,
        rgba=[0.8, 0.8, 0.78, 1.0],
    )


def _add_plug(
    spec: mujoco.MjSpec,
    name: str,
    cx: float,
    cy: float,
    sub: Substrate,
    claws: PlugClawsConfig,
    seedling: Seedling | None,
) -> None:
    """A free plug seated in the cell at (cx, cy): outer frustum, pin socket, leaves."""
    c = sub.cfg
    clr = c.clearance_mm * 1e-3
    h = sub.height_m
    top, bottom = sub.plug_top_m - 2 * clr, c.bottom_mm * 1e-3 - 2 * clr
    spec.add_mesh(name=f"{name}_frustum", uservert=_frustum_vertices(top, bottom, h))
    body = spec.worldbody.add_body(
        name=name, pos=[cx, cy, TRAY_TOP_M - c.surface_below_top_mm * 1e-3]
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
        conaffinity=BIT_TRAY | plug_claws.BIT_STRIPPER,
        friction=[c.wall_friction, 0.005, 0.0001],
        density=0,
        rgba=[0.36, 0.25, 0.16, 1.0],
    )
    # the pin socket: the core the pins press into at full stroke, overlapping each tip's
    # surface by the interference (the substrate the pin displaces sideways)
    core = (claws.tip_offset_mm - claws.claw_radius_mm + claws.pin_interference_mm) * 1e-3
    z_top = claws.insertion_depth_mm * 1e-3 - 0.012
    body.add_geom(
        name=f"{name}_socket",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[core, core, (h - 0.001 - z_top) / 2],
        pos=[0, 0, -(z_top + h - 0.001) / 2],
        contype=0,
        conaffinity=plug_claws.BIT_PIN,
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
    leaf = {"contype": plug_claws.BIT_CANOPY, "conaffinity": 0, "density": 0, "group": 1}
    green = [0.35, 0.6, 0.25, 1.0]
    surface = c.surface_below_top_mm * 1e-3  # leaf heights are above the tray's top
    sx, sy = seedling.stem
    for k, lf in enumerate(seedling.leaves):
        z = lf.height_mm * 1e-3 + surface
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


def build_bench(
    plugs: PlugsConfig | None = None,
    claws: PlugClawsConfig | None = None,
    bench: BenchConfig | None = None,
    seedling: Seedling | None = None,
    models: str | Path | None = None,
) -> mujoco.MjSpec:
    """The bench's spec: a 2 x 2 block of source cells (the plug in the cell at the origin, a
    neighbour plug beside it) and a 2 x 2 block of target cells `move_mm` along +x, empty.
    `seedling` (tray frame, mm, about its cell's centre) gives the source plug its leaves."""
    plugs, claws, bench = plugs or PlugsConfig(), claws or PlugClawsConfig(), bench or BenchConfig()
    sub = Substrate(plugs)
    spec = mujoco.MjSpec.from_file(str(model_xml(models)))
    plug_claws.apply(spec, claws)
    plug_claws.add_canopy_contact(spec, claws)
    for key in list(spec.keys):
        spec.delete(key)
    spec.option.timestep = bench.timestep_ms * 1e-3
    mount = spec.body("claws_mount")
    mount.mass = 1.0  # the carrier (a robot's platform) with the mount
    mount.inertia = [2e-3, 2e-3, 3e-3]
    mount.pos = [0, 0, TRAY_TOP_M + claws.work_height_m() + bench.approach_mm * 1e-3]
    kp = 2e5
    for axis, vec in (("x", [1, 0, 0]), ("y", [0, 1, 0]), ("z", [0, 0, 1])):
        mount.add_joint(name=f"carrier_{axis}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=vec)
        spec.add_actuator(
            name=f"carrier_{axis}",
            target=f"carrier_{axis}",
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE,
            gainprm=[kp] + [0] * 9,
            biasprm=[0, -kp, 0] + [0] * 7,
        )
        kv = 2 * math.sqrt(kp * 1.4)
        spec.add_actuator(
            name=f"carrier_{axis}_v",
            target=f"carrier_{axis}",
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE,
            gainprm=[kv] + [0] * 9,
            biasprm=[0, 0, -kv] + [0] * 7,
        )
    mount.gravcomp = 1.0
    spec.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.5, 0.5, 0.01],
        contype=BIT_TRAY, conaffinity=BIT_TRAY, rgba=[0.3, 0.3, 0.32, 1],
    )  # fmt: skip
    spec.worldbody.add_light(pos=[0, 0, 1.0], dir=[0, 0, -1])
    pitch = 0.034
    for block, x0 in (("src", 0.0), ("dst", bench.move_mm * 1e-3)):
        for i in range(2):
            for j in range(2):
                _add_cell(spec, f"{block}{i}{j}", x0 + i * pitch, j * pitch, sub)
    _add_plug(spec, "plug", 0.0, 0.0, sub, claws, seedling)
    _add_plug(spec, "neighbour", pitch, 0.0, sub, claws, None)
    return spec


def _profile(d: float, a: float, t: float) -> tuple[float, float]:
    """Cycloidal move of length d whose acceleration peaks at a (a sine over the move: no
    jump in acceleration at either end): (position, velocity) at time t."""
    if d == 0.0:
        return 0.0, 0.0
    T = _move_time(d, a)
    u = min(max(t, 0.0), T) / T
    pos = d * (u - math.sin(2 * math.pi * u) / (2 * math.pi))
    vel = d / T * (1.0 - math.cos(2 * math.pi * u))
    return pos, vel


def _move_time(d: float, a: float) -> float:
    """Duration of a cycloidal move of length d with peak acceleration a: sqrt(2 pi d / a)."""
    return math.sqrt(2 * math.pi * abs(d) / a) if d else 0.0


class _Contacts:
    """Per-step contact reading: the pins' net force on the plug, leaf strikes."""

    def __init__(self, model: mujoco.MjModel, claws: PlugClawsConfig) -> None:
        self.m = model
        gid = lambda n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n)  # noqa: E731
        self.socket = gid("plug_socket")
        self.pins = {gid(n) for n in plug_claws.CLAWS}
        self.substrate = gid("plug_substrate")
        self.strippers = {gid(n) for n in plug_claws.STRIPPERS}
        self.pressers = {gid(n) for n in (*plug_claws.CLAWS, *plug_claws.STRIPPERS)}
        self.leaves = {
            i
            for i in range(model.ngeom)
            if (model.geom(i).name or "").startswith(("plug_leaf_", "plug_petiole_"))
        }
        self.threshold = claws.leaf_damage_force_n
        self._f = np.zeros(6)

    def _world_force(self, d: mujoco.MjData, i: int) -> np.ndarray:
        mujoco.mj_contactForce(self.m, d, i, self._f)
        frame = d.contact[i].frame.reshape(3, 3)
        return frame.T @ self._f[:3]

    def pin_load(self, d: mujoco.MjData) -> float:
        """The load the pins carry: the sum of their contact forces on the socket, its
        downward part (the pins pressing the plug onto its seat) left out (N)."""
        total = np.zeros(3)
        for i in range(d.ncon):
            con = d.contact[i]
            g1, g2 = int(con.geom1), int(con.geom2)
            if self.socket in (g1, g2) and ({g1, g2} & self.pins):
                f = self._world_force(d, i)
                total += f if g2 == self.socket else -f
        return float(math.hypot(max(total[2], 0.0), total[0], total[1]))

    def stripper_push(self, d: mujoco.MjData) -> float:
        """Sum of the stripper's normal forces on the plug (N)."""
        total = 0.0
        for i in range(d.ncon):
            con = d.contact[i]
            pair = {int(con.geom1), int(con.geom2)}
            if self.substrate in pair and pair & self.strippers:
                mujoco.mj_contactForce(self.m, d, i, self._f)
                total += float(self._f[0])
        return total

    def leaf_strikes(self, d: mujoco.MjData) -> list[tuple[int, int, float]]:
        out = []
        for i in range(d.ncon):
            con = d.contact[i]
            g1, g2 = int(con.geom1), int(con.geom2)
            if g1 in self.leaves and g2 in self.pressers:
                leaf, by = g1, g2
            elif g2 in self.leaves and g1 in self.pressers:
                leaf, by = g2, g1
            else:
                continue
            mujoco.mj_contactForce(self.m, d, i, self._f)
            out.append((leaf, by, float(self._f[0])))
        return out


def centred_seedling(cell: CellTruth, geometry: TrayGeometry) -> Seedling:
    """A drawn cell's seedling moved from the tray frame to its cell's centre (mm)."""
    cx, cy = geometry.centre(cell.row, cell.col)
    s = cell.seedling
    if s is None:
        raise ValueError(f"cell {cell.index} is empty")
    leaves = tuple(
        replace(lf, cx=lf.cx - cx, cy=lf.cy - cy, base=(lf.base[0] - cx, lf.base[1] - cy))
        for lf in s.leaves
    )
    return replace(s, stem=(s.stem[0] - cx, s.stem[1] - cy), leaves=leaves)


def run_pick(
    plugs: PlugsConfig | None = None,
    claws: PlugClawsConfig | None = None,
    bench: BenchConfig | None = None,
    seedling: Seedling | None = None,
    models: str | Path | None = None,
) -> BenchResult:
    """One pick: rotate, come down onto the source cell, extend, lift, move to the target
    cell, come down to the release height, retract (the stripper pushes the plug off), leave
    and settle. Deterministic: the same inputs give the same result bit for bit."""
    plugs, claws, bench = plugs or PlugsConfig(), claws or PlugClawsConfig(), bench or BenchConfig()
    sub = Substrate(plugs)
    spec = build_bench(plugs, claws, bench, seedling, models)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    dt = model.opt.timestep
    plug = model.body("plug").id
    mass0 = float(model.body_mass[plug])
    inertia0 = model.body_inertia[plug].copy()
    socket = model.geom("plug_socket").id
    contacts = _Contacts(model, claws)
    cycle = ClawCycle(claws)
    capacity = sub.pin_capacity_n
    qadr = model.jnt_qposadr[model.joint("plug").id]
    vadr = model.jnt_dofadr[model.joint("plug").id]
    seat_z = float(data.qpos[qadr + 2])
    carrier = [model.actuator(f"carrier_{a}").id for a in "xyz"]
    carrier_v = [model.actuator(f"carrier_{a}_v").id for a in "xyz"]
    effector = [model.actuator(n).id for n in plug_claws.ACTUATORS]

    # the schedule: (start time, axis, distance, peak acceleration) of each carrier move
    approach = bench.approach_mm * 1e-3
    lift = bench.lift_mm * 1e-3
    move = bench.move_mm * 1e-3
    release = bench.release_above_mm * 1e-3
    t = cycle.rotate(0.0, bench.rotary_deg) if bench.rotary_deg else 0.0
    times = {"rotated": t}
    v_app = bench.approach_speed_mm_s * 1e-3
    t_down = approach / v_app
    moves = [(t, 2, -approach, None, t_down)]
    t += t_down
    times["down"] = t
    t_ext = t + claws.settle_ms * 1e-3
    t_lift = cycle.extend(t_ext) + claws.settle_ms * 1e-3
    times["extended"] = t_lift
    T = _move_time(lift, bench.extraction_accel_m_s2)
    moves.append((t_lift, 2, lift, bench.extraction_accel_m_s2, T))
    t = t_lift + T
    times["lifted"] = t
    T = _move_time(move, bench.move_accel_m_s2)
    moves.append((t, 0, move, bench.move_accel_m_s2, T))
    t += T
    times["moved"] = t
    T = _move_time(lift - release, bench.move_accel_m_s2)
    moves.append((t, 2, -(lift - release), bench.move_accel_m_s2, T))
    t += T
    times["lowered"] = t
    t_ret = t + claws.settle_ms * 1e-3
    times["retract"] = t_ret
    t_off = cycle.retract(t_ret) + claws.settle_ms * 1e-3
    times["released"] = t_off
    T = _move_time(lift, bench.move_accel_m_s2)
    moves.append((t_off, 2, lift, bench.move_accel_m_s2, T))
    t_end = t_off + T + bench.settle_after_ms * 1e-3
    times["end"] = t_end
    home = np.array([0.0, 0.0, 0.0])

    def carrier_ref(tt: float) -> tuple[np.ndarray, np.ndarray]:
        pos, vel = home.copy(), np.zeros(3)
        for t0, ax, dist, acc, dur in moves:
            if tt <= t0:
                continue
            if acc is None:  # constant speed
                s = min(tt - t0, dur)
                pos[ax] += dist * s / dur
                vel[ax] += dist / dur if tt - t0 < dur else 0.0
            else:
                p, v = _profile(dist, acc, tt - t0)
                pos[ax] += p
                vel[ax] += v
        return pos, vel

    peak = 0.0
    dropped_at = None
    track: dict[str, tuple[float, float, float]] = {}
    pending = sorted(times.items(), key=lambda kv: kv[1])
    tip = model.body("claw_right").id
    tip_depth = 0.0
    stripper_peak = 0.0
    damaged: dict[int, LeafDamage] = {}
    n = int(round(t_end / dt))
    for k in range(n):
        tt = k * dt
        pos, vel = carrier_ref(tt)
        data.ctrl[carrier] = pos
        data.ctrl[carrier_v] = vel
        data.ctrl[effector] = cycle.ctrl(tt)
        # the cell's adhesion: a resistance while the plug rises out of its seat
        rise = float(data.qpos[qadr + 2]) - seat_z
        vz = float(data.qvel[vadr + 2])
        over_seat = abs(float(data.qpos[qadr])) < 0.5 * sub.cfg.top_mm * 1e-3
        if dropped_at is None and tt < t_ret and vz > 0.0 and over_seat:
            adhesion = sub.cell_adhesion_n(max(rise, 0.0)) * min(vz / 1e-3, 1.0)
            data.xfrc_applied[plug, 2] = -adhesion
        else:
            data.xfrc_applied[plug, 2] = 0.0
        mujoco.mj_step(model, data)
        # carried: from the lift until the claws start to retract
        if dropped_at is None and t_lift <= tt < t_ret:
            load = contacts.pin_load(data)
            if load > capacity:
                dropped_at = tt
                model.geom_conaffinity[socket] = 0  # the substrate round the pins sheared
            elif load > peak:
                peak = load
                scale = 1.0 - sub.lost_fraction(peak)
                model.body_mass[plug] = mass0 * scale
                model.body_inertia[plug] = inertia0 * scale
        if t_ret <= tt < t_off:
            stripper_peak = max(stripper_peak, contacts.stripper_push(data))
        if tt < t_lift:
            tip_depth = float(data.xpos[plug, 2] - data.xpos[tip, 2])
        while pending and pending[0][1] <= tt + dt / 2:
            name, _ = pending.pop(0)
            x, y, z = (float(v) for v in data.xpos[plug])
            track[name] = (x * 1e3, y * 1e3, (z - TRAY_TOP_M) * 1e3)
        for leaf, by, force in contacts.leaf_strikes(data):
            if force > contacts.threshold and leaf not in damaged:
                damaged[leaf] = LeafDamage(model.geom(leaf).name, model.geom(by).name, force, tt)
                model.geom_contype[leaf] = 0  # torn: it no longer stops anything
    xyz = data.qpos[qadr : qadr + 3]
    target = np.array([move, 0.0])
    in_target = bool(
        np.linalg.norm(xyz[:2] - target) < 0.004 and abs(float(xyz[2]) - seat_z) < 0.004
    )
    mass = float(model.body_mass[plug])
    delivered = mass / mass0 if (in_target and dropped_at is None) else 0.0
    return BenchResult(
        held=dropped_at is None,
        dropped_at_s=dropped_at,
        retention=delivered,
        mass0_g=mass0 * 1e3,
        mass_g=mass * 1e3,
        peak_load_n=peak,
        pin_capacity_n=capacity,
        final_xyz_mm=tuple(float(v) * 1e3 for v in (xyz[0], xyz[1], xyz[2] - TRAY_TOP_M)),
        in_target=in_target,
        leaf_damage=sorted(damaged.values(), key=lambda d: (d.time_s, d.leaf)),
        times_s=times,
        track_mm=track,
        tip_depth_mm=tip_depth * 1e3,
        stripper_peak_n=stripper_peak,
    )


def measure_hold(
    plugs: PlugsConfig | None = None,
    claws: PlugClawsConfig | None = None,
    timestep_ms: float = 1.0,
    ramp_n_s: float = 4.0,
    slip_mm: float = 5.0,
    models: str | Path | None = None,
) -> float:
    """The pins' friction hold (N), measured in the physics: the claws go into a plug, lift it
    20 mm clear of its cell, then a downward pull on the plug grows at `ramp_n_s` until the
    plug has slid `slip_mm` down the claws; the pull then (plus the plug's weight) is the
    hold. The substrate's shear (`Substrate.pin_capacity_n`) is not applied here: this is
    what the contact alone carries."""
    plugs, claws = plugs or PlugsConfig(), claws or PlugClawsConfig()
    bench = BenchConfig(timestep_ms=timestep_ms, approach_mm=0.0)
    spec = build_bench(plugs, claws, bench, None, models)
    model = spec.compile()
    data = mujoco.MjData(model)
    dt = model.opt.timestep
    plug = model.body("plug").id
    mount = model.body("claws_mount").id
    cycle = ClawCycle(claws)
    t_lift = cycle.extend(0.0) + claws.settle_ms * 1e-3
    lift, t_up = 0.02, 0.1
    z_ctrl = model.actuator("carrier_z").id
    effector = [model.actuator(n).id for n in plug_claws.ACTUATORS]
    weight = float(model.body_mass[plug]) * -float(model.opt.gravity[2])
    gap0 = None
    t_pull = t_lift + t_up + 0.1
    for k in range(int(round((t_pull + 20.0) / dt))):
        tt = k * dt
        s = min(max((tt - t_lift) / t_up, 0.0), 1.0)
        data.ctrl[z_ctrl] = lift * (3 * s * s - 2 * s**3)
        data.ctrl[effector] = cycle.ctrl(tt)
        pull = max(tt - t_pull, 0.0) * ramp_n_s
        data.xfrc_applied[plug, 2] = -pull
        mujoco.mj_step(model, data)
        gap = float(data.xpos[mount, 2] - data.xpos[plug, 2])
        if tt < t_pull:
            gap0 = gap
        elif gap - gap0 > slip_mm * 1e-3:
            return pull + weight
    return math.inf
