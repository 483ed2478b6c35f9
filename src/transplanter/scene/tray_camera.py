"""A drawn plug tray (`transplanter.scene.plug_tray`) in the plug_trays workcell's imaging
station, as MuJoCo sees it: the substrate in every cell, the seedlings' stems, petioles and
leaf blades (green visual geoms), moss specks and perlite grains, the tray tilted and shifted a
little as a real tray sits on its conveyor, and the lighting, leaf and substrate colours of the
draw; rendered offscreen from the camera `tray_camera` (mujoco.Renderer).

The picture is all the recognition pipeline (`transplanter.vision`) gets: nothing of the draw
is passed to it.
"""

from __future__ import annotations

import colorsys
import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from transplanter.scene import offscreen
from transplanter.scene.plug_tray import TrayDraw

CAMERA = "tray_camera"
MODEL = "plug_trays"


def model_dir(models: str | Path | None = None) -> Path:
    """The workcell's Menagerie folder (models/workcells/plug_trays/)."""
    if models is not None:
        return Path(models) / "workcells" / MODEL
    from transplanter.scene.build import models_dir

    return Path(models_dir()) / "workcells" / MODEL


@dataclass(frozen=True)
class ImagingDraw:
    """How the imaging station varies from tray to tray (uniform ranges; all estimates):
    the lights' brightness factor, the leaves' and the substrate's colour (HSV: hue in
    degrees, saturation and value 0-1), how far the tray sits turned (yaw), tipped (about x
    and y) and shifted from its nominal place. A range (a, a) fixes the value: `darker()` and
    `brighter()` are the fixed lightings of the robustness check."""

    light_scale: tuple[float, float] = (0.85, 1.15)
    leaf_hue_deg: tuple[float, float] = (80.0, 130.0)
    leaf_saturation: tuple[float, float] = (0.5, 0.8)
    leaf_value: tuple[float, float] = (0.45, 0.75)
    leaf_jitter: float = 0.06
    substrate_hue_deg: tuple[float, float] = (18.0, 34.0)
    substrate_saturation: tuple[float, float] = (0.4, 0.6)
    substrate_value: tuple[float, float] = (0.28, 0.45)
    yaw_deg: float = 2.0
    tip_deg: float = 0.5
    shift_mm: float = 8.0

    @staticmethod
    def darker() -> ImagingDraw:
        return ImagingDraw(light_scale=(0.55, 0.55))

    @staticmethod
    def brighter() -> ImagingDraw:
        return ImagingDraw(light_scale=(1.45, 1.45))


@dataclass(frozen=True)
class Appearance:
    """One draw of the imaging station: the values `ImagingDraw`'s ranges gave."""

    light_scale: float
    leaf_rgb: tuple[float, float, float]
    substrate_rgb: tuple[float, float, float]
    yaw_rad: float
    tip_rad: tuple[float, float]
    shift_mm: tuple[float, float]

    def as_dict(self) -> dict:
        return {
            "light_scale": round(self.light_scale, 4),
            "leaf_rgb": [round(v, 4) for v in self.leaf_rgb],
            "substrate_rgb": [round(v, 4) for v in self.substrate_rgb],
            "yaw_deg": round(math.degrees(self.yaw_rad), 4),
            "tip_deg": [round(math.degrees(v), 4) for v in self.tip_rad],
            "shift_mm": [round(v, 3) for v in self.shift_mm],
        }


def draw_appearance(seed: int, imaging: ImagingDraw | None = None) -> Appearance:
    """The imaging station's draw for a seed (a stream apart from the tray's cells)."""
    imaging = imaging or ImagingDraw()
    rng = np.random.default_rng([seed, 0xC0FFEE])

    def u(lo_hi: tuple[float, float]) -> float:
        return float(rng.uniform(*lo_hi))

    leaf = colorsys.hsv_to_rgb(
        u(imaging.leaf_hue_deg) / 360, u(imaging.leaf_saturation), u(imaging.leaf_value)
    )
    soil = colorsys.hsv_to_rgb(
        u(imaging.substrate_hue_deg) / 360,
        u(imaging.substrate_saturation),
        u(imaging.substrate_value),
    )
    return Appearance(
        light_scale=u(imaging.light_scale),
        leaf_rgb=tuple(float(v) for v in leaf),
        substrate_rgb=tuple(float(v) for v in soil),
        yaw_rad=math.radians(float(rng.uniform(-1, 1)) * imaging.yaw_deg),
        tip_rad=tuple(math.radians(float(v) * imaging.tip_deg) for v in rng.uniform(-1, 1, 2)),
        shift_mm=tuple(float(v) * imaging.shift_mm for v in rng.uniform(-1, 1, 2)),
    )


def _quat_zyx(yaw: float, pitch: float = 0.0, roll: float = 0.0) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_euler2Quat(q, np.array([roll, pitch, yaw]), "xyz")
    return q


def _yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def build_spec(
    tray: TrayDraw,
    appearance: Appearance,
    models: str | Path | None = None,
    leaf_jitter: float = ImagingDraw.leaf_jitter,
) -> mujoco.MjSpec:
    """The imaging station's scene.xml with the drawn tray's contents added (not compiled)."""
    spec = mujoco.MjSpec.from_file(str(model_dir(models) / "scene.xml"))
    g = tray.geometry
    m = 1e-3
    body = spec.body("tray")
    tx, ty = appearance.tip_rad
    body.quat = _quat_zyx(appearance.yaw_rad, ty, tx)
    body.pos = [appearance.shift_mm[0] * m, appearance.shift_mm[1] * m, g.depth_mm * m]
    for light in spec.lights:
        light.diffuse = np.asarray(light.diffuse) * appearance.light_scale
    spec.material("substrate").rgba = [*appearance.substrate_rgb, 1.0]
    rng = np.random.default_rng([tray.seed, 0x1EAF])
    z_soil = -g.substrate_below_top_mm
    half = g.opening_mm / 2 - 0.2
    for cell in tray.cells:
        cx, cy = g.centre(cell.row, cell.col)
        body.add_geom(
            name=f"substrate_{cell.index}",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[half * m, half * m, 2.0 * m],
            pos=[cx * m, cy * m, (z_soil - 2.0) * m],
            material="substrate",
            contype=0,
            conaffinity=0,
        )
        s = cell.seedling
        if s is None:
            continue
        hsv = colorsys.rgb_to_hsv(*appearance.leaf_rgb)
        value = float(np.clip(hsv[2] * (1 + rng.normal(0, leaf_jitter)), 0.05, 1.0))
        hue = (hsv[0] + rng.normal(0, leaf_jitter / 10)) % 1.0
        rgba = [*colorsys.hsv_to_rgb(hue, hsv[1], value), 1.0]
        stem_rgba = [*colorsys.hsv_to_rgb(hue, hsv[1] * 0.7, min(value * 1.15, 1.0)), 1.0]
        top = max(leaf.height_mm for leaf in s.leaves)
        sx, sy = s.stem
        plant = {"contype": 0, "conaffinity": 0, "group": 1}
        body.add_geom(
            name=f"stem_{cell.index}",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[sx * m, sy * m, z_soil * m, sx * m, sy * m, top * m],
            size=[s.stem_radius_mm * m, 0, 0],
            rgba=stem_rgba,
            **plant,
        )
        body.add_geom(
            name=f"hub_{cell.index}",
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[s.hub_radius_mm * m, 0, 0],
            pos=[sx * m, sy * m, top * m],
            rgba=stem_rgba,
            **plant,
        )
        for k, leaf in enumerate(s.leaves):
            z = leaf.height_mm * m
            body.add_geom(
                name=f"petiole_{cell.index}_{k}",
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[sx * m, sy * m, z, leaf.base[0] * m, leaf.base[1] * m, z],
                size=[leaf.petiole_radius_mm * m, 0, 0],
                rgba=stem_rgba,
                **plant,
            )
            body.add_geom(
                name=f"leaf_{cell.index}_{k}",
                type=mujoco.mjtGeom.mjGEOM_ELLIPSOID,
                size=[leaf.radial_mm * m, leaf.tangential_mm * m, 0.25 * m],
                pos=[leaf.cx * m, leaf.cy * m, z],
                quat=_yaw_quat(leaf.angle_rad),
                rgba=rgba,
                **plant,
            )
    moss = [*colorsys.hsv_to_rgb(0.25, 0.6, 0.45), 1.0]
    for k, speck in enumerate(tray.specks):
        body.add_geom(
            name=f"{speck.kind}_{k}",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[speck.radius_mm * m, 0.3 * m, 0],
            pos=[speck.x * m, speck.y * m, (z_soil + 0.3) * m],
            rgba=moss if speck.kind == "moss" else [0.93, 0.93, 0.9, 1.0],
            contype=0,
            conaffinity=0,
            group=1,
        )
    return spec


class RenderFailed(RuntimeError):
    """No OpenGL context could be made to render the tray camera."""


def render_tray(
    tray: TrayDraw,
    appearance: Appearance,
    width: int = 1600,
    height: int = 900,
    models: str | Path | None = None,
    leaf_jitter: float = ImagingDraw.leaf_jitter,
) -> np.ndarray:
    """The camera's picture of the drawn tray: (height, width, 3) uint8 RGB. Headless, set
    MUJOCO_GL=egl (or osmesa) before MuJoCo is first imported."""
    spec = build_spec(tray, appearance, models, leaf_jitter)
    vis = spec.visual.global_
    vis.offwidth, vis.offheight = max(vis.offwidth, width), max(vis.offheight, height)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    try:
        renderer = offscreen.renderer(model, height, width)
    except offscreen.NoOffscreenGL as exc:
        raise RenderFailed(f"{exc}; headless, use MUJOCO_GL=egl or MUJOCO_GL=osmesa") from None
    try:
        flags = renderer.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        renderer.update_scene(data, camera=CAMERA)
        return renderer.render().copy()
    finally:
        renderer.close()
