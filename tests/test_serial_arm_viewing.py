"""Filming the serial arm's pick and place (viewing.serial_arm.SerialVideo, `render
serial_arm`): the scene's named cameras, an MP4 with a frame per 1 / fps s of the job, the
same numbers as the trial without it, and clear refusals (no OpenGL context, a camera or an
option the job has not).

Rendering runs in a subprocess with MUJOCO_GL=egl (MuJoCo picks its GL backend when it is
first imported, and this test process imported it without one); where no EGL context can be
made here, the rendering tests are skipped."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import mujoco
import pytest

from transplanter import cli
from transplanter.scenario.schema import load_scenario
from transplanter.scene import serial_scene
from transplanter.twin import serial_arm

SEED = 1
SETS = ["--set", "pool_to_belt.count=1"]
FPS = 5.0


def _numbers(result_dict: dict) -> str:
    return json.dumps({k: v for k, v in result_dict.items() if k != "wall_time_s"}, sort_keys=True)


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "egl"
    env.update(extra)
    return env


def _transplanter(*args: str, env: dict[str, str] | None = None):
    return subprocess.run(
        [sys.executable, "-m", "transplanter.cli", *args],
        capture_output=True,
        text=True,
        env=env or _env(),
        timeout=300,
    )


def test_the_pick_scene_has_the_overview_and_the_gripper_closeup():
    sc = load_scenario("serial_arm", {"pool_to_belt.count": 1})
    spec, cfg = serial_arm._scene(sc, "pool_to_belt", seed=SEED)
    model = serial_scene.compile_scene(spec)
    names = sorted(model.camera(i).name for i in range(model.ncam))
    assert names == ["gripper_closeup", "overview"]  # the workcell's own overview replaced
    closeup = model.camera("gripper_closeup")
    assert model.body(int(closeup.bodyid[0])).name == "gripper_mount"  # it rides on the gripper
    # the overview looks at the arm's base, the pool's station and the belt's place spot
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cam = model.camera("overview").id
    pos, mat = data.cam_xpos[cam], data.cam_xmat[cam].reshape(3, 3)
    from transplanter.scene.workcells import pool_to_belt

    for point in ((0, 0, 0.06), pool_to_belt.station_xyz(cfg.workcell),
                  pool_to_belt.place_xyz(cfg.workcell)):  # fmt: skip
        v = mat.T @ (point - pos)  # camera frame: it looks along -z
        half = math.radians(model.cam_fovy[cam] / 2)
        assert v[2] < 0 and abs(v[1] / v[2]) < math.tan(half)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    pytest.importorskip("imageio.v2")
    pytest.importorskip("imageio_ffmpeg")
    tmp = tmp_path_factory.mktemp("render")
    out, results = tmp / "pick.mp4", tmp / "r.json"
    run = _transplanter(
        "render", "serial_arm", "--seed", str(SEED), *SETS, "--out", str(out),
        "--json", str(results), "--width", "160", "--height", "120", "--fps", str(FPS),
        "--camera", "gripper_closeup", "--quiet",
    )  # fmt: skip
    if run.returncode == 2 and "no OpenGL context could be made" in run.stderr:
        pytest.skip(f"no EGL context here: {run.stderr.strip()}")
    return run, out, results, tmp


@pytest.mark.slow
def test_render_writes_an_mp4_of_the_pick_and_place(rendered):
    import imageio.v2 as iio

    run, out, results, tmp = rendered
    assert run.returncode == 0, run.stderr
    assert "video of the pick and place written to" in run.stdout
    reader = iio.get_reader(out)
    try:
        frames = [f for f in reader]  # list(reader) asks len(), which is inf for a stream
    finally:
        reader.close()
    assert frames[0].shape == (120, 160, 3)
    # a frame every 1 / fps s from the first step to the job's end: its one tomato's cycle
    # and the 2 s the job settles after its program
    (tomato,) = json.loads(results.read_text())["pick_place"]["tomatoes"]
    expected = math.floor((tomato["end_s"] + 2.0) * FPS) + 1
    assert abs(len(frames) - expected) <= 2
    assert f"{len(frames)} frames" in run.stdout
    assert not list(tmp.glob(".*"))  # no temporary file left


@pytest.mark.slow
def test_the_video_leaves_the_trials_numbers_unchanged(rendered):
    run, _, results, _ = rendered
    assert run.returncode == 0, run.stderr
    sc = load_scenario("serial_arm", {"pool_to_belt.count": 1})
    plain = serial_arm.run_serial_arm(sc, SEED)
    assert _numbers(json.loads(results.read_text())) == _numbers(
        json.loads(json.dumps(plain.to_dict()))
    )


def test_render_without_a_gl_context_says_so(tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    run = _transplanter(
        "render", "serial_arm", *SETS, "--out", str(tmp_path / "a.mp4"), env=_env(MUJOCO_GL="glfw")
    )  # fmt: skip  GLFW needs a display
    assert run.returncode == 2
    assert "render refused: no OpenGL context could be made" in run.stderr
    assert "MUJOCO_GL=egl" in run.stderr and "osmesa" in run.stderr
    assert not list(tmp_path.iterdir())  # no video, no temporary file


def test_render_refusals_name_the_problem(tmp_path, monkeypatch, capsys):
    pytest.importorskip("imageio_ffmpeg")
    monkeypatch.setenv("MUJOCO_GL", "egl")
    out = tmp_path / "x.mp4"
    base = ["render", "serial_arm", *SETS, "--out", str(out)]
    assert cli.main([*base, "--camera", "funnel"]) == 2
    err = capsys.readouterr().err
    assert "no camera 'funnel'" in err and "gripper_closeup" in err
    for option in ("--cells-of", "--seedlings-of"):
        assert cli.main([*base, option, "0"]) == 2
        assert f"render refused: {option}" in capsys.readouterr().err
    assert not out.exists() and not list(tmp_path.glob(".*"))
