"""The fuzzy gripper controller of seed 004 (Table 2's 27 rules, Mamdani min/max, centroid) and
the HC-SR04 sensor model that feeds it: every rule's core gives an angle in its output range,
the controller equals an evaluation written here in plain numpy, and the 18 trials of
Table 6 give angles in their ranges."""

from __future__ import annotations

import math

import numpy as np
import pytest

from transplanter.machine.fuzzy_gripper import (
    NO_ECHO,
    OUTPUT_RANGES_DEG,
    RULES,
    TABLE6,
    WIDE_DISTANCE_TERMS_CM,
    FuzzyGripper,
    UltrasonicSensor,
)

FLC = FuzzyGripper()

# Table 2 read again, independently of the module: OUT[s1][s2][theta1], indices 0 Near/Small,
# 1 Medium, 2 Far; outputs 0 Small, 1 Medium, 2 Big.
OUT = np.array(
    [
        [[0, 0, 0], [0, 1, 1], [1, 1, 1]],  # S1 Near: rules 1-9
        [[1, 1, 1], [1, 1, 1], [1, 1, 2]],  # S1 Medium: rules 10-18
        [[2, 2, 2], [2, 2, 2], [2, 2, 2]],  # S1 Far: rules 19-27
    ]
)
DIST_BREAKS = [(0, 0, 5, 6), (5, 6, 10, 11), (10, 11, 20, 20)]  # cm
BASE_BREAKS = [(0, 0, 30, 60), (30, 60, 120, 150), (120, 150, 180, 180)]  # deg
OUT_BREAKS = [(18, 20, 25, 27), (23, 25, 33, 35), (35, 37, 60, 60)]  # deg
DIST_CORE = [2.5, 8.0, 15.5]  # the middle of each distance term's core
BASE_CORE = [15.0, 90.0, 165.0]
OUT_NAMES = ["small", "medium", "big"]


def trap(x, abcd):
    """A trapezoid membership in plain numpy (vertical shoulders where a == b or c == d)."""
    a, b, c, d = abcd
    x = np.asarray(x, dtype=np.float64)
    rise = np.ones_like(x) if a == b else np.clip((x - a) / (b - a), 0, 1)
    fall = np.ones_like(x) if c == d else np.clip((d - x) / (d - c), 0, 1)
    inside = (x >= a) & (x <= d)
    return np.where(inside, np.minimum(rise, fall), 0.0)


def reference(s1, s2, base, step=0.001):
    """Mamdani min/max with the centroid over a fine grid of the output, in plain numpy."""
    s1, s2 = min(s1, 20.0), min(s2, 20.0)
    mu1 = [float(trap(s1, b)) for b in DIST_BREAKS]
    mu2 = [float(trap(s2, b)) for b in DIST_BREAKS]
    mu3 = [float(trap(base, b)) for b in BASE_BREAKS]
    y = np.arange(0.0, 60.0 + step / 2, step)
    agg = np.zeros_like(y)
    for i in range(3):
        for j in range(3):
            for k in range(3):
                w = min(mu1[i], mu2[j], mu3[k])
                agg = np.maximum(agg, np.minimum(w, trap(y, OUT_BREAKS[OUT[i, j, k]])))
    return float((y * agg).sum() / agg.sum())


def test_the_rule_base_is_table_2():
    assert len(RULES) == 27
    names = ["near", "medium", "far"]
    base = ["small", "medium", "far"]
    for n, (s1, s2, b, out) in enumerate(RULES):
        i, j, k = n // 9, (n // 3) % 3, n % 3  # the table's order: S1, then S2, then theta1
        assert (s1, s2, b) == (names[i], names[j], base[k])
        assert out == OUT_NAMES[OUT[i, j, k]], f"rule {n + 1}"


@pytest.mark.parametrize("n", range(27), ids=[f"rule{n + 1}" for n in range(27)])
def test_each_rules_core_gives_an_angle_in_its_output_range(n):
    i, j, k = n // 9, (n // 3) % 3, n % 3
    inputs = (DIST_CORE[i], DIST_CORE[j], BASE_CORE[k])
    strengths = FLC.firing(*inputs)
    assert strengths[n] == 1.0 and strengths.sum() == 1.0  # this rule alone fires
    angle = FLC.control(*inputs)
    lo, hi = OUTPUT_RANGES_DEG[RULES[n][3]]
    assert lo <= angle <= hi
    assert FuzzyGripper.term_of(angle) == RULES[n][3]


def test_the_cores_give_each_terms_centroid():
    assert FLC.control(2.5, 2.5, 15) == pytest.approx(22.5, abs=0.01)  # Small (18, 20, 25, 27)
    assert FLC.control(8, 8, 90) == pytest.approx(29.0, abs=0.01)  # Medium (23, 25, 33, 35)
    assert FLC.control(15.5, 15.5, 165) == pytest.approx(48.0, abs=0.05)  # Big (35, 37, 60, 60)


def test_the_controller_equals_a_plain_numpy_evaluation_of_the_same_rules():
    rng = np.random.default_rng(4)
    # random inputs everywhere, many of them on the ramps where two or more rules fire
    points = np.column_stack(
        [rng.uniform(0, 22, 150), rng.uniform(0, 22, 150), rng.uniform(0, 180, 150)]
    )
    ramps = [(5.5, 10.5, 45.0), (5.2, 5.7, 135.0), (10.3, 6.0, 30.0), (5.9, 10.9, 149.0)]
    worst = 0.0
    for s1, s2, base in [*points, *ramps]:
        got = FLC.control(s1, s2, base)
        worst = max(worst, abs(got - reference(s1, s2, base)))
    assert worst < 0.1, worst


@pytest.mark.parametrize("trial", TABLE6, ids=[f"row{t.row}" for t in TABLE6])
def test_the_18_trials_of_table_6_give_angles_in_their_range(trial):
    """Sensor 1 "Detected" reads 3 cm (Near), "No detection" gets no echo (Far); sensor 2
    over its row's range; the base angle Small for row 4, Medium or Far for rows 5-6, any
    for the others (Table 6 does not give it)."""
    sensor = UltrasonicSensor()
    s1 = sensor.reading_cm(0.03) if trial.sensor1_detected else sensor.reading_cm(-1.0)
    assert (s1 == NO_ECHO) is (not trial.sensor1_detected)
    bases = {4: [15.0], 5: [90.0, 165.0], 6: [90.0, 165.0]}.get(trial.row, BASE_CORE)
    lo, hi = trial.angle_deg
    for s2 in np.linspace(*trial.sensor2_cm, 5):
        for base in bases:
            angle = FLC.control(s1, s2, base)
            assert lo <= angle <= hi, (trial.row, s2, base, angle)


def test_the_papers_worked_samples():
    """Sec. 3: (Near, Near, Small) -> Small (20 deg measured); (Near, Far, Medium) -> Medium
    (27 deg); (Medium, Far, Medium) -> Medium (33 deg); (Far, Far, Small) -> rule 25 says Big
    (the text's "Medium, 60 deg" contradicts it; 60 deg lies in Big)."""
    assert FLC.term_of(FLC.control(2, 2, 10)) == "small"
    assert FLC.term_of(FLC.control(2, 15, 90)) == "medium"
    assert FLC.term_of(FLC.control(8, 15, 90)) == "medium"
    assert FLC.term_of(FLC.control(15, 15, 10)) == "big"


def test_the_wide_reading_of_eq_7_and_bad_inputs():
    wide = FuzzyGripper(distance_terms=WIDE_DISTANCE_TERMS_CM)
    # at 8 cm the wide Medium peaks with Near and Far at half; the narrow terms are crisp
    mu_wide, _, _ = wide.memberships(8, 8, 90)
    mu_narrow, _, _ = FLC.memberships(8, 8, 90)
    assert mu_wide == pytest.approx({"near": 0.5, "medium": 1.0, "far": 0.5})
    assert mu_narrow == {"near": 0.0, "medium": 1.0, "far": 0.0}
    assert np.count_nonzero(wide.firing(8, 8, 90)) == 9
    assert np.count_nonzero(FLC.firing(8, 8, 90)) == 1
    with pytest.raises(ValueError, match="sensor2_cm must be a distance"):
        FLC.control(3, -1, 0)
    with pytest.raises(ValueError, match="needs the terms"):
        FuzzyGripper(output_terms={"small": (0, 1, 2, 3)})


def test_hc_sr04_range_noise_and_no_echo():
    sensor = UltrasonicSensor()
    assert sensor.reading(0.1234) == pytest.approx(0.1234)
    assert sensor.reading(-1.0) == NO_ECHO  # MuJoCo's rangefinder: nothing hit
    assert sensor.reading(4.5) == NO_ECHO  # beyond 400 cm
    assert sensor.reading(0.005) == pytest.approx(0.02)  # nothing closer than 2 cm
    assert sensor.reading([-1.0, 0.30, 0.25]) == pytest.approx(0.25)  # the nearest echo
    rng = np.random.default_rng(0)
    readings = np.array([sensor.reading(1.0, rng) for _ in range(4000)])
    assert readings.mean() == pytest.approx(1.0, abs=0.0003)
    assert readings.std() == pytest.approx(0.003, rel=0.05)
    whole_cm = UltrasonicSensor(resolution_m=0.01)
    assert whole_cm.reading_cm(0.1234) == pytest.approx(12.0)
    # the beam: the axis and a ring 7.5 deg off it (15 deg cone)
    dirs = sensor.beam_directions(per_ring=6)
    assert dirs.shape == (7, 3)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0)
    np.testing.assert_allclose(np.degrees(np.arccos(dirs[1:, 2])), 7.5)
    # no echo reaches the controller as Far: sensor 1 sees nothing -> standby (Big)
    assert FLC.term_of(FLC.control(sensor.reading_cm(-1.0), 3.0, 90)) == "big"
    assert math.isinf(NO_ECHO)
