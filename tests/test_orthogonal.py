"""transplanter.studies.orthogonal: the L9 array, the range analysis and Eq. 1's score against
the paper's Table 2 (Zhao, Cheng, Dong, Ma, Xiong and Tong, Agriculture 2022)."""

import numpy as np
import pytest

from transplanter.studies.orthogonal import (
    L9,
    comprehensive_score,
    format_range_table,
    membership,
    order,
    range_analysis,
    sweep_range_analysis,
    twin_score,
)

# Table 2: levels A B C, then healthy %, inferior %, retention %, cleanness %, score
TABLE2 = [
    ((1, 1, 1), 87.50, 85.93, 87.54, 87.37, 0.695),
    ((1, 2, 2), 96.88, 92.19, 85.32, 83.14, 0.871),
    ((1, 3, 3), 89.06, 85.94, 82.36, 82.26, 0.447),
    ((2, 1, 2), 89.06, 87.50, 85.83, 82.66, 0.624),
    ((2, 2, 3), 85.94, 84.38, 83.28, 81.45, 0.419),
    ((2, 3, 1), 85.94, 82.81, 86.77, 82.48, 0.501),
    ((3, 1, 3), 81.25, 78.13, 82.26, 79.58, 0.123),
    ((3, 2, 1), 84.38, 82.81, 83.41, 80.15, 0.323),
    ((3, 3, 2), 85.94, 84.38, 80.74, 74.42, 0.219),
]
NAMES = ("moisture", "age", "acceleration")


def test_the_l9_array_is_orthogonal_and_its_first_columns_are_the_papers_runs():
    assert [tuple(int(v) for v in row[:3]) for row in L9] == [lv for lv, *_ in TABLE2]
    for i in range(4):
        for j in range(i + 1, 4):  # every pair of levels once in every pair of columns
            pairs = {(int(a), int(b)) for a, b in L9[:, [i, j]]}
            assert len(pairs) == 9


def test_k_and_r_of_the_papers_score_column():
    levels = np.array([lv for lv, *_ in TABLE2])
    score = [row[-1] for row in TABLE2]
    a, b, c = range_analysis(levels, score, NAMES)
    assert a.k == pytest.approx((0.671, 0.515, 0.222), abs=5e-4)
    assert b.k == pytest.approx((0.481, 0.538, 0.389), abs=5e-4)
    assert c.k == pytest.approx((0.506, 0.571, 0.330), abs=5e-4)
    assert (a.r, b.r, c.r) == pytest.approx((0.449, 0.149, 0.241), abs=1e-3)
    assert [fr.name for fr in order((a, b, c))] == ["moisture", "acceleration", "age"]
    assert (a.best, b.best, c.best) == (1, 2, 2)  # the paper's optimum A1 B2 C2


def test_eq1_with_the_papers_weights_recomputes_its_scores():
    cols = [[row[i] for row in TABLE2] for i in (1, 2, 3, 4)]
    score = comprehensive_score(cols)
    assert np.round(score, 3).tolist() == [0.686, 0.869, 0.485, 0.627, 0.407, 0.492, 0.124,
                                           0.327, 0.223]  # fmt: skip
    # the paper's printed scores differ by at most 0.038 (run 3)
    assert np.max(np.abs(score - [row[-1] for row in TABLE2])) == pytest.approx(0.0378, abs=1e-3)


def test_the_twin_score_is_eq1_with_the_inferior_indices_equal_to_the_healthy_ones():
    success, retention = [0.9, 1.0, 0.5], [0.8, 0.85, 0.9]
    # memberships: success 0.8, 1, 0; retention 0, 0.5, 1
    assert twin_score(success, retention) == pytest.approx([0.48, 0.8, 0.4])
    assert membership([2.0, 2.0]).tolist() == [0.0, 0.0]
    with pytest.raises(ValueError, match="3 indices for 4 weights"):
        comprehensive_score([[1.0], [1.0], [1.0]])


def test_the_printed_table_names_k_r_order_and_best_levels():
    levels = np.array([lv for lv, *_ in TABLE2])
    text = format_range_table("score:", range_analysis(levels, [row[-1] for row in TABLE2], NAMES))
    lines = text.splitlines()
    assert lines[0] == "score:"
    assert lines[2].split() == ["k1", "0.671", "0.481", "0.506"]
    # C's R is 0.5713 - 0.3297 = 0.2417: the paper's 0.241 is the difference of its rounded k
    assert lines[5].split() == ["R", "0.449", "0.149", "0.242"]
    assert lines[6] == "order: A > C > B"
    assert lines[7] == "best levels: A1 B2 C2"


def test_a_sweeps_range_analysis_from_its_settings_and_runs():
    axes = [("plugs.moisture_pct", (65.0, 75.0, 85.0)), ("plugs.age_d", (20.0, 25.0, 30.0)),
            ("plug_bench.extraction_accel_m_s2", (20.0, 30.0, 40.0))]  # fmt: skip
    settings, rows = [], []
    for lv, healthy, _, retention, _, _ in TABLE2:
        setting = {k: v[i - 1] for (k, v), i in zip(axes, lv, strict=True)}
        settings.append({**setting, "success_rate": healthy / 100,
                         "substrate_retention": retention / 100, "cycle_time_s": 1.5})  # fmt: skip
        for seed, shift in ((1, -0.01), (2, 0.01)):
            rows.append({**setting, "seed": seed, "success_rate": healthy / 100 + shift,
                         "substrate_retention": retention / 100, "cycle_time_s": 1.5})  # fmt: skip
    # a setting where nothing arrived delivers no substrate: its retention counts as 0
    settings[6] = {**settings[6], "success_rate": 0.0, "substrate_retention": None}
    text, csv_rows = sweep_range_analysis(axes, settings, rows)
    assert "success:" in text and "retention:" in text and "score (Eq. 1" in text
    assert "R over the 2 seeds one at a time" in text
    by = {(r["response"], r["factor"]): r for r in csv_rows}
    a = by["substrate_retention", "A plugs.moisture_pct"]
    assert a["k3"] == pytest.approx((0 + 0.8341 + 0.8074) / 3)
    assert a["best_value"] == 75.0 and a["R"] == pytest.approx(0.8529 - 0.5472, abs=1e-4)
    # the run without arrivals (A3 B1 C3) pulls C3 down as much: C ranks first, A second
    assert [by["substrate_retention", f]["rank"] for f in ("A plugs.moisture_pct",
            "B plugs.age_d", "C plug_bench.extraction_accel_m_s2")] == [2, 3, 1]  # fmt: skip
    success_a = by["success_rate", "A plugs.moisture_pct"]
    assert success_a["k1"] == pytest.approx((0.875 + 0.9688 + 0.8906) / 3)
    # the seeds differ by a shift common to all runs: each seed's R is the pooled one
    assert success_a["R_seed_min"] == pytest.approx(success_a["R_seed_max"])
    cycle = by["cycle_time_s", "C plug_bench.extraction_accel_m_s2"]
    assert cycle["R"] == 0.0


def test_ties_are_printed_as_ties():
    levels = np.array([row[:3] for row in L9])
    # a response that varies only at A3: B and C are confounded in its three runs
    values = [1, 1, 1, 1, 1, 1, 0.2, 0.7, 0.4]
    text = format_range_table("success:", range_analysis(levels, values, NAMES))
    assert "order: A > B = C" in text
    assert "best levels: A1|A2 B2 C1" in text
