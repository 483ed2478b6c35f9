"""Benchmark: seed 002's recognition pipeline against drawn trays (docs/vision.md's numbers).

For each lighting (the default draw, darker 0.55x, brighter 1.45x) and picture size, renders
the trays of held-out seeds (not used to choose the thresholds: those were seeds 0-4), grades
each picture and prints the pooled class accuracy with its 95 % Wilson interval, the confusion
matrix, the leaf-area error and the time to grade one picture (rendering excluded). Asserts
nothing. Headless: MUJOCO_GL=egl (or osmesa).

    MUJOCO_GL=egl python benchmarks/bench_vision.py [first_seed count]   (default 100 10)
"""

from __future__ import annotations

import sys

import numpy as np

from transplanter.studies.vision import grade_seed, pooled
from transplanter.vision.metrics import format_matrix


def main(argv: list[str]) -> int:
    first = int(argv[0]) if argv else 100
    count = int(argv[1]) if len(argv) > 1 else 10
    seeds = range(first, first + count)
    for width, height in ((1600, 900), (960, 540)):
        for lighting in ("default", "darker", "brighter"):
            trays = [grade_seed(s, width, height, lighting) for s in seeds]
            total = pooled(trays)
            times = np.array([t.grading.seconds for t in trays]) * 1000
            per_tray = [t.score.accuracy for t in trays]
            lo, hi = total.interval
            print(
                f"\n## {width}x{height}, {lighting} lighting, seeds {first}-{first + count - 1}: "
                f"{total.correct}/{total.cells} = {total.accuracy:.2%} "
                f"(95 % Wilson {lo:.2%}-{hi:.2%}); worst tray {min(per_tray):.2%}; leaf area "
                f"error {total.area_error_mean_mm2:+.1f} mm^2 mean, "
                f"{total.area_error_abs_mm2:.1f} mm^2 mean absolute; grading "
                f"{times.mean():.0f} ms mean, {times.max():.0f} ms max per picture\n"
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
