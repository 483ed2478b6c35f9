"""Seed 002's cull and refill: a 128-cell planting tray graded by vision, its inferior
seedlings pulled to a bin and every hole refilled from a supply tray."""

from __future__ import annotations

from dataclasses import dataclass

from transplanter.kinds.interfaces import ALL
from transplanter.kinds.sections import Section, key

NAME = "plug_trays"
SUMMARY = "cull inferior plug seedlings to a bin and refill from a supply tray (seed 002)"
WORKCELL = "transplanter.scene.workcells.plug_trays"
UNIT = "cells"
RUN = "transplanter.runs.plug_trays"
KEY_POINTS = "transplanter.runs.plug_trays:key_points"
"""Where its tool must go (`scenario.reach`: the robot reaches them from some placement)."""
UNITS_KEY = "delta_refill.max_cells"


def uses_robot() -> bool:
    return True


def refusal(robot: str, effector: str) -> str | None:
    """Which robot and effector the trays' host drives; whether a robot reaches the trays at
    all is computed from its kinematics (`scenario.reach`, KEY_POINTS), not listed here."""
    if robot != "delta":
        return (
            f"no host program drives the {robot} robot on the trays: their host "
            "(twin.delta_refill) drives the delta's own controller"
        )
    if effector != "plug_claws":
        return "the trays' plugs are pulled by the plug_claws effector only"
    return None


def reads(robot: str, effector: str) -> dict:
    return {
        "delta_refill": ALL,
        "plugs": ALL,
        "vision": ALL,
        "bus": ("baud_bps",),
        "physics": ("timestep_ms",),
    }


def runner(robot: str) -> str:
    return "transplanter.twin.delta_refill:run_delta_refill"


@dataclass(frozen=True)
class DeltaRefillSection:
    """[delta_refill]: the delta's cull-and-refill job (`[workcell] kind = "plug_trays"`;
    read only by transplanter.twin.delta_refill). Optional: the defaults are the paper's
    numbers where it gives them and estimates otherwise (docs/delta.md)."""

    image_delay_s: float = key("float", 0, 60000, doc="the PC's imaging and grading time")
    pose_judgement: bool = key("bool", doc="turn the claws by the cell's leaf layout")
    fixed_rotary_rad: float = key("float", 0, 90, doc="rotary setting without pose judgement")
    following_error_limit_rad: float = key("float", 0.001, 90, doc="drive alarm level")
    travel_speed_m_s: float = key("float", 1, 5000, doc="G1 speed of the travel moves")
    approach_speed_m_s: float = key("float", 1, 5000, doc="G1 speed onto a cell")
    path_accel_m_s2: float = key("float", 1, 1e6, doc="the controller's path acceleration")
    segment_m: float = key("float", 0.01, 10, doc="interpolation grid of the controller")
    point_time_s: float = key("float", 1, 1e5, doc="the controller's IK time per point")
    lift_m: float = key("float", 10, 300, doc="lift above the work height (the paper: 100)")
    arc_radius_m: float = key(
        "float", 1, 300, doc="arc at the top of a bspline5 transfer's lift (the paper: 50)"
    )
    exit_m: float = key(
        "float", 0, 299, doc="bspline5: key point straight above each end (0: the paper's 7)"
    )
    release_above_m: float = key("float", 0, 50, doc="platform above work height at release")
    bin_release_above_m: float = key("float", 0, 200, doc="platform above work over the bin")
    bin_x_m: float = key("float", -1000, 1000, doc="the bin's centre X")
    bin_y_m: float = key("float", -1000, 1000, doc="the bin's centre Y")
    tray_change_s: float = key("float", 0, 600000, doc="tray out and next tray in")
    settle_after_s: float = key("float", 0, 10000, doc="simulated after the last line")
    max_cells: int = key("int", lo=0, hi=128, doc="cells serviced per tray (0: all)")
    supply_seed_offset: int = key("int", lo=1, hi=10**9, doc="supply tray's seed - seed")
    vision: str = key(
        "str",
        choices=("pipeline", "truth"),
        doc="the grading map: the OpenCV pipeline on the camera's pictures (needs an "
        "offscreen GL context: MUJOCO_GL=egl or osmesa) or the drawn truth",
    )


_DELTA_REFILL_DEFAULTS = {
    "image_delay_ms": 2000.0,
    "pose_judgement": True,
    "fixed_rotary_deg": 0.0,
    "following_error_limit_deg": 2.0,
    "travel_speed_mm_s": 500.0,
    "approach_speed_mm_s": 200.0,
    "path_accel_mm_s2": 5000.0,
    "segment_mm": 0.5,
    "point_time_us": 100.0,
    "lift_mm": 100.0,
    "arc_radius_mm": 50.0,
    "exit_mm": 10.0,
    "release_above_mm": 8.0,
    "bin_release_above_mm": 20.0,
    "bin_x_mm": 360.0,
    "bin_y_mm": 0.0,
    "tray_change_ms": 3000.0,
    "settle_after_ms": 300.0,
    "max_cells": 0,
    "supply_seed_offset": 1000003,
    "vision": "pipeline",
}


@dataclass(frozen=True)
class VisionSection:
    """[vision]: the trays' seedlings, the imaging station's draw and the recognition
    pipeline's thresholds (seed 002's vision, docs/vision.md; read by `transplanter grade` and
    the delta's trial with `delta_refill.vision = "pipeline"`). Optional: the defaults are
    `SeedlingDraw`, `ImagingDraw`, `CameraMount` and `VisionThresholds` (estimates chosen on
    seeds 0-4; the paper gives none). Ranges are [low, high] pairs drawn uniformly."""

    seedling_draw: str = key(
        "str", choices=("default", "near_thresholds"), doc="SeedlingDraw() or its hard draw"
    )
    image_width_px: int = key("int", lo=64, hi=4096, doc="the camera's picture width")
    image_height_px: int = key("int", lo=64, hi=4096, doc="the camera's picture height")
    light_scale: tuple[float, float] = key("xy", 0.01, 10, doc="the lights' brightness factor")
    leaf_hue_rad: tuple[float, float] = key("xy", 0, 360, doc="leaves' hue range")
    leaf_saturation: tuple[float, float] = key("xy", 0, 1, doc="leaves' saturation range")
    leaf_value: tuple[float, float] = key("xy", 0, 1, doc="leaves' value range")
    leaf_jitter: float = key("float", 0, 1, doc="per-seedling spread of the leaves' colour")
    substrate_hue_rad: tuple[float, float] = key("xy", 0, 360, doc="substrate's hue range")
    substrate_saturation: tuple[float, float] = key("xy", 0, 1, doc="substrate saturation")
    substrate_value: tuple[float, float] = key("xy", 0, 1, doc="substrate's value range")
    tray_yaw_rad: float = key("float", 0, 45, doc="the tray turned up to +- this")
    tray_tip_rad: float = key("float", 0, 10, doc="the tray tipped up to +- this")
    tray_shift_m: float = key("float", 0, 100, doc="the tray shifted up to +- this")
    camera_height_m: float = key("float", 100, 100000, doc="camera above the tray (assumed)")
    leaf_height_m: float = key("float", 0, 100, doc="leaves above the tray (assumed)")
    white_percentile: float = key("float", 50, 100, doc="the grey picture's white point")
    min_white_level: float = key("float", 0, 255, doc="a darker white point: too dark")
    min_contrast: float = key("float", 0, 255, doc="a smaller grey std: blank picture")
    tray_band: tuple[float, float] = key("xy", 0, 2, doc="T1, T2 of the white point")
    close_fraction: float = key("float", 0, 0.5, doc="frame closing, of the long side")
    erode_m: float = key("float", 0, 20, doc="the walls' erosion (and dilation back)")
    open_m: float = key("float", 0, 20, doc="the walls' opening (perlite grains go)")
    tray_aspect_tolerance: float = key("float", 0, 1, doc="frame's aspect against the tray's")
    rectified_resolution_m: float = key("float", 0.05, 5, doc="rectified picture's pixel")
    profile_level: float = key("float", 0, 1, doc="a projection profile under it: an opening")
    leaf_hue_band_rad: tuple[float, float] = key("xy", 0, 360, doc="leaf pixels' hue")
    leaf_min_saturation: int = key("int", lo=0, hi=255, doc="leaf pixels' least saturation")
    leaf_min_value: int = key("int", lo=0, hi=255, doc="leaf pixels' least value")
    min_component_mm2: float = key("float", 0, 1000, doc="smaller leaf components removed")
    core_radius_m: float = key("float", 0, 17, doc="a cell's leaves touch this disc")
    min_leaf_area_mm2: float = key("float", 0, 1000, doc="paper: less is inferior")
    max_centroid_offset_m: float = key("float", 0, 17, doc="paper: further is inferior")
    min_secant_m: float = key("float", 0, 34, doc="paper: a longer secant crosses")
    empty_area_mm2: float = key("float", 0, 1000, doc="less leaf area: an empty cell")


_VISION_DEFAULTS = {
    "seedling_draw": "default",
    "image_width_px": 1600,
    "image_height_px": 900,
    "light_scale": [0.85, 1.15],
    "leaf_hue_deg": [80.0, 130.0],
    "leaf_saturation": [0.5, 0.8],
    "leaf_value": [0.45, 0.75],
    "leaf_jitter": 0.06,
    "substrate_hue_deg": [18.0, 34.0],
    "substrate_saturation": [0.4, 0.6],
    "substrate_value": [0.28, 0.45],
    "tray_yaw_deg": 2.0,
    "tray_tip_deg": 0.5,
    "tray_shift_mm": 8.0,
    "camera_height_mm": 3000.0,
    "leaf_height_mm": 14.0,
    "white_percentile": 99.5,
    "min_white_level": 25.0,
    "min_contrast": 8.0,
    "tray_band": [0.65, 1.01],
    "close_fraction": 1 / 150,
    "erode_mm": 1.0,
    "open_mm": 2.0,
    "tray_aspect_tolerance": 0.12,
    "rectified_resolution_mm": 0.5,
    "profile_level": 0.5,
    "leaf_hue_band_deg": [56.0, 190.0],
    "leaf_min_saturation": 45,
    "leaf_min_value": 35,
    "min_component_mm2": 6.0,
    "core_radius_mm": 12.0,
    "min_leaf_area_mm2": 100.0,
    "max_centroid_offset_mm": 10.0,
    "min_secant_mm": 12.0,
    "empty_area_mm2": 10.0,
}


SECTIONS = {
    "delta_refill": Section(DeltaRefillSection, defaults=_DELTA_REFILL_DEFAULTS),
    "vision": Section(VisionSection, defaults=_VISION_DEFAULTS),
}
"""Its own sections (transplanter.kinds.sections)."""
