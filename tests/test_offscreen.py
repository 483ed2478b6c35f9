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
