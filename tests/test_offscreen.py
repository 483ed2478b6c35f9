"""transplanter.scene.offscreen: MuJoCo's offscreen renderer is asked for once a process; a
failed try is raised again without asking MuJoCo (whose second try aborts the process)."""

import pytest

from transplanter.scene import offscreen


@pytest.fixture
def no_gl(monkeypatch):
    calls = []

    def failing(model, height, width):
        calls.append((height, width))
        raise RuntimeError("an OpenGL platform library has not been loaded into this process")

    monkeypatch.setattr(offscreen, "_FAILED", [])
    monkeypatch.setattr(offscreen.mujoco, "Renderer", failing)
    monkeypatch.setenv("MUJOCO_GL", "glfw")
    return calls


def test_a_failed_try_is_remembered_and_never_repeated(no_gl):
    model = offscreen.mujoco.MjModel.from_xml_string("<mujoco/>")
    with pytest.raises(offscreen.NoOffscreenGL, match=r"MUJOCO_GL=glfw\): an OpenGL platform"):
        offscreen.renderer(model, 8, 8)
    for _ in range(3):
        with pytest.raises(offscreen.NoOffscreenGL, match="MUJOCO_GL=glfw"):
            offscreen.renderer(model, 16, 16)
    assert no_gl == [(8, 8)]
    assert "MUJOCO_GL=glfw" in offscreen.offscreen_gl_error()
    assert no_gl == [(8, 8)]


def test_the_tray_camera_and_the_video_say_what_to_set(no_gl):
    from transplanter.scene.plug_tray import draw_tray
    from transplanter.scene.tray_camera import RenderFailed, draw_appearance, render_tray
    from transplanter.viewing.video import FrameGrabber, GLUnavailable

    tray = draw_tray(1)
    with pytest.raises(RenderFailed, match="headless, use MUJOCO_GL=egl"):
        render_tray(tray, draw_appearance(1), 64, 36)
    model = offscreen.mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><camera name='c'/></worldbody></mujoco>"
    )
    with pytest.raises(GLUnavailable, match="Headless, use MUJOCO_GL=egl"):
        FrameGrabber(model, 64, 36, "c")
    assert len(no_gl) == 1


def _headless_env() -> dict[str, str]:
    import os

    drop = ("MUJOCO_GL", "DISPLAY", "WAYLAND_DISPLAY", "PYOPENGL_PLATFORM")
    return {k: v for k, v in os.environ.items() if k not in drop}


def test_the_command_line_picks_the_machines_offscreen_backend_when_headless():
    """Headless with MUJOCO_GL unset, every command runs with the backend this machine has
    (EGL where libEGL is installed, else OSMesa): `trial delta_refill` photographs its trays
    on a server as `render` films, with no variable to set first."""
    import ctypes.util
    import subprocess
    import sys

    want = ("egl" if ctypes.util.find_library("EGL") else
            "osmesa" if ctypes.util.find_library("OSMesa") else "None")  # fmt: skip
    code = ("import os, sys; from transplanter.cli import main; main(['scenarios']); "
            "print(os.environ.get('MUJOCO_GL'), 'mujoco' in sys.modules)")  # fmt: skip
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=_headless_env(), timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert run.stdout.split()[-2] == want
    mine = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**_headless_env(), "MUJOCO_GL": "osmesa"}, timeout=120)  # fmt: skip
    assert mine.stdout.split()[-2] == "osmesa"  # a user's choice is kept


def test_a_picture_taking_trial_renders_headless_with_nothing_set(tmp_path):
    """The user's path on a server: `transplanter trial delta_refill` with no MUJOCO_GL
    grades its trays from the camera's pictures (skipped where the machine has no offscreen
    GL at all)."""
    import ctypes.util
    import json
    import subprocess
    import sys

    if not (ctypes.util.find_library("EGL") or ctypes.util.find_library("OSMesa")):
        pytest.skip("no offscreen GL library on this machine")
    out = tmp_path / "r.json"
    cmd = [sys.executable, "-m", "transplanter.cli", "trial", "delta_refill", "--seedlings",
           "1", "--json", str(out), "--quiet"]  # fmt: skip
    run = subprocess.run(cmd, capture_output=True, text=True, env=_headless_env(), timeout=900)
    assert run.returncode == 0, run.stderr[-1500:]
    result = json.loads(out.read_text())
    assert result["vision"] == "pipeline" and len(result["cells"]) == 1
