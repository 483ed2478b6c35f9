"""The delta's cull-and-refill scene (seed 002: Zhao, Cheng, Dong, Ma, Xiong and Tong,
*Research on the End Effector and Optimal Motion Control Strategy for a Plug Seedling
Transplanting Parallel Robot*): the rotary delta (models/delta) with the plug-in claws
(models/effectors/plug_claws) attached under its platform by MjSpec attach, the planting tray
and the supply tray side by side under the base, and a bin for culled seedlings.

The trays' cells are drawn by `transplanter.scene.plug_tray.draw_tray` (planting tray: the
seed; supply tray: the seed's supply stream). What the job touches is physics
(`transplanter.scene.plug_physics`): the cells it empties or fills get their tapered walls
and floor, and the plugs it lifts are free bodies held by contact only. Every other plug is
a static body: its substrate's surface a box a dropped plug lands on, its leaves collision
geoms that the claws and the stripper can still strike (a neighbour's leaf crossing into the
cell being worked); the trays' plates stop what falls through a cell without a plug. So a
run's cost follows its job, not the tray's 256 plugs.

World frame: the delta's base frame (Z up, the platform below the base). Tray frame to world:
x along the trays' length (16 columns), y across (8 rows); planting tray at +y, supply tray
at -y.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco

from transplanter.scene import kinds
from transplanter.scene.effectors.plug_claws import PlugClawsConfig
from transplanter.scene.plug_physics import BIT_TRAY, add_cell, add_leaves, add_plug
from transplanter.scene.plug_substrate import PlugsConfig, Substrate
from transplanter.scene.plug_tray import Seedling, TrayDraw, TrayGeometry

__all__ = [
    "DeltaSceneConfig",
    "JobCells",
    "build_delta_spec",
    "compile_scene",
    "export_spec",
    "models_dir",
]

PLATFORM_HALF_THICKNESS_M = 0.01
"""The platform's collision disc is 20 mm thick: the claws' mount hangs under it."""
CAMERAS_M = {
    # name: (position, point looked at, vertical field of view deg), both relative to the
    # work zone's centre: x 0, y midway between the trays, z the platform's work height
    "overview": ((1.5, -1.2, 0.55), (0.05, 0.0, 0.25), 45.0),
    "trays": ((0.8, 0.0, 0.6), (0.0, 0.0, -0.04), 50.0),
}
"""The scene's named cameras (`transplanter render`): the whole machine, and both trays and
the bin from above the bin's side; `claws_closeup` rides on the platform (models/delta)."""


def models_dir() -> Path:
    import transplanter

    here = Path(transplanter.__file__).resolve()
    for parent in here.parents:
        if (parent / "models" / "delta" / "delta.xml").is_file():
            return parent / "models"
    import models  # the packaged models (wheel)

    return Path(models.__file__).resolve().parent


@dataclass(frozen=True)
class DeltaSceneConfig:
    """What the delta scene is built from (SI). The delta's numbers come from its
    kinematics' scenario section; the rest from `[delta_refill]` (docs/delta.md)."""

    gear_ratio: float = 25.0
    joint_torque_limit_nm: float = 12.0
    platform_mass_kg: float = 1.0
    home_q_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Arm angles at power-on (the platform's work pose over the trays' middle)."""
    work_z_m: float = -0.8
    """Platform centre's Z while the claws go into a cell."""
    planting_y_m: float = 0.16
    supply_y_m: float = -0.16
    bin_xy_m: tuple[float, float] = (0.36, 0.0)
    bin_size_m: float = 0.16
    """The bin's inside width (a crate; estimate): a 3 x 3 grid of drop spots 45 mm apart."""
    bin_depth_m: float = 0.2
    """The bin's depth below the trays' top (estimate): three culled plugs a spot."""
    timestep_s: float = 0.001
    claws: PlugClawsConfig = field(default_factory=PlugClawsConfig)
    plugs: PlugsConfig = field(default_factory=PlugsConfig)
    geometry: TrayGeometry = field(default_factory=TrayGeometry)

    @property
    def tray_top_m(self) -> float:
        """Z of the trays' top: the platform at work_z puts the claws' mount at the claws'
        work height above it."""
        return self.work_z_m - PLATFORM_HALF_THICKNESS_M - self.claws.work_height_m()

    def bin_spot(self, k: int) -> tuple[float, float]:
        """The k-th drop spot over the bin (the host cycles through a 3 x 3 grid)."""
        i, j = divmod(k % 9, 3)
        return self.bin_xy_m[0] + (i - 1) * 0.045, self.bin_xy_m[1] + (j - 1) * 0.045

    def cell_xy(self, tray: str, index: int) -> tuple[float, float]:
        """World (x, y) of a cell's centre (m); tray 'planting' or 'supply'."""
        g = self.geometry
        x, y = g.centre(*divmod(index, g.cols))
        y0 = self.planting_y_m if tray == "planting" else self.supply_y_m
        return x * 1e-3, y0 + y * 1e-3


@dataclass(frozen=True)
class JobCells:
    """Which cells the job touches: planting cells it culls (their plugs free bodies),
    planting cells it fills (their walls built), supply cells it picks from."""

    culled: tuple[int, ...] = ()
    filled: tuple[int, ...] = ()
    supply: tuple[int, ...] = ()


def plug_name(tray: str, index: int) -> str:
    return f"{tray[0]}{index:03d}"


def centred(seedling: Seedling, centre_mm: tuple[float, float]) -> Seedling:
    """A drawn seedling (tray frame, mm) about its cell's centre."""
    from dataclasses import replace

    cx, cy = centre_mm
    leaves = tuple(
        replace(lf, cx=lf.cx - cx, cy=lf.cy - cy, base=(lf.base[0] - cx, lf.base[1] - cy))
        for lf in seedling.leaves
    )
    return replace(seedling, stem=(seedling.stem[0] - cx, seedling.stem[1] - cy), leaves=leaves)


def _static_plug(
    spec: mujoco.MjSpec, name: str, x: float, y: float, top: float, sub: Substrate, s: Seedling
) -> None:
    """A plug the job does not lift: a static body, its substrate's surface a collision box
    that free plugs meet (a dropped plug lands on it, not through the tray), its leaves
    collision geoms (canopy bit) so that a strike on a neighbour is seen and named."""
    c = sub.cfg
    surface = top - c.surface_below_top_mm * 1e-3
    body = spec.worldbody.add_body(name=name, pos=[x, y, surface])
    side = sub.plug_top_m * 0.5
    body.add_geom(
        name=f"{name}_substrate",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[side, side, 0.002],
        pos=[0, 0, -0.002],
        contype=0,
        conaffinity=BIT_TRAY,
        rgba=[0.36, 0.25, 0.16, 1.0],
    )
    add_leaves(body, name, s, 0.0)


def add_trays(
    spec: mujoco.MjSpec,
    cfg: DeltaSceneConfig,
    planting: TrayDraw,
    supply: TrayDraw,
    job: JobCells,
) -> None:
    """Both trays (plates drawn, the job's cells built with plug_physics), their plugs (the
    job's free, the rest static) and the bin."""
    sub = Substrate(cfg.plugs)
    top = cfg.tray_top_m
    g = cfg.geometry
    for tray, y0 in (("planting", cfg.planting_y_m), ("supply", cfg.supply_y_m)):
        spec.worldbody.add_geom(
            name=f"{tray}_tray",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[g.length_mm * 5e-4, g.width_mm * 5e-4, 0.001],
            pos=[0.0, y0, top - g.depth_mm * 1e-3 - 0.003],
            contype=0,
            conaffinity=BIT_TRAY,  # under the cells: what falls through an empty one lands
            rgba=[0.8, 0.8, 0.78, 0.6],
        )
    free = {("planting", i) for i in job.culled} | {("supply", i) for i in job.supply}
    walls = free | {("planting", i) for i in job.filled}
    for tray, draw in (("planting", planting), ("supply", supply)):
        for cell in draw.cells:
            x, y = cfg.cell_xy(tray, cell.index)
            name = plug_name(tray, cell.index)
            if (tray, cell.index) in walls:
                add_cell(spec, f"{name}_cell", x, y, top, sub)
            if cell.seedling is None:
                continue
            s = centred(cell.seedling, g.centre(cell.row, cell.col))
            if (tray, cell.index) in free:
                add_plug(spec, name, x, y, top, sub, cfg.claws, s)
            else:
                _static_plug(spec, name, x, y, top, sub, s)
    _add_bin(spec, cfg)


def _look_at_quat(pos, target) -> list[float]:
    """The quaternion of a camera at `pos` looking at `target`, its x axis level."""
    import numpy as np

    forward = np.asarray(target, float) - np.asarray(pos, float)
    forward /= np.linalg.norm(forward)
    x = np.cross(forward, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(x, forward)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([x, y, -forward]).ravel())
    return quat.tolist()


def add_cameras(spec: mujoco.MjSpec, cfg: DeltaSceneConfig) -> None:
    """The named cameras of CAMERAS_M, placed about the trays where `cfg` puts them."""
    centre = (0.0, (cfg.planting_y_m + cfg.supply_y_m) / 2, cfg.work_z_m)
    for name, (pos, target, fovy) in CAMERAS_M.items():
        p = [c + d for c, d in zip(centre, pos, strict=True)]
        t = [c + d for c, d in zip(centre, target, strict=True)]
        spec.worldbody.add_camera(name=name, pos=p, quat=_look_at_quat(p, t), fovy=fovy)


def _add_bin(spec: mujoco.MjSpec, cfg: DeltaSceneConfig) -> None:
    bx, by = cfg.bin_xy_m
    half, depth, t = cfg.bin_size_m / 2, cfg.bin_depth_m, 0.002
    top = cfg.tray_top_m
    common = {"contype": BIT_TRAY, "conaffinity": BIT_TRAY, "rgba": [0.2, 0.3, 0.6, 0.5]}
    world = spec.worldbody
    world.add_geom(name="bin_floor", type=mujoco.mjtGeom.mjGEOM_BOX,
                   size=[half, half, t], pos=[bx, by, top - depth - t], **common)  # fmt: skip
    for k, (dx, dy, sx, sy) in enumerate(
        ((half, 0, t, half), (-half, 0, t, half), (0, half, half, t), (0, -half, half, t))
    ):
        world.add_geom(name=f"bin_wall{k}", type=mujoco.mjtGeom.mjGEOM_BOX,
                       size=[sx, sy, depth / 2], pos=[bx + dx, by + dy, top - depth / 2],
                       **common)  # fmt: skip


def build_delta_spec(
    cfg: DeltaSceneConfig,
    planting: TrayDraw,
    supply: TrayDraw,
    job: JobCells,
    models: str | Path | None = None,
) -> mujoco.MjSpec:
    """The scene's spec: the delta (robot kind 'delta'), the claws attached under its
    platform (effector kind 'plug_claws'), the trays and bin (workcell kind 'plug_trays').
    Keyframe 'home' holds the power-on pose."""
    root = Path(models) if models is not None else models_dir()
    robot = kinds.robot("delta")
    spec = mujoco.MjSpec.from_file(str(root / robot.MODEL / f"{robot.MODEL}.xml"))
    robot.attach_effector(spec, root)
    robot.apply(spec, cfg)
    effector = kinds.effector("plug_claws")
    effector.apply(spec, cfg.claws)
    effector.add_canopy_contact(spec, cfg.claws)
    robot.apply_inertials(spec, cfg)
    kinds.workcell("plug_trays").populate_job(spec, cfg, planting, supply, job)
    spec.option.timestep = cfg.timestep_s
    spec.worldbody.add_light(pos=[0, 0, 0.5], dir=[0, 0, -1])
    add_cameras(spec, cfg)
    # the background of `transplanter render` (as the models' scene.xml): drawn only
    spec.add_texture(
        name="skybox", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.3, 0.5, 0.7], rgb2=[0, 0, 0],
        width=512, height=3072,
    )  # fmt: skip
    return spec


def compile_scene(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """Compile the scene (MuJoCo's note on the claws attached without a name prefix
    silenced: `robots.delta.quiet_prefix_note`)."""
    with kinds.robot("delta").quiet_prefix_note():
        return spec.compile()


def export_spec(
    spec: mujoco.MjSpec,
    out: str | Path,
    models: str | Path | None = None,
    mount: str = "claws_mount",
) -> Path:
    """Write a delta scene's spec (`twin.delta_refill.job_spec`, `twin.delta_pots.scene_spec`)
    as one MJCF file with its meshes beside it (`scene.export.export_spec`), MuJoCo's note on
    the effector attached without a prefix silenced."""
    from transplanter.scene.export import export_spec as write

    with kinds.robot("delta").quiet_prefix_note():
        return write(spec, out, models if models is not None else models_dir(), mount)
