"""Pot randomisation: the paper pots and seedlings of one scene as a typed batch.

`PotBatch.draw(config, seed)` draws every random number of a scene from
`np.random.default_rng(seed)`, always in the same order (diameter, height, mass, friction,
offset, stem length, leaf count, leaf yaw, bond, soft, sway, crook, fill), so a seed gives the
same pots on every run and every machine. Pots are indexed row-major: pot i sits in row i // cols,
column i % cols.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from scipy.special import gammaincinv, ndtr, ndtri

from transplanter.scene.config import CROOKED_FOOT_HEIGHT, POT_FILL_GAP_MAX, SceneConfig
from transplanter.scene.geometry import cell_centres, crook_frame


def truncated_normal(z: np.ndarray, mean: float, sd: float, lo: float, hi: float) -> np.ndarray:
    """Normal(mean, sd) truncated to [lo, hi], one value per standard normal draw z (its
    quantile mapped into the truncated range: nothing piles up at the bounds, nothing is
    clipped)."""
    if sd == 0:
        return np.full(np.shape(z), float(mean))
    a, b = ndtr((lo - mean) / sd), ndtr((hi - mean) / sd)
    u = a + ndtr(np.asarray(z)) * (b - a)
    return np.clip(mean + sd * ndtri(u), lo, hi)  # only float rounding at the very ends


GAMMA_NORMAL_BELOW = 1e-6
"""A gamma whose sd is below this share of its mean is drawn as its normal limit."""


def gamma_of(z: np.ndarray, mean: float, sd: float) -> np.ndarray:
    """A gamma distribution with this mean and sd (never negative: a friction coefficient),
    one value per standard normal draw z (its quantile); mean 0 gives exactly 0."""
    if sd == 0 or mean == 0:
        return np.full(np.shape(z), float(mean))
    if sd < mean * GAMMA_NORMAL_BELOW:
        # shape (mean/sd)^2 past 1e12: the gamma is its normal limit to far below float
        # precision, and its shape would overflow a float for a tiny sd such as 1e-300
        return np.maximum(mean + sd * np.asarray(z, dtype=np.float64), 0.0)
    shape, scale = (mean / sd) ** 2, sd * sd / mean
    return scale * gammaincinv(shape, ndtr(np.asarray(z)))


@dataclass(frozen=True)
class PotBatch:
    """The rows*cols pots of a scene (arrays are read-only, indexed row-major).

    diameter, height (m), mass (kg, without the seedling), friction (sliding, paper on jaws
    and belt), offset (n, 2: placement offset from the cell centre, m), cell_xy (n, 2: cell
    centre at conveyor position 0, m), stem_length (m above the pot's top), n_leaves (int),
    leaf_yaw0 (rad, yaw of leaf 0; the others follow evenly around the stem), bond_force (N,
    strength of the pot's bond to the belt; 0: none), soft (bool: a soaked pot whose wall
    gives under the jaws), sway_hz (the natural frequency of its seedling's shoot swaying on
    its stem, Hz; transplanter.twin.shoot), crook (rad: how far its wall leans over its foot; 0
    for a straight pot), crook_azimuth (rad: towards which side, from +x) and fill_gap (m:
    how far below the rim its soil lies).
    """

    diameter: np.ndarray
    height: np.ndarray
    mass: np.ndarray
    friction: np.ndarray
    offset: np.ndarray
    cell_xy: np.ndarray
    stem_length: np.ndarray
    n_leaves: np.ndarray
    leaf_yaw0: np.ndarray
    bond_force: np.ndarray
    soft: np.ndarray
    sway_hz: np.ndarray
    crook: np.ndarray
    crook_azimuth: np.ndarray
    fill_gap: np.ndarray

    def __post_init__(self) -> None:
        for f in fields(self):
            getattr(self, f.name).setflags(write=False)

    @classmethod
    def draw(cls, config: SceneConfig, seed: int) -> PotBatch:
        """The pots of a scene with this config and seed (np.random.default_rng(seed))."""
        return cls.draw_from(config, np.random.default_rng(seed))

    @classmethod
    def draw_from(cls, config: SceneConfig, rng: np.random.Generator) -> PotBatch:
        """The pots drawn from rng, in the fixed order of the module docstring."""
        cfg = config
        n = cfg.rows * cfg.cols
        diameter = cfg.pot_diameter + cfg.pot_diameter_sd * rng.standard_normal(n)
        height = cfg.pot_height + cfg.pot_height_sd * rng.standard_normal(n)
        mass = truncated_normal(
            rng.standard_normal(n), cfg.pot_mass, cfg.pot_mass_sd, *cfg.pot_mass_range
        )
        friction = gamma_of(rng.standard_normal(n), cfg.pot_friction, cfg.pot_friction_sd)
        offset = truncated_normal(
            rng.standard_normal((n, 2)), 0.0, cfg.pot_offset_sd, -cfg.pot_offset_max,
            cfg.pot_offset_max,
        )  # fmt: skip
        stem_length = rng.uniform(*cfg.stem_length_range, n)
        n_leaves = rng.integers(cfg.leaves_range[0], cfg.leaves_range[1] + 1, n)
        leaf_yaw0 = rng.uniform(0, 2 * np.pi, n)
        bonded = rng.random(n) < cfg.pot_bond_share
        strength = cfg.pot_bond_force * np.exp(cfg.pot_bond_sd_log * rng.standard_normal(n))
        bond_force = np.where(bonded, strength, 0.0)
        soft = rng.random(n) < cfg.pot_soft_share
        sway_hz = gamma_of(rng.standard_normal(n), cfg.stem_sway_hz, cfg.stem_sway_sd_hz)
        crooked = rng.random(n) < cfg.pot_crooked_share
        crook = np.where(crooked, rng.uniform(0.0, cfg.pot_crooked_max, n), 0.0)
        crook_azimuth = rng.uniform(0.0, 2 * np.pi, n)
        fill_gap = truncated_normal(
            rng.standard_normal(n), cfg.pot_fill_gap, cfg.pot_fill_gap_sd, 0.0, POT_FILL_GAP_MAX
        )
        return cls(
            diameter=diameter,
            height=height,
            mass=mass,
            friction=friction,
            offset=offset,
            cell_xy=cell_centres(cfg),
            stem_length=stem_length,
            n_leaves=n_leaves,
            leaf_yaw0=leaf_yaw0,
            bond_force=bond_force,
            soft=soft,
            sway_hz=sway_hz,
            crook=crook,
            crook_azimuth=crook_azimuth,
            fill_gap=fill_gap,
        )

    def soil_z(self, i: int) -> float:
        """Height (m) of pot i's soil above its centre, where its seedling stands."""
        return float(self.height[i] / 2 - self.fill_gap[i])

    def wall_frame(self, i: int):
        """Pot i's crook_frame (pivot, rotation, quaternion), or None for a straight pot."""
        if self.crook[i] == 0:
            return None
        foot = CROOKED_FOOT_HEIGHT
        return crook_frame(self.crook[i], self.crook_azimuth[i], self.height[i], foot)

    def __len__(self) -> int:
        return int(self.diameter.size)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PotBatch):
            return NotImplemented
        return all(
            np.array_equal(getattr(self, f.name), getattr(other, f.name)) for f in fields(self)
        )
