"""scripts/planner_all_moves.py: every cell-to-cell move of the delta's two trays, planned with
the mirror symmetry of the delta and the trays, resumable. Checks the layout's exact
symmetry, the move set, that a mirror image plans to the same total, and that a resumed run
writes the same rows as one without a break."""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from transplanter.machine import planner_bspline as pb
from transplanter.machine.kinematics.delta import DeltaKinematics

ROOT = Path(__file__).resolve().parents[1]
KIN = DeltaKinematics()
LIMITS = pb.MoveLimits.of(KIN)


@pytest.fixture(scope="module")
def pam():
    spec = importlib.util.spec_from_file_location(
        "planner_all_moves", ROOT / "scripts" / "planner_all_moves.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_trays_are_mirror_images_and_the_moves_pair_up(pam):
    pam._check_layout()  # supply cell k mirrored in XZ is planting cell tau(k), exactly
    moves = [(i, j) for i in range(128) for j in range(128)]
    assert all(pam.image(pam.image(m)) == m for m in moves)
    assert sum(pam.image(m) == m for m in moves) == 128
    order = pam.move_order(0, symmetry=True)
    assert len(order) == len(set(order)) == 8256  # (16384 + 128) / 2
    assert {min(m, pam.image(m)) for m in moves} == set(order)
    assert (0, 127) in order[:4]  # the four longest first (corner to far corner)
    assert len(pam.move_order(0, symmetry=False)) == 16384


def test_a_mirror_image_plans_to_the_same_total(pam):
    move = (3, 100)
    a = pb.plan_move(KIN, pam.SUPPLY[move[0]], pam.PLANTING[move[1]], LIMITS)
    i, j = pam.image(move)
    b = pb.plan_move(KIN, pam.SUPPLY[i], pam.PLANTING[j], LIMITS)
    # the same problem, mirrored and reversed; the numbers differ in their last bits, and
    # SLSQP's path with them (docs/planner.md): the totals agree to the search's ~1e-5 s
    assert b.total_s == pytest.approx(a.total_s, abs=2e-5)
    np.testing.assert_allclose(b.intervals_s, a.intervals_s[::-1], atol=2e-3)
    row = pam.mirrored_row(pam.plan_row(KIN, LIMITS, move))
    assert (row["supply"], row["planting"]) == (i, j) and row["planned"] == "mirror"
    assert row["within_limits"]


def test_a_resumed_run_writes_the_same_rows(pam, tmp_path):
    class Args:
        seed, no_symmetry, flush, no_toppra = 0, False, 1, False

    whole, parts = Args(), Args()
    whole.out, whole.max_moves = str(tmp_path / "whole.csv"), 3
    parts.out, parts.max_moves = str(tmp_path / "parts.csv"), 2
    pam.run(whole)
    pam.run(parts)
    parts.max_moves = 1
    pam.run(parts)  # resumes: plans the third move only

    def rows(path):
        with open(path, newline="") as f:
            return [{k: v for k, v in r.items() if k not in ("cpu_s", "wall_s", "toppra_cpu_s")}
                    for r in csv.DictReader(f)]  # fmt: skip

    assert rows(whole.out) == rows(parts.out)
    assert len(rows(whole.out)) == 6  # three moves and their images
    assert all(r["within_limits"] == "True" for r in rows(whole.out))
    # TOPP-RA's optimum on every row, the image's the same, the spline 10-20 % slower
    by_move = {(r["supply"], r["planting"]): r for r in rows(whole.out)}
    for r in by_move.values():
        topp, total = float(r["toppra_total_s"]), float(r["total_s"])
        assert 1.10 < total / topp < 1.20
        assert float(r["ratio"]) == pytest.approx(total / topp, rel=1e-12)
        i, j = pam.image((int(r["supply"]), int(r["planting"])))
        assert by_move[(str(i), str(j))]["toppra_total_s"] == r["toppra_total_s"]
