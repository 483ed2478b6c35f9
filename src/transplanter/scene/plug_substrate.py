"""The plug of substrate in a 128-cell tray as a physical body, and the laws of the
substrate a plug-in gripper works on: pure Python and math, no MuJoCo.

Seed 002 (Zhao, Cheng, Dong, Ma, Xiong and Tong, *Research on the End Effector and Optimal
Motion Control Strategy for a Plug Seedling Transplanting Parallel Robot*, Agriculture 2022)
varies substrate moisture (60-70 / 70-80 / 80-90 %), seedling age (20 / 25 / 30 d) and the
transplanting acceleration, and scores the seedlings dropped and the substrate retained; it
gives no law and no constant for the substrate. Everything here is this project's estimate
(docs/plug_claws.md lists each with what it rests on):

- the plug: a frustum 30 x 30 mm at the top, 20 x 20 mm at the bottom, its top
  `surface_below_top_mm` below the tray's top; mass = volume x wet bulk density, the density
  from the dry bulk density and the wet-basis moisture, capped at saturation;
- root binding R(age) in [0, 1): 0 until the roots reach the cell walls (`root_onset_d`),
  then 1 - exp(-(age - onset) / `root_time_d`);
- the substrate's cohesion c(w, age) (kPa): the root-free cohesion at the reference
  moisture, falling e-fold for every `cohesion_moisture_scale_pct` of water above it
  (capillary suction is lost as the pores fill), times (1 + `root_cohesion_gain` R);
- the cell's adhesion tau_w(w, age) (kPa on the plug's side walls): rising with moisture
  (water films) and with the roots pressed against the walls; the pull-out resistance is
  tau_w times the side area still in the cell, so it falls to zero as the plug leaves;
- the pins' hold: the pins carry the plug through contact; their bearing capacity is
  P = N_c c A_pins (the deep bearing factor N_c of a cohesive soil times the pins' bearing
  area): a net pin load above P shears the substrate round the pins and the plug drops;
- retention: the substrate not bound by roots (the loose fraction, falling with R) breaks
  away in a Weibull law of the peak net load L the pins put through the plug, against the
  capacity C = c A_mid of its mid cross-section: lost = m0 f_loose (1 - exp(-(L/C)^k)).
  L is measured in the physics (the vector sum of the pins' contact forces on the plug):
  weight, the acceleration of the lift and the cell's adhesion all load it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

__all__ = ["PlugsConfig", "Substrate", "from_table", "frustum_volume_mm3"]

GRAVITY_M_S2 = 9.81


@dataclass(frozen=True)
class PlugsConfig:
    """The `[plugs]` keys (file units in the names). Geometry from the paper's tray; every
    other default is an estimate (docs/plug_claws.md)."""

    moisture_pct: float = 65.0
    """Wet-basis water content of the substrate: water mass / wet mass (the paper's factor A)."""
    age_d: float = 25.0
    """Seedling age, days after sowing (the paper's factor B)."""
    top_mm: float = 30.0
    """Side of the cell's (and the plug's) square top opening (paper)."""
    bottom_mm: float = 20.0
    """Side of the cell's square bottom (paper)."""
    depth_mm: float = 42.0
    """Depth of the cell (paper)."""
    surface_below_top_mm: float = 3.0
    """How far the substrate's surface lies below the top of the cell walls (estimate)."""
    clearance_mm: float = 0.3
    """Gap between the plug's sides and the cell walls in the model (numerical)."""
    core_top_depth_mm: float = 20.0
    """Depth below the plug's top where the core the pins grip (the pin socket) begins: the
    claws' lowest 12 mm bear on it (estimate)."""
    adhesion_onset_speed_mm_s: float = 1.0
    """Upward speed from which the cell's full adhesion resists (regularised one-way friction)."""
    dry_bulk_density_kg_m3: float = 160.0
    """Dry bulk density of a peat-vermiculite plug substrate (estimate, 100-250 usual)."""
    porosity_pct: float = 90.0
    """Total pore space: caps the wet density at saturation (estimate)."""
    cohesion_kpa: float = 0.55
    """Root-free cohesion of the substrate at the reference moisture (estimate)."""
    reference_moisture_pct: float = 65.0
    """Moisture at which `cohesion_kpa` and `wall_adhesion_kpa` hold."""
    cohesion_moisture_scale_pct: float = 25.0
    """Cohesion falls e-fold per this much more water (estimate)."""
    root_onset_d: float = 12.0
    """Age at which roots start to bind the plug (estimate)."""
    root_time_d: float = 10.0
    """Time constant of root binding after the onset (estimate)."""
    root_cohesion_gain: float = 3.0
    """A fully rooted plug is 1 + this times as cohesive as bare substrate (estimate)."""
    wall_adhesion_kpa: float = 0.05
    """Adhesion of root-free substrate to the cell walls at the reference moisture (estimate)."""
    wall_adhesion_moisture_scale_pct: float = 40.0
    """Wall adhesion grows e-fold per this much more water (estimate)."""
    root_wall_gain: float = 2.0
    """A fully rooted plug sticks 1 + this times as hard to its cell (estimate)."""
    loose_fraction_pct: float = 40.0
    """Share of a root-free plug's substrate that can break away (estimate)."""
    root_loose_reduction_pct: float = 75.0
    """How much of the loose share a fully rooted plug binds (estimate)."""
    weibull_modulus: float = 2.0
    """Spread of the substrate's breaking loads (Weibull modulus, estimate)."""
    bearing_factor: float = 9.0
    """N_c, deep bearing capacity factor of a cohesive soil round a pin (Skempton's 9)."""
    pin_bearing_mm2: float = 200.0
    """Bearing area of the two pins in the substrate (projected, estimate)."""
    pin_friction: float = 0.7
    """Pin-substrate friction coefficient at the reference moisture (estimate)."""
    pin_friction_per_pct: float = 0.01
    """Loss of pin friction per % of moisture above the reference (water lubricates)."""
    wall_friction: float = 0.4
    """Plug-wall friction coefficient (estimate: wet peat on polystyrene or PP)."""
    substrate_timeconst_ms: float = 12.0
    """MuJoCo solref time constant of the pin-substrate contact at the reference (softness)."""
    substrate_stiffening: float = 1.0
    """The contact's time constant divides by (1 + this R): roots stiffen the plug."""
    reference_mass_g: float = 11.0
    """Plug mass at which `substrate_timeconst_ms` holds: MuJoCo's soft contact is set in
    acceleration units, so its force follows the bodies' masses; the time constant grows with
    sqrt(mass / this) to keep the squeeze a property of the substrate, not of its water."""

    def __post_init__(self) -> None:
        if not 0.0 < self.moisture_pct < 100.0:
            raise ValueError(f"plugs.moisture_pct must lie in (0, 100), got {self.moisture_pct}")
        if self.age_d < 0.0:
            raise ValueError(f"plugs.age_d must be >= 0, got {self.age_d}")
        if not self.bottom_mm < self.top_mm:
            raise ValueError("plugs.bottom_mm must be smaller than plugs.top_mm")


def from_table(cls: type, table: dict, section: str):
    """A config dataclass from a TOML table (file units), refusing unknown keys by name."""
    known = {f.name for f in fields(cls)}
    unknown = sorted(set(table) - known)
    if unknown:
        raise ValueError(f"[{section}]: unknown keys {unknown}; known: {sorted(known)}")
    return cls(**{k: float(v) for k, v in table.items()})


def frustum_volume_mm3(top_mm: float, bottom_mm: float, height_mm: float) -> float:
    """Volume of a square frustum: h/3 (A1 + A2 + sqrt(A1 A2))."""
    a1, a2 = top_mm**2, bottom_mm**2
    return height_mm / 3.0 * (a1 + a2 + math.sqrt(a1 * a2))


@dataclass(frozen=True)
class Substrate:
    """The laws of one plug (`PlugsConfig`), in SI."""

    cfg: PlugsConfig

    # --- geometry ---------------------------------------------------------------------
    @property
    def height_m(self) -> float:
        """Height of the plug (cell depth less the empty top)."""
        return (self.cfg.depth_mm - self.cfg.surface_below_top_mm) * 1e-3

    def side_at_depth_m(self, depth_below_top_m: float) -> float:
        """The cell's side at a depth below the top of the walls."""
        c = self.cfg
        frac = depth_below_top_m / (c.depth_mm * 1e-3)
        return (c.top_mm + (c.bottom_mm - c.top_mm) * frac) * 1e-3

    @property
    def plug_top_m(self) -> float:
        """Side of the plug's top face (the cell's side at the substrate surface)."""
        return self.side_at_depth_m(self.cfg.surface_below_top_mm * 1e-3)

    @property
    def volume_m3(self) -> float:
        return (
            frustum_volume_mm3(self.plug_top_m * 1e3, self.cfg.bottom_mm, self.height_m * 1e3)
            * 1e-9
        )

    @property
    def side_area_m2(self) -> float:
        """Area of the plug's four side faces (in contact with the cell)."""
        a, b, h = self.plug_top_m, self.cfg.bottom_mm * 1e-3, self.height_m
        slant = math.hypot(h, (a - b) / 2)
        return 4 * (a + b) / 2 * slant

    @property
    def mid_section_m2(self) -> float:
        """The plug's horizontal cross-section at half its height."""
        return ((self.plug_top_m + self.cfg.bottom_mm * 1e-3) / 2) ** 2

    # --- moisture and roots -----------------------------------------------------------
    @property
    def water_fraction(self) -> float:
        return self.cfg.moisture_pct / 100.0

    @property
    def wet_density_kg_m3(self) -> float:
        """rho_dry / (1 - w), capped at the saturated density rho_dry + porosity x 1000."""
        c = self.cfg
        saturated = c.dry_bulk_density_kg_m3 + c.porosity_pct / 100.0 * 1000.0
        return min(c.dry_bulk_density_kg_m3 / (1.0 - self.water_fraction), saturated)

    @property
    def mass_kg(self) -> float:
        return self.wet_density_kg_m3 * self.volume_m3

    @property
    def root_binding(self) -> float:
        """R(age) in [0, 1)."""
        c = self.cfg
        grown = max(c.age_d - c.root_onset_d, 0.0)
        return 1.0 - math.exp(-grown / c.root_time_d)

    def _moisture_excess_pct(self) -> float:
        return self.cfg.moisture_pct - self.cfg.reference_moisture_pct

    @property
    def cohesion_pa(self) -> float:
        c = self.cfg
        bare = (
            c.cohesion_kpa
            * 1e3
            * math.exp(-self._moisture_excess_pct() / c.cohesion_moisture_scale_pct)
        )
        return bare * (1.0 + c.root_cohesion_gain * self.root_binding)

    @property
    def wall_adhesion_pa(self) -> float:
        c = self.cfg
        bare = (
            c.wall_adhesion_kpa
            * 1e3
            * math.exp(self._moisture_excess_pct() / c.wall_adhesion_moisture_scale_pct)
        )
        return bare * (1.0 + c.root_wall_gain * self.root_binding)

    def cell_adhesion_n(self, rise_m: float) -> float:
        """Pull-out resistance of the cell after the plug has risen `rise_m` out of its seat:
        the adhesion on the side area still inside the cell."""
        inside = min(max(1.0 - rise_m / self.height_m, 0.0), 1.0)
        return self.wall_adhesion_pa * self.side_area_m2 * inside

    # --- hold and retention -----------------------------------------------------------
    @property
    def pin_capacity_n(self) -> float:
        """P = N_c c A_pins: the net load the pins carry before the substrate round them shears."""
        return self.cfg.bearing_factor * self.cohesion_pa * self.cfg.pin_bearing_mm2 * 1e-6

    @property
    def section_capacity_n(self) -> float:
        """C = c A_mid: the load scale of the loose substrate's breaking away."""
        return self.cohesion_pa * self.mid_section_m2

    @property
    def loose_fraction(self) -> float:
        c = self.cfg
        return (
            c.loose_fraction_pct
            / 100.0
            * (1.0 - c.root_loose_reduction_pct / 100.0 * self.root_binding)
        )

    def lost_fraction(self, peak_load_n: float) -> float:
        """Share of the plug's initial mass broken away by a peak net pin load."""
        ratio = max(peak_load_n, 0.0) / self.section_capacity_n
        return self.loose_fraction * (1.0 - math.exp(-(ratio**self.cfg.weibull_modulus)))

    @property
    def pin_friction(self) -> float:
        c = self.cfg
        return max(c.pin_friction - c.pin_friction_per_pct * self._moisture_excess_pct(), 0.05)

    @property
    def contact_timeconst_s(self) -> float:
        c = self.cfg
        stiff = 1.0 + c.substrate_stiffening * self.root_binding
        mass = math.sqrt(self.mass_kg / (c.reference_mass_g * 1e-3))
        return c.substrate_timeconst_ms * 1e-3 / stiff * mass
