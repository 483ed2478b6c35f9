"""The fuzzy gripper controller of seed paper 004 (Dewi et al. 2020, Sec. 2.2, Tables 2 and 6)
and the HC-SR04 ultrasonic sensors that feed it, pure python/numpy with scikit-fuzzy.

Inputs: sensor 1 (at the pick station: is an object there?) and sensor 2 (on the gripper: how
far is the object?), distances in cm, and the base servo's angle in deg; output: the gripper
servo angle theta4 in deg (0 closed, 60 fully open). Terms: distances Near / Medium / Far,
base angle Small / Medium / Far, gripper Small (20-25 deg, picking and placing) / Medium
(25-33 deg, initial motion) / Big (37-60 deg, standby). The 27 rules are Table 2's, each
ANDing its three antecedents.

What the paper does not state is filled in with defaults (docs/serial_arm.md): Mamdani
inference with AND = min, implication = min, aggregation = max and centroid
defuzzification (SciLab sciFLT's and MATLAB's defaults); the distance terms are the crisp
ranges of Table 6 (Near 0-5, Medium 6-10, Far 11-20 cm) joined by the paper's Eq. 7 linear
ramps over the gaps (5 -> 6 and 10 -> 11 cm); the base-angle terms are invented (no data):
Small 0-30, Medium 60-120, Far 150-180 deg with 30 deg ramps; the output terms have the
paper's ranges as cores and 2 deg ramps. The wider reading of Eq. 7 (one ramp from 5 to
11 cm, Medium a triangle at 8 cm) is :data:`WIDE_DISTANCE_TERMS_CM`.

scikit-fuzzy's functional API does the work (``trapmf``, ``interp_membership``, ``defuzz``);
its ``skfuzzy.control`` layer needs networkx, which its 0.5 wheel does not declare.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import skfuzzy as fuzz

__all__ = [
    "BASE_TERMS_DEG",
    "DISTANCE_TERMS_CM",
    "NO_ECHO",
    "OUTPUT_RANGES_DEG",
    "OUTPUT_TERMS_DEG",
    "RULES",
    "TABLE6",
    "WIDE_DISTANCE_TERMS_CM",
    "FuzzyGripper",
    "Table6Trial",
    "UltrasonicSensor",
]

Trapezoid = tuple[float, float, float, float]

DISTANCE_TERMS_CM: dict[str, Trapezoid] = {
    "near": (0.0, 0.0, 5.0, 6.0),
    "medium": (5.0, 6.0, 10.0, 11.0),
    "far": (10.0, 11.0, 20.0, 20.0),
}
"""Sensor distance terms (cm): Table 6's crisp ranges, Eq. 7 ramps over the gaps."""

WIDE_DISTANCE_TERMS_CM: dict[str, Trapezoid] = {
    "near": (0.0, 0.0, 5.0, 11.0),
    "medium": (5.0, 8.0, 8.0, 11.0),
    "far": (5.0, 11.0, 20.0, 20.0),
}
"""The other reading of Eq. 7: one ramp between alpha = 5 and beta = 11 cm."""

BASE_TERMS_DEG: dict[str, Trapezoid] = {
    "small": (0.0, 0.0, 30.0, 60.0),
    "medium": (30.0, 60.0, 120.0, 150.0),
    "far": (120.0, 150.0, 180.0, 180.0),
}
"""Base servo angle terms (deg): not in the paper (a default)."""

OUTPUT_TERMS_DEG: dict[str, Trapezoid] = {
    "small": (18.0, 20.0, 25.0, 27.0),
    "medium": (23.0, 25.0, 33.0, 35.0),
    "big": (35.0, 37.0, 60.0, 60.0),
}
"""Gripper angle terms (deg): the paper's ranges as cores, 2 deg ramps."""

OUTPUT_RANGES_DEG: dict[str, tuple[float, float]] = {
    "small": (20.0, 25.0),
    "medium": (25.0, 33.0),
    "big": (37.0, 60.0),
}
"""The paper's range of each gripper term (Sec. 2.2 and Table 6)."""

DISTANCE_RANGE_CM = (0.0, 20.0)
BASE_RANGE_DEG = (0.0, 180.0)
OUTPUT_RANGE_DEG = (0.0, 60.0)

_N, _M, _F = "near", "medium", "far"
_S, _B = "small", "big"
RULES: tuple[tuple[str, str, str, str], ...] = (
    (_N, _N, _S, _S), (_N, _N, _M, _S), (_N, _N, _F, _S),
    (_N, _M, _S, _S), (_N, _M, _M, _M), (_N, _M, _F, _M),
    (_N, _F, _S, _M), (_N, _F, _M, _M), (_N, _F, _F, _M),
    (_M, _N, _S, _M), (_M, _N, _M, _M), (_M, _N, _F, _M),
    (_M, _M, _S, _M), (_M, _M, _M, _M), (_M, _M, _F, _M),
    (_M, _F, _S, _M), (_M, _F, _M, _M), (_M, _F, _F, _B),
    (_F, _N, _S, _B), (_F, _N, _M, _B), (_F, _N, _F, _B),
    (_F, _M, _S, _B), (_F, _M, _M, _B), (_F, _M, _F, _B),
    (_F, _F, _S, _B), (_F, _F, _M, _B), (_F, _F, _F, _B),
)  # fmt: skip
"""Table 2, rules 1-27 in order: (sensor 1, sensor 2, base angle) -> gripper. The base
angle's terms are small / medium / far (the paper's "Far" for its largest)."""


@dataclass(frozen=True)
class Table6Trial:
    """One gripper trial of Table 6: sensor 1's state, sensor 2's distance range, the output
    term and angle range the paper measured in."""

    row: int
    sensor1_detected: bool
    sensor2_cm: tuple[float, float]
    term: str
    angle_deg: tuple[float, float]


def _t6(row, detected, s2, term):
    return Table6Trial(row, detected, s2, term, OUTPUT_RANGES_DEG[term])


TABLE6: tuple[Table6Trial, ...] = (
    _t6(1, True, (0, 5), _S), _t6(2, True, (0, 5), _S), _t6(3, True, (0, 5), _S),
    _t6(4, True, (6, 10), _S), _t6(5, True, (6, 10), _M), _t6(6, True, (6, 10), _M),
    _t6(7, True, (11, 20), _M), _t6(8, True, (11, 20), _M), _t6(9, True, (11, 20), _M),
    _t6(10, False, (0, 5), _B), _t6(11, False, (0, 5), _B), _t6(12, False, (0, 5), _B),
    _t6(13, False, (6, 10), _B), _t6(14, False, (6, 10), _B), _t6(15, False, (6, 10), _B),
    _t6(16, False, (11, 20), _B), _t6(17, False, (11, 20), _B), _t6(18, False, (11, 20), _B),
)  # fmt: skip
"""The 18 gripper trials of Table 6. "Detected" is sensor 1 Near and "No detection" Far;
row 4 (Small with sensor 2 at 6-10 cm) needs a Small base angle (rule 4), rows 5-6 a Medium
or Far one (rules 5-6)."""

NO_ECHO = math.inf
"""What a sensor reads when no echo comes back (nothing within its range): beyond every
distance term, so the controller takes it as Far."""


def _terms_mf(universe: np.ndarray, terms: Mapping[str, Trapezoid]) -> dict[str, np.ndarray]:
    return {name: fuzz.trapmf(universe, list(abcd)) for name, abcd in terms.items()}


@dataclass(frozen=True)
class FuzzyGripper:
    """The Mamdani controller of Table 2 (min AND and implication, max aggregation, centroid
    over the output universe sampled every ``resolution_deg``)."""

    distance_terms: Mapping[str, Trapezoid] = field(default_factory=lambda: DISTANCE_TERMS_CM)
    base_terms: Mapping[str, Trapezoid] = field(default_factory=lambda: BASE_TERMS_DEG)
    output_terms: Mapping[str, Trapezoid] = field(default_factory=lambda: OUTPUT_TERMS_DEG)
    rules: tuple[tuple[str, str, str, str], ...] = RULES
    resolution_deg: float = 0.01
    input_resolution: float = 0.01
    """Sampling of the input universes (cm, deg): breakpoints on it make the memberships
    exact."""

    def __post_init__(self) -> None:
        for name, terms, expected in (
            ("distance_terms", self.distance_terms, {_N, _M, _F}),
            ("base_terms", self.base_terms, {_S, _M, _F}),
            ("output_terms", self.output_terms, {_S, _M, _B}),
        ):
            if set(terms) != expected:
                raise ValueError(f"FuzzyGripper.{name} needs the terms {sorted(expected)}")
        for rule in self.rules:
            s1, s2, base, out = rule
            if not (
                {s1, s2} <= set(self.distance_terms)
                and base in self.base_terms
                and out in self.output_terms
            ):
                raise ValueError(f"FuzzyGripper: rule {rule} names an unknown term")
        step = self.input_resolution
        distance = np.arange(DISTANCE_RANGE_CM[0], DISTANCE_RANGE_CM[1] + step / 2, step)
        base = np.arange(BASE_RANGE_DEG[0], BASE_RANGE_DEG[1] + step / 2, step)
        out = np.arange(OUTPUT_RANGE_DEG[0], OUTPUT_RANGE_DEG[1] + self.resolution_deg / 2,
                        self.resolution_deg)  # fmt: skip
        object.__setattr__(self, "_distance", (distance, _terms_mf(distance, self.distance_terms)))
        object.__setattr__(self, "_base", (base, _terms_mf(base, self.base_terms)))
        object.__setattr__(self, "_out", (out, _terms_mf(out, self.output_terms)))

    @property
    def output_universe(self) -> np.ndarray:
        return self._out[0]

    def memberships(self, sensor1_cm: float, sensor2_cm: float, base_angle_deg: float):
        """({term: mu} of sensor 1, of sensor 2, of the base angle). Distances beyond the
        universe (20 cm), NO_ECHO among them, count as 20 cm; angles are clipped to 0-180."""
        for name, value in (("sensor1_cm", sensor1_cm), ("sensor2_cm", sensor2_cm)):
            if math.isnan(value) or value < 0:
                raise ValueError(f"FuzzyGripper: {name} must be a distance >= 0, got {value!r}")
        if not math.isfinite(base_angle_deg):
            raise ValueError(f"FuzzyGripper: base_angle_deg must be finite, got {base_angle_deg}")
        universe, mfs = self._distance
        s1 = min(float(sensor1_cm), DISTANCE_RANGE_CM[1])
        s2 = min(float(sensor2_cm), DISTANCE_RANGE_CM[1])
        mu1 = {t: float(fuzz.interp_membership(universe, mf, s1)) for t, mf in mfs.items()}
        mu2 = {t: float(fuzz.interp_membership(universe, mf, s2)) for t, mf in mfs.items()}
        b_universe, b_mfs = self._base
        angle = min(max(float(base_angle_deg), BASE_RANGE_DEG[0]), BASE_RANGE_DEG[1])
        mu3 = {t: float(fuzz.interp_membership(b_universe, mf, angle)) for t, mf in b_mfs.items()}
        return mu1, mu2, mu3

    def firing(self, sensor1_cm: float, sensor2_cm: float, base_angle_deg: float) -> np.ndarray:
        """(27,) firing strength of each rule: the min of its three memberships."""
        mu1, mu2, mu3 = self.memberships(sensor1_cm, sensor2_cm, base_angle_deg)
        return np.array([min(mu1[a], mu2[b], mu3[c]) for a, b, c, _ in self.rules])

    def aggregate(self, sensor1_cm: float, sensor2_cm: float, base_angle_deg: float):
        """The aggregated output membership over :attr:`output_universe`: every rule's
        output term clipped at its strength (min), then the max over the rules."""
        strengths = self.firing(sensor1_cm, sensor2_cm, base_angle_deg)
        universe, mfs = self._out
        aggregated = np.zeros_like(universe)
        for strength, rule in zip(strengths, self.rules, strict=True):
            if strength > 0:
                aggregated = np.fmax(aggregated, np.fmin(strength, mfs[rule[3]]))
        return aggregated

    def control(self, sensor1_cm: float, sensor2_cm: float, base_angle_deg: float = 0.0) -> float:
        """The gripper servo angle (deg): the centroid of the aggregated output."""
        aggregated = self.aggregate(sensor1_cm, sensor2_cm, base_angle_deg)
        if not aggregated.any():  # the terms leave a gap the inputs fell into
            raise ValueError(
                f"FuzzyGripper: no rule fires at ({sensor1_cm}, {sensor2_cm}, {base_angle_deg})"
            )
        return float(fuzz.defuzz(self.output_universe, aggregated, "centroid"))

    @staticmethod
    def term_of(angle_deg: float) -> str | None:
        """The gripper term whose paper range holds an angle (None between Medium and Big)."""
        for term, (lo, hi) in OUTPUT_RANGES_DEG.items():
            if lo <= angle_deg <= hi:
                return term
        return None


@dataclass(frozen=True)
class UltrasonicSensor:
    """An HC-SR04 ultrasonic ranger as the MuJoCo rangefinder's readings pass through it.

    Datasheet (Elec Freaks HC-SR04): range 2 cm to 4 m, measuring angle 15 deg, ranging
    accuracy 3 mm, 40 kHz, a measurement cycle of at least 60 ms. The ray(s) of the
    rangefinder give true distances (-1 where nothing is hit); the sensor reports the nearest
    echo inside its cone with Gaussian noise, nothing closer than its minimum range, and
    :data:`NO_ECHO` where nothing lies within its maximum range.
    """

    min_range_m: float = 0.02
    max_range_m: float = 4.0
    beam_angle_rad: float = math.radians(15.0)
    """Full angle of the cone it hears echoes from."""
    noise_sd_m: float = 0.003
    """Standard deviation of a reading (the datasheet's 3 mm accuracy taken as one sd)."""
    resolution_m: float = 0.0
    """Quantisation of the reported distance (0: none; 0.01 for firmware that reports whole
    centimetres, echo_us / 58)."""
    cycle_s: float = 0.060

    def __post_init__(self) -> None:
        if not 0 <= self.min_range_m < self.max_range_m:
            raise ValueError("UltrasonicSensor needs 0 <= min_range_m < max_range_m")
        if not 0 < self.beam_angle_rad < math.pi:
            raise ValueError("UltrasonicSensor.beam_angle_rad must lie in (0, pi)")
        if self.noise_sd_m < 0 or self.resolution_m < 0 or self.cycle_s <= 0:
            raise ValueError("UltrasonicSensor: noise, resolution >= 0 and cycle > 0 needed")

    def beam_directions(self, per_ring: int = 8) -> np.ndarray:
        """(1 + per_ring, 3) unit vectors in the sensor's frame (its +z the axis): the axis
        and a ring on the cone's edge, for a caller casting one ray each."""
        half = 0.5 * self.beam_angle_rad
        phi = np.arange(per_ring) * (2.0 * math.pi / per_ring)
        across = np.sin(half)
        ring = np.stack(
            [across * np.cos(phi), across * np.sin(phi), np.full(per_ring, np.cos(half))], axis=-1
        )
        return np.vstack([[0.0, 0.0, 1.0], ring])

    def reading(self, distances_m, rng: np.random.Generator | None = None) -> float:
        """The distance (m) the sensor reports for the true distances of one or more rays
        (any negative value: nothing hit); NO_ECHO if no ray hits within the range. With
        ``rng``, Gaussian noise of ``noise_sd_m``; then clipped to the minimum range and
        quantised."""
        d = np.atleast_1d(np.asarray(distances_m, dtype=np.float64))
        hits = d[(d >= 0) & np.isfinite(d)]
        if hits.size == 0:
            return NO_ECHO
        nearest = float(hits.min())
        if rng is not None and self.noise_sd_m > 0:
            nearest += float(rng.normal(0.0, self.noise_sd_m))
        if nearest > self.max_range_m:
            return NO_ECHO
        nearest = max(nearest, self.min_range_m)
        if self.resolution_m > 0:
            nearest = round(nearest / self.resolution_m) * self.resolution_m
        return nearest

    def reading_cm(self, distances_m, rng: np.random.Generator | None = None) -> float:
        """:meth:`reading` in cm, the controller's unit (NO_ECHO stays NO_ECHO)."""
        value = self.reading(distances_m, rng)
        return value if value == NO_ECHO else value * 100.0
