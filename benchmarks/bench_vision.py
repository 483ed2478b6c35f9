"""Benchmark: seed 002's recognition pipeline against drawn trays (docs/vision.md's numbers).

For each picture size, lighting (the default draw, darker 0.55x, brighter 1.45x) and seedling
draw (the default `SeedlingDraw()`, whose kinds lie clearly on their side of the thresholds,
and `SeedlingDraw.near_thresholds()`, spread across them), renders the trays of held-out seeds
(not used to choose the thresholds: those were seeds 0-4), grades each picture and prints the
pooled class accuracy with its 95 % Wilson interval, the confusion matrix, the measurement
errors (leaf area, centroid offset, secant of crossing leaves; graded - true) and the time to
grade one picture (rendering excluded), then every missed cell. Asserts nothing.
Headless: MUJOCO_GL=egl (or osmesa).

    MUJOCO_GL=egl python benchmarks/bench_vision.py [first_seed count]   (default 100 10)
"""

from __future__ import annotations

import sys

import numpy as np

from transplanter.scene.plug_tray import SeedlingDraw
from transplanter.studies.vision import grade_seed, pooled
from transplanter.vision.metrics import format_matrix

DRAWS = {"default": SeedlingDraw, "near_thresholds": SeedlingDraw.near_thresholds}
RUNS = [
    ((1600, 900), "default", "default"),
    ((1600, 900), "darker", "default"),
    ((1600, 900), "brighter", "default"),
    ((1600, 900), "default", "near_thresholds"),
    ((1600, 900), "darker", "near_thresholds"),
    ((1600, 900), "brighter", "near_thresholds"),
    ((960, 540), "default", "default"),
    ((960, 540), "default", "near_thresholds"),
]


def errors(trays) -> dict[str, tuple[float, float]]:
    """(mean, mean absolute) of graded - true over cells with a seedling graded non-empty."""
    area, offset, secant = [], [], []
    for t in trays:
        for g, c in zip(t.grading.cells, t.tray.cells, strict=True):
            if c.seedling is None or g.area_mm2 == 0:
                continue
            area.append(g.area_mm2 - c.area_mm2)
            offset.append(g.centroid_offset_mm - c.centroid_offset_mm)
            if c.secant_lr_mm > 0:
                secant.append(g.secant_lr_mm - c.secant_lr_mm)
            if c.secant_ud_mm > 0:
                secant.append(g.secant_ud_mm - c.secant_ud_mm)
    out = {}
    for name, v in (("area_mm2", area), ("offset_mm", offset), ("secant_mm", secant)):
        a = np.array(v)
        out[name] = (float(a.mean()), float(np.abs(a).mean()))
    return out


def main(argv: list[str]) -> int:
    first = int(argv[0]) if argv else 100
    count = int(argv[1]) if len(argv) > 1 else 10
    seeds = range(first, first + count)
    for (width, height), lighting, draw in RUNS:
        trays = [grade_seed(s, width, height, lighting, DRAWS[draw]()) for s in seeds]
        total = pooled(trays)
        times = np.array([t.grading.seconds for t in trays]) * 1000
        lo, hi = total.interval
        err = errors(trays)
        print(
            f"\n## {width}x{height}, {lighting} lighting, {draw} draw, seeds {first}-"
            f"{first + count - 1}: {total.correct}/{total.cells} = {total.accuracy:.2%} "
            f"(95 % Wilson {lo:.2%}-{hi:.2%}); worst tray "
            f"{min(t.score.accuracy for t in trays):.2%}; grading {times.mean():.0f} ms mean, "
            f"{times.max():.0f} ms max per picture\n"
        )
        print(
            "errors (graded - true; mean, mean absolute): "
            + "; ".join(f"{k} {m:+.2f}, {a:.2f}" for k, (m, a) in err.items())
            + "\n"
        )
        print(format_matrix(total.matrix))
        for t in trays:
            for g, c in zip(t.grading.cells, t.tray.cells, strict=True):
                if g.grade != c.truth:
                    print(
                        f"  seed {t.seed} cell {c.index}: {c.truth} (drawn {c.kind}) graded "
                        f"{g.grade}: area {g.area_mm2:.0f}/{c.area_mm2:.0f} mm^2, offset "
                        f"{g.centroid_offset_mm:.1f}/{c.centroid_offset_mm:.1f} mm, secants "
                        f"lr {g.secant_lr_mm:.1f}/{c.secant_lr_mm:.1f} "
                        f"ud {g.secant_ud_mm:.1f}/{c.secant_ud_mm:.1f} mm (graded/true)"
                    )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
