"""Seed 002's plug-in claws: pins into the plug, a stripper, a rotary cylinder."""

from dataclasses import dataclass

from transplanter.kinds.interfaces import ALL
from transplanter.kinds.sections import Section, key

NAME = "plug_claws"
SUMMARY = "plug-in claws with a stripper on a rotary cylinder (seed 002)"
SCENE = "transplanter.scene.effectors.plug_claws"
MODEL = "plug_claws"
READS = {"plug_claws": ALL}


@dataclass(frozen=True)
class PlugClawsSection:
    """[plug_claws]: the plug-in claws (`transplanter.scene.effectors.plug_claws.
    PlugClawsConfig`, whose fields are the file keys), read by the delta's jobs. Optional: the
    defaults are PlugClawsConfig's estimates (docs/plug_claws.md)."""

    insertion_angle_rad: float = key("float", 1, 45, doc="each claw's slide from vertical")
    insertion_depth_m: float = key("float", 5, 38, doc="tips below the substrate at full stroke")
    tip_offset_m: float = key("float", 1, 14, doc="tip from the cell's centre line")
    tip_recess_m: float = key("float", 0, 20, doc="retracted tips inside the stripper")
    stripper_drop_m: float = key("float", 20, 200, doc="stripper's underside below the mount")
    work_gap_m: float = key("float", 0, 20, doc="stripper above the tray while the claws go in")
    tray_substrate_below_top_m: float = key("float", 0, 20, doc="the stroke's substrate level")
    claw_radius_m: float = key("float", 0.2, 5, doc="claw collision capsule radius")
    pin_interference_m: float = key("float", 0, 5, doc="claw surface into the plug's core")
    pressure_mpa: float = key("float", 0.01, 1.0, doc="cylinder supply pressure (gauge)")
    bore_m: float = key("float", 2, 50, doc="cylinder bore")
    rod_m: float = key("float", 1, 25, doc="cylinder rod")
    cylinder_stroke_s: float = key("float", 10, 5000, doc="full stroke (throttled)")
    cylinder_kv_n_s_m: float = key("float", 0.1, 10000, doc="stiffness of the flow limit")
    rotary_stroke_s: float = key("float", 10, 5000, doc="the rotary cylinder's 90 deg swing")
    rotary_torque_nm: float = key("float", 0.01, 100, doc="rotary cylinder torque")
    rotary_kp_nm_rad: float = key("float", 0.01, 1000, doc="rotary cylinder stiffness")
    settle_s: float = key("float", 0, 5000, doc="dwell after a stroke (switch, valve)")
    leaf_damage_force_n: float = key("float", 0.01, 100, doc="a leaf pressed harder tears")


_PLUG_CLAWS_DEFAULTS = {
    "insertion_angle_deg": 12.0,
    "insertion_depth_mm": 32.0,
    "tip_offset_mm": 7.0,
    "tip_recess_mm": 3.0,
    "stripper_drop_mm": 60.0,
    "work_gap_mm": 2.0,
    "tray_substrate_below_top_mm": 3.0,
    "claw_radius_mm": 1.0,
    "pin_interference_mm": 1.5,
    "pressure_mpa": 0.5,
    "bore_mm": 10.0,
    "rod_mm": 4.0,
    "cylinder_stroke_ms": 150.0,
    "cylinder_kv_n_s_m": 20.0,
    "rotary_stroke_ms": 250.0,
    "rotary_torque_nm": 0.3,
    "rotary_kp_nm_rad": 2.0,
    "settle_ms": 30.0,
    "leaf_damage_force_n": 0.5,
}


def _check(claws: dict) -> str | None:
    if claws["rod_m"] >= claws["bore_m"]:
        return (
            "plug_claws.rod_mm must be below plug_claws.bore_mm (the return stroke pushes on "
            "the annulus between them)."
        )
    return None


SECTIONS = {
    "plug_claws": Section(
        PlugClawsSection,
        defaults=_PLUG_CLAWS_DEFAULTS,
        check=_check,
        file_keys={
            "cylinder_stroke_s": "cylinder_stroke_ms",
            "rotary_stroke_s": "rotary_stroke_ms",
            "settle_s": "settle_ms",
            "cylinder_kv_n_s_m": "cylinder_kv_n_s_m",
            "rotary_kp_nm_rad": "rotary_kp_nm_rad",
        },
    ),
}
"""Its own sections (transplanter.kinds.sections)."""
