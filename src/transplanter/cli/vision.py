"""`transplanter grade`: a drawn 128-cell plug tray photographed by the plug_trays workcell's
camera and graded by seed 002's recognition pipeline; the picture, an overlay of the grid and
the classes, and a JSON of every cell's class beside its truth.

No scenario yet: the tray, its seedlings and the imaging station are drawn from `--seed` with
the defaults of `SeedlingDraw` and `ImagingDraw`; `--size` and `--lighting` choose the picture,
`--draw` the seedlings' draw, the thresholds are `VisionThresholds()`'s (docs/vision.md)."""

from __future__ import annotations

import argparse
from pathlib import Path

from transplanter.cli.common import EXIT_OUTPUT_FAILED, EXIT_REFUSED, _err, ascii_int

PICTURE, OVERLAY, RESULTS = "tray.png", "overlay.png", "grading.json"
MAX_SIDE_PX = 4096


def register(sub) -> None:
    p = sub.add_parser(
        "grade",
        help="photograph a drawn plug tray and grade every cell from the picture (seed 002's "
        "vision); writes the picture, an overlay and a JSON of class and truth per cell",
    )
    p.add_argument("--seed", type=ascii_int, default=0, help="the tray's seed (default: 0)")
    p.add_argument("--out", type=Path, required=True, help="folder for the three files")
    p.add_argument(
        "--size",
        default="1600x900",
        help="picture size WIDTHxHEIGHT in pixels (default: 1600x900)",
    )
    p.add_argument(
        "--lighting",
        choices=("default", "darker", "brighter"),
        default="default",
        help="the station's lighting: drawn around the nominal (default) or fixed at 0.55x "
        "(darker) or 1.45x (brighter)",
    )
    p.add_argument(
        "--draw",
        choices=("default", "near_thresholds"),
        default="default",
        help="the seedlings: SeedlingDraw() (each kind clear of the thresholds) or "
        "SeedlingDraw.near_thresholds() (areas, centroids and secants across them)",
    )
    p.set_defaults(func=cmd_grade)


def _size(text: str) -> tuple[int, int] | None:
    w, x, h = text.lower().partition("x")
    if not (x and w.isascii() and h.isascii() and w.isdigit() and h.isdigit()):
        return None
    width, height = int(w), int(h)
    if not (64 <= width <= MAX_SIDE_PX and 64 <= height <= MAX_SIDE_PX):
        return None
    return width, height


def cmd_grade(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.scene.plug_tray import SeedlingDraw
    from transplanter.scene.tray_camera import RenderFailed
    from transplanter.studies.vision import grade_seed
    from transplanter.vision.metrics import format_matrix
    from transplanter.vision.overlay import draw_overlay, png_bytes
    from transplanter.vision.pipeline import ImageUnusable

    size = _size(args.size)
    if size is None:
        _err(f"--size {args.size!r}: give WIDTHxHEIGHT, each 64 to {MAX_SIDE_PX} px, e.g. 1600x900")
        return EXIT_REFUSED
    out: Path = args.out
    if out.exists() and not out.is_dir():
        _err(f"--out {out}: exists and is not a folder")
        return EXIT_REFUSED
    try:
        seedlings = SeedlingDraw.near_thresholds() if args.draw == "near_thresholds" else None
        graded = grade_seed(args.seed, size[0], size[1], args.lighting, seedlings)
    except RenderFailed as exc:
        _err(str(exc))
        return EXIT_REFUSED
    except ImageUnusable as exc:
        _err(f"the picture cannot be graded: {exc}")
        return EXIT_REFUSED
    s = graded.score
    payload = {
        "seed": args.seed,
        "size": list(size),
        "lighting": args.lighting,
        "draw": args.draw,
        "appearance": graded.appearance.as_dict(),
        "tilt_deg": round(graded.grading.tilt_deg, 4),
        "grade_seconds": round(graded.grading.seconds, 4),
        "render_seconds": round(graded.render_seconds, 4),
        "score": s.as_dict(),
        "cells": graded.cells(),
    }
    try:
        out.mkdir(parents=True, exist_ok=True)
        for name, data in (
            (PICTURE, png_bytes(graded.picture)),
            (OVERLAY, png_bytes(draw_overlay(graded.grading, graded.tray.classes()))),
        ):
            tmp = fileio.temp_beside(out / name)
            tmp.write_bytes(data)
            fileio.commit(tmp, out / name, follow=False)
        fileio.write_json_atomic(out / RESULTS, payload, follow=False)
    except OSError as exc:
        _err(f"could not write the results into {out}: {exc}")
        return EXIT_OUTPUT_FAILED
    lo, hi = s.interval
    print(
        f"seed {args.seed}: {s.correct}/{s.cells} cells graded as their truth "
        f"({s.accuracy:.1%}, 95 % Wilson {lo:.1%}-{hi:.1%}); leaf area error "
        f"{s.area_error_mean_mm2:+.1f} mm^2 mean, {s.area_error_abs_mm2:.1f} mm^2 mean absolute; "
        f"{graded.grading.seconds * 1000:.0f} ms to grade the picture"
    )
    print(format_matrix(s.matrix))
    print(f"wrote {out / PICTURE}, {out / OVERLAY}, {out / RESULTS}")
    return 0
