"""`transplanter grade`: a drawn 128-cell plug tray photographed by the plug_trays workcell's
camera and graded by seed 002's recognition pipeline; the picture, an overlay of the grid and
the classes, and a JSON of every cell's class beside its truth.

The scenario (default: the packaged delta_refill) gives the seedlings' draw, the imaging
station's draw, the picture's size and the pipeline's thresholds (its [vision] section, with
--set); its workcell must have the tray camera (`[workcell] kind = "plug_trays"`). `--size`,
`--lighting` and `--draw` override its picture size, light and seedling draw
(docs/vision.md)."""

from __future__ import annotations

import argparse
from pathlib import Path

from transplanter.cli.common import (
    EXIT_OUTPUT_FAILED,
    EXIT_REFUSED,
    OPTIONS,
    _err,
    _overrides,
    ascii_int,
)

PICTURE, OVERLAY, RESULTS = "tray.png", "overlay.png", "grading.json"
MAX_SIDE_PX = 4096
DEFAULT_SCENARIO = "delta_refill"  # the packaged scenario whose workcell has the tray camera
LIGHT_SCALES = {"darker": 0.55, "brighter": 1.45}  # ImagingDraw.darker() / brighter()


def register(sub) -> None:
    p = sub.add_parser(
        "grade",
        help="photograph a drawn plug tray and grade every cell from the picture (seed 002's "
        "vision); writes the picture, an overlay and a JSON of class and truth per cell",
    )
    p.add_argument(
        "scenario",
        nargs="?",
        default=None,
        help=f"scenario file or packaged name (default: {DEFAULT_SCENARIO}); its [vision] "
        "section gives the draws and thresholds",
    )
    p.add_argument("--scenario", dest="scenario_option", default=None, help="the same")
    p.add_argument("--set", **OPTIONS["--set"])
    p.add_argument(
        "--seed",
        type=ascii_int,
        default=None,
        help="the tray's seed (default: the scenario's scenario.seed, as `transplanter trial` "
        "takes it: the tray its job plants)",
    )
    p.add_argument("--out", type=Path, required=True, help="folder for the three files")
    p.add_argument(
        "--size",
        default=None,
        help="picture size WIDTHxHEIGHT in pixels (default: the scenario's, 1600x900)",
    )
    p.add_argument(
        "--lighting",
        choices=("default", "darker", "brighter"),
        default=None,
        help="the station's lighting: the scenario's vision.light_scale (default: drawn "
        "around the nominal) or fixed at 0.55x (darker) or 1.45x (brighter)",
    )
    p.add_argument(
        "--draw",
        choices=("default", "near_thresholds"),
        default=None,
        help="the seedlings (vision.seedling_draw): SeedlingDraw() (each kind clear of the "
        "thresholds) or SeedlingDraw.near_thresholds() (areas, centroids and secants across "
        "them)",
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


def _scenario(args: argparse.Namespace):
    """The scenario with --set and the picture options, or ScenarioError (also for a
    workcell without the tray camera)."""
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.scene import kinds

    if args.scenario and args.scenario_option and args.scenario != args.scenario_option:
        raise ScenarioError(
            f"two scenarios given ({args.scenario!r} and --scenario {args.scenario_option!r}): "
            "give one"
        )
    name = args.scenario or args.scenario_option or DEFAULT_SCENARIO
    overrides = _overrides(args)
    if args.size is not None:
        size = _size(args.size)
        if size is None:
            raise ScenarioError(
                f"--size {args.size!r}: give WIDTHxHEIGHT, each 64 to {MAX_SIDE_PX} px, "
                "e.g. 1600x900"
            )
        overrides["vision.image_width_px"], overrides["vision.image_height_px"] = size
    if args.lighting in LIGHT_SCALES:
        overrides["vision.light_scale"] = [LIGHT_SCALES[args.lighting]] * 2
    elif args.lighting == "default":
        overrides["vision.light_scale"] = [0.85, 1.15]
    if args.draw is not None:
        overrides["vision.seedling_draw"] = args.draw
    scenario = load_scenario(name, overrides)
    kind = scenario.workcell.kind
    camera = getattr(kinds.workcell(kind), "CAMERA", None)
    if camera is None:
        raise ScenarioError(
            f"scenario {scenario.name!r}: its workcell {kind!r} has no camera over a plug tray; "
            "grade needs [workcell] kind = 'plug_trays' (the imaging station's tray_camera), "
            f"e.g. the packaged {DEFAULT_SCENARIO}"
        )
    return scenario


def _unwritable(out: Path) -> str | None:
    """Why grade could not write its three files into the folder `out`, or None; checked
    before any work and creating nothing: a folder that exists must take each file (not a
    directory or a symbolic link in its place, a writable folder: `fileio.check_output`), one
    that does not must be makeable (its nearest existing parent a writable folder)."""
    from transplanter import fileio

    try:
        if out.is_dir():
            for name in (PICTURE, OVERLAY, RESULTS):
                try:
                    fileio.check_output(out / name, derived=True)
                except fileio.FileRefused as exc:
                    return f"--out: {exc}"
            return None
        if out.exists() or out.is_symlink():
            return f"--out {out}: exists and is not a folder; give a folder"
        parent = out.parent
        while not (parent.exists() or parent.is_symlink()):
            parent = parent.parent
        if not parent.is_dir():
            return f"--out {out} cannot be made: {parent} is not a folder"
        try:
            fileio.discard(fileio.temp_beside(parent / out.name))
        except OSError as exc:
            return f"--out {out} cannot be made: {parent} is not writable: {exc.strerror}"
    except OSError as exc:  # a parent that cannot be searched
        return f"--out {out}: {exc.strerror or exc}"
    return None


def cmd_grade(args: argparse.Namespace) -> int:
    from transplanter import fileio
    from transplanter.scenario.assemble import vision_config
    from transplanter.scenario.schema import ScenarioError, check_value
    from transplanter.scene.tray_camera import RenderFailed
    from transplanter.studies.vision import grade_seed
    from transplanter.vision.metrics import format_matrix
    from transplanter.vision.overlay import draw_overlay, png_bytes
    from transplanter.vision.pipeline import ImageUnusable

    try:
        scenario = _scenario(args)
    except ScenarioError as exc:
        _err(f"grade refused: {exc}")
        return EXIT_REFUSED
    try:
        if args.seed is not None:  # the seeds trial takes (-1 was a traceback)
            check_value("scenario.seed", args.seed)
    except ScenarioError as exc:
        _err(f"grade refused: --seed: {exc}")
        return EXIT_REFUSED
    seed = scenario.seed if args.seed is None else args.seed  # trial's tray by default
    vc = vision_config(scenario)
    size = (vc.width_px, vc.height_px)
    out: Path = args.out
    refused = _unwritable(out)  # before the picture is drawn, not after
    if refused is not None:
        _err(f"grade refused: {refused}")
        return EXIT_REFUSED
    try:
        graded = grade_seed(
            seed,
            size[0],
            size[1],
            seedlings=vc.seedlings,
            thresholds=vc.thresholds,
            imaging=vc.imaging,
            mount=vc.mount,
        )
    except RenderFailed as exc:
        _err(str(exc))
        return EXIT_REFUSED
    except ImageUnusable as exc:
        _err(f"the picture cannot be graded ({type(exc).__name__}): {exc}; no grading written")
        return EXIT_REFUSED
    s = graded.score
    payload = {
        "seed": seed,
        "scenario": scenario.name,
        "size": list(size),
        "lighting": args.lighting or "scenario",
        "light_scale": list(vc.imaging.light_scale),
        "draw": scenario.vision.seedling_draw,
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
            try:
                tmp.write_bytes(data)
            except BaseException:
                fileio.discard(tmp)  # a full disk leaves no cut-off temporary file
                raise
            fileio.commit(tmp, out / name, follow=False)
        fileio.write_json_atomic(out / RESULTS, payload, follow=False)
    except OSError as exc:
        _err(f"could not write the results into {out}: {exc}")
        return EXIT_OUTPUT_FAILED
    lo, hi = s.interval
    print(
        f"seed {seed}: {s.correct}/{s.cells} cells graded as their truth "
        f"({s.accuracy:.1%}, 95 % Wilson {lo:.1%}-{hi:.1%}); leaf area error "
        f"{s.area_error_mean_mm2:+.1f} mm^2 mean, {s.area_error_abs_mm2:.1f} mm^2 mean absolute; "
        f"{graded.grading.seconds * 1000:.0f} ms to grade the picture"
    )
    print(format_matrix(s.matrix))
    print(f"wrote {out / PICTURE}, {out / OVERLAY}, {out / RESULTS}")
    return 0
