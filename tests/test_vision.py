"""Seedlings graded from pictures (transplanter.vision): rendered trays of seeds that were not
used to choose the thresholds are graded to >= 95 % of their cells; a blank or unreadable
picture raises a named error; `transplanter grade` writes the picture, the overlay and the JSON.

Rendering runs in a subprocess with MUJOCO_GL=egl (osmesa if EGL cannot make a context): MuJoCo
picks its GL backend when it is first imported, and this test process may have imported it
without one."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import cv2
import numpy as np
import pytest

from transplanter import cli
from transplanter.twin.results import wilson_interval as twin_wilson
from transplanter.vision import (
    CLASSES,
    GridNotFound,
    ImageUnusable,
    TrayNotFound,
    grade_tray,
)
from transplanter.vision.metrics import confusion, score, wilson_interval

# Seeds 0-4 chose the thresholds (docs/vision.md); these were not looked at.
HELD_OUT = (1000, 1001)
SIZE = "960x540"


def _grade_cli(seed: int, out, *extra: str, size: str | None = SIZE) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    run = None
    sized = ["--size", size] if size is not None else []
    for gl in ("egl", "osmesa"):
        env["MUJOCO_GL"] = gl
        run = subprocess.run(
            [sys.executable, "-m", "transplanter.cli", "grade", "--seed", str(seed),
             "--out", str(out), *sized, *extra],
            capture_output=True, text=True, env=env, timeout=300,
        )  # fmt: skip
        if run.returncode == 0 or "OpenGL" not in run.stderr:
            return run
    pytest.skip(f"no offscreen OpenGL here (egl, osmesa): {run.stderr.strip()[-300:]}")


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    out = {}
    for seed in HELD_OUT:
        folder = tmp_path_factory.mktemp(f"grade{seed}")
        run = _grade_cli(seed, folder)
        assert run.returncode == 0, run.stderr
        out[seed] = (folder, run)
    return out


def test_the_cli_writes_the_picture_the_overlay_and_every_cell(graded):
    folder, run = graded[HELD_OUT[0]]
    picture = cv2.imread(str(folder / "tray.png"))
    overlay = cv2.imread(str(folder / "overlay.png"))
    assert picture.shape == (540, 960, 3)
    assert overlay.ndim == 3 and overlay.shape[1] > overlay.shape[0]
    result = json.loads((folder / "grading.json").read_text())
    cells = result["cells"]
    assert len(cells) == 128 and [c["index"] for c in cells] == list(range(128))
    assert all(c["class"] in CLASSES and c["truth"] in CLASSES for c in cells)
    assert result["seed"] == HELD_OUT[0] and result["size"] == [960, 540]
    assert "cells graded as their truth" in run.stdout and "Wilson" in run.stdout
    assert sorted(p.name for p in folder.iterdir()) == ["grading.json", "overlay.png", "tray.png"]


@pytest.mark.parametrize("seed", HELD_OUT)
def test_held_out_trays_are_graded_to_95_percent(graded, seed):
    folder, _ = graded[seed]
    result = json.loads((folder / "grading.json").read_text())
    cells = result["cells"]
    accuracy = np.mean([c["class"] == c["truth"] for c in cells])
    assert accuracy >= 0.95, [c for c in cells if c["class"] != c["truth"]]
    assert result["score"]["accuracy"] == pytest.approx(accuracy)
    assert abs(result["score"]["area_error_mean_mm2"]) < 15.0
    assert result["grade_seconds"] < 5.0


def _regrade(folder, picture: np.ndarray) -> float:
    result = json.loads((folder / "grading.json").read_text())
    truth = [c["truth"] for c in result["cells"]]
    graded = grade_tray(picture).classes()
    return float(np.mean([a == b for a, b in zip(truth, graded, strict=True)]))


def test_a_turned_and_darkened_picture_is_still_graded(graded):
    folder, _ = graded[HELD_OUT[1]]
    picture = cv2.cvtColor(cv2.imread(str(folder / "tray.png")), cv2.COLOR_BGR2RGB)
    h, w = picture.shape[:2]
    turn = cv2.getRotationMatrix2D((w / 2, h / 2), 2.5, 1.0)
    turned = cv2.warpAffine(picture, turn, (w, h), borderValue=(18, 18, 18))
    assert _regrade(folder, turned) >= 0.95
    darker = (picture.astype(np.float32) * 0.6).astype(np.uint8)
    assert _regrade(folder, darker) >= 0.95


@pytest.mark.parametrize(
    "picture, error, message",
    [
        (np.zeros((540, 960, 3), np.uint8), ImageUnusable, "too dark"),
        (np.full((540, 960, 3), 128, np.uint8), ImageUnusable, "blank picture"),
        (np.full((540, 960, 3), 255, np.uint8), ImageUnusable, "blank picture"),
        (np.zeros((540, 960), np.uint8), ImageUnusable, "uint8 RGB"),
        (np.zeros((540, 960, 3), np.float32), ImageUnusable, "uint8 RGB"),
        (np.zeros((20, 30, 3), np.uint8), ImageUnusable, "too small"),
        ("tray.png", ImageUnusable, "not an image array"),
    ],
)
def test_a_blank_or_unreadable_picture_raises_a_named_error(picture, error, message):
    with pytest.raises(error, match=message):
        grade_tray(picture)


def test_noise_or_a_plain_rectangle_is_no_tray():
    rng = np.random.default_rng(0)
    noise = rng.integers(0, 256, (540, 960, 3), dtype=np.uint8)
    with pytest.raises(ImageUnusable):
        grade_tray(noise)
    square = np.full((540, 960, 3), 20, np.uint8)
    square[100:440, 300:640] = 200  # the right grey, the wrong shape
    with pytest.raises(TrayNotFound, match="aspect"):
        grade_tray(square)
    tray_shaped = np.full((540, 960, 3), 20, np.uint8)
    tray_shaped[100:400, 100:694] = 200  # a tray's outline with no cells in it
    with pytest.raises(GridNotFound, match="cell openings"):
        grade_tray(tray_shaped)


def test_confusion_and_wilson():
    truth = ["empty", "healthy", "healthy", "inferior"]
    graded = ["empty", "healthy", "healthy_lr", "inferior"]
    m = confusion(truth, graded)
    assert m.sum() == 4 and np.trace(m) == 3
    assert m[CLASSES.index("healthy"), CLASSES.index("healthy_lr")] == 1
    s = score(truth, graded, [0, 200, 210, 50], [0, 190, 230, 40])
    assert s.accuracy == 0.75
    assert s.area_error_mean_mm2 == pytest.approx((-10 + 20 - 10) / 3)
    for k, n in ((3, 4), (128, 128), (0, 10), (250, 256)):
        assert wilson_interval(k, n) == pytest.approx(twin_wilson(k, n))


def test_the_cli_refuses_a_bad_size(tmp_path, capsys):
    assert cli.main(["grade", "--out", str(tmp_path / "g"), "--size", "12x9"]) == 2
    assert "WIDTHxHEIGHT" in capsys.readouterr().err
    assert not (tmp_path / "g").exists()


def test_the_json_truth_is_the_draws_and_grading_is_repeatable(graded):
    from transplanter.scene.plug_tray import draw_tray

    folder, _ = graded[HELD_OUT[0]]
    cells = json.loads((folder / "grading.json").read_text())["cells"]
    assert [c["truth"] for c in cells] == draw_tray(HELD_OUT[0]).classes()
    picture = cv2.cvtColor(cv2.imread(str(folder / "tray.png")), cv2.COLOR_BGR2RGB)
    assert grade_tray(picture).classes() == grade_tray(picture.copy()).classes()
    assert grade_tray(picture).classes() == [c["class"] for c in cells]


def test_the_vision_package_never_imports_mujoco():
    code = (
        "import sys; sys.modules['mujoco'] = None\n"
        "import numpy as np\n"
        "import transplanter.vision, transplanter.vision.overlay, transplanter.vision.metrics\n"
        "from transplanter.vision import ImageUnusable, grade_tray\n"
        "try:\n"
        "    grade_tray(np.zeros((100, 100, 3), np.uint8))\n"
        "except ImageUnusable:\n"
        "    print('ok')\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.stdout.strip() == "ok", run.stderr


def test_grade_without_a_gl_context_says_so_and_writes_nothing(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "glfw"  # GLFW needs a display: none here
    out = tmp_path / "g"
    run = subprocess.run(
        [sys.executable, "-m", "transplanter.cli", "grade", "--out", str(out), "--size", "320x180"],
        capture_output=True, text=True, env=env, timeout=120,
    )  # fmt: skip
    assert run.returncode == 2, run.stderr
    assert "no OpenGL context" in run.stderr and "MUJOCO_GL=egl" in run.stderr
    assert not out.exists()


def test_the_vision_section_defaults_are_the_dataclasses():
    from transplanter.scenario.assemble import vision_config
    from transplanter.scenario.schema import load_scenario
    from transplanter.scene.plug_tray import SeedlingDraw
    from transplanter.scene.tray_camera import ImagingDraw
    from transplanter.vision.pipeline import CameraMount, VisionThresholds

    for name in ("delta_refill", "paper"):  # a file without [vision] takes the defaults
        vc = vision_config(load_scenario(name))
        assert vc.thresholds == VisionThresholds() and vc.imaging == ImagingDraw()
        assert vc.mount == CameraMount() and vc.seedlings == SeedlingDraw()
        assert (vc.width_px, vc.height_px) == (1600, 900)


def test_the_vision_keys_carry_their_units():
    from transplanter.scenario.assemble import vision_config
    from transplanter.scenario.schema import ScenarioError, load_scenario
    from transplanter.scene.plug_tray import SeedlingDraw

    vc = vision_config(load_scenario("delta_refill", {
        "vision.leaf_hue_band_deg": [60, 180], "vision.rectified_resolution_mm": 0.25,
        "vision.min_secant_mm": 11.0, "vision.core_radius_mm": 10.0, "vision.tray_shift_mm": 5,
        "vision.light_scale": [0.55, 0.55], "vision.seedling_draw": "near_thresholds",
        "vision.tray_yaw_deg": 1.5, "vision.camera_height_mm": 2500,
    }))  # fmt: skip
    th = vc.thresholds
    assert th.hue == (30, 90) and th.px_per_mm == pytest.approx(4.0)
    assert th.rule.min_secant_mm == pytest.approx(11.0)
    assert th.core_radius_mm == pytest.approx(10.0)
    assert vc.imaging.shift_mm == pytest.approx(5.0)
    assert vc.imaging.yaw_deg == pytest.approx(1.5) and vc.imaging.light_scale == (0.55, 0.55)
    assert vc.mount.height_mm == pytest.approx(2500.0)
    assert vc.seedlings == SeedlingDraw.near_thresholds()
    with pytest.raises(ScenarioError, match="vision.seedling_draw"):
        load_scenario("delta_refill", {"vision.seedling_draw": "hard"})
    with pytest.raises(ScenarioError, match="wrong unit"):
        load_scenario("delta_refill", {"vision.erode_m": 0.001})


def test_grade_refuses_a_scenario_without_a_camera(tmp_path, capsys):
    out = tmp_path / "g"
    assert cli.main(["grade", "paper", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "workcell 'conveyor_tube' has no camera" in err and "plug_trays" in err
    assert cli.main(["grade", "--scenario", "paper", "--out", str(out)]) == 2
    assert "has no camera" in capsys.readouterr().err
    assert cli.main(["grade", "paper", "--scenario", "delta_refill", "--out", str(out)]) == 2
    assert "two scenarios given" in capsys.readouterr().err
    assert cli.main(["grade", "--out", str(out), "--set", "vision.min_contrast=-1"]) == 2
    assert "vision.min_contrast" in capsys.readouterr().err
    assert not out.exists()


def test_grade_refuses_a_bad_seed_or_an_out_it_cannot_write_before_drawing(
    tmp_path, capsys, monkeypatch
):
    """`--seed=-1` ended in numpy's `expected non-negative integer` traceback (trial refuses
    it in one line); an --out that cannot take the files was found only after the picture
    was drawn and graded. Both are refused, exit 2, before anything is drawn, and nothing is
    created."""
    from transplanter.studies import vision as studies_vision

    def never(*args, **kwargs):  # pragma: no cover - a refusal draws nothing
        raise AssertionError("a picture was drawn")

    monkeypatch.setattr(studies_vision, "grade_seed", never)
    out = tmp_path / "g"

    def refused(*args: str) -> str:
        assert cli.main(["grade", *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, err
        return err[0]

    for seed in ("-1", str(2**63)):
        assert "--seed" in refused(f"--seed={seed}", "--out", str(out))
    assert "-1 is outside the allowed range" in refused("--seed=-1", "--out", str(out))
    assert not out.exists()
    for name in ("tray.png", "grading.json"):
        (out / name).mkdir(parents=True)
        assert f"{name} is a directory" in refused("--out", str(out))
        (out / name).rmdir()
    (out / "overlay.png").symlink_to(tmp_path / "elsewhere.png")  # a name grade derives
    assert "overlay.png is a symbolic link" in refused("--out", str(out))
    (out / "overlay.png").unlink()
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert "is not a folder" in refused("--out", str(blocker / "g"))
    assert "exists and is not a folder" in refused("--out", str(blocker))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "g"]
    assert list(out.iterdir()) == [] and blocker.read_text() == ""


def test_grade_looks_at_the_tray_trial_plants_by_default(tmp_path, capsys, monkeypatch):
    """grade's default seed was 0 and trial's the scenario's (1 in delta_refill): by default
    they looked at different trays. grade now takes scenario.seed as trial does."""
    from transplanter.scenario.schema import load_scenario
    from transplanter.scene.tray_camera import RenderFailed
    from transplanter.studies import vision as studies_vision

    seeds = []

    def noted(seed, *args, **kwargs):  # the seed it would draw; no picture needed
        seeds.append(seed)
        raise RenderFailed("no picture in this test")

    monkeypatch.setattr(studies_vision, "grade_seed", noted)
    own = tmp_path / "own.toml"
    own.write_text('[scenario]\nbase = "delta_refill"\nname = "own"\nseed = 7\n')
    out = str(tmp_path / "g")
    for argv in (
        [],
        [str(own)],
        ["--set", "scenario.seed=3"],
        ["--seed", "5"],
        [str(own), "--seed", "0"],
    ):
        assert cli.main(["grade", *argv, "--out", out]) == 2
    capsys.readouterr()
    assert load_scenario("delta_refill").seed == 1
    assert seeds == [1, 7, 3, 5, 0]


def test_grade_takes_the_draws_and_picture_from_a_scenario(tmp_path):
    from transplanter.scene.plug_tray import SeedlingDraw, draw_tray

    scenario = tmp_path / "hard.toml"
    scenario.write_text(
        '[scenario]\nbase = "delta_refill"\nname = "hard"\n\n'
        '[vision]\nseedling_draw = "near_thresholds"\nimage_width_px = 800\n'
        "image_height_px = 450\n"
    )
    out = tmp_path / "g"
    run = _grade_cli(HELD_OUT[0], out, str(scenario), size=None)
    assert run.returncode == 0, run.stderr
    result = json.loads((out / "grading.json").read_text())
    assert result["scenario"] == "hard" and result["draw"] == "near_thresholds"
    assert result["size"] == [800, 450]
    assert cv2.imread(str(out / "tray.png")).shape == (450, 800, 3)
    truth = draw_tray(HELD_OUT[0], SeedlingDraw.near_thresholds()).classes()
    assert [c["truth"] for c in result["cells"]] == truth


def test_a_blank_picture_by_the_scenario_yields_a_named_error_and_no_grading(tmp_path):
    out = tmp_path / "g"
    run = _grade_cli(HELD_OUT[0], out, "--set", "vision.min_contrast=200")
    assert run.returncode == 2, run.stderr
    assert "cannot be graded (ImageUnusable): blank picture" in run.stderr
    assert not (out / "grading.json").exists()


def test_the_leaves_reach_is_measured_within_a_millimetre(graded):
    from transplanter.scene.plug_tray import draw_tray
    from transplanter.twin.delta_grading import leaf_extents_mm

    folder, _ = graded[HELD_OUT[0]]
    tray = draw_tray(HELD_OUT[0])
    errors = []
    for c, t in zip(json.loads((folder / "grading.json").read_text())["cells"], tray.cells,
                    strict=True):  # fmt: skip
        if t.truth == "healthy":
            ex, ey = leaf_extents_mm(t, tray.geometry)
            errors += [c["reach_lr_mm"] - ex, c["reach_ud_mm"] - ey]
    assert len(errors) > 80 and float(np.mean(np.abs(errors))) < 1.0


def test_the_overlay_has_a_legend_of_every_class_the_borders_and_the_cross():
    from transplanter.vision import overlay

    band = overlay._legend(1132, with_truth=True)
    assert band.shape[1] == 1132 and (band == 255).mean() > 0.8  # a white band
    colours = {tuple(int(v) for v in px) for px in band.reshape(-1, 3)}
    for colour, _ in overlay.STYLE.values():  # each class's swatch, in its colour
        assert colour in colours
    assert (255, 255, 0) in colours and (255, 0, 0) in colours
    assert (255, 0, 0) not in {tuple(int(v) for v in px) for px in
                               overlay._legend(1132, with_truth=False).reshape(-1, 3)}  # fmt: skip
