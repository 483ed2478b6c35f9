"""MuJoCo's offscreen renderer, tried once a process.

MuJoCo aborts the whole process (``libc++abi: __cxa_guard_acquire detected recursive
initialization``) when a second ``mujoco.Renderer`` is made after the first failed for want
of an OpenGL context: a sweep's worker that ran two picture-taking trials headless without
``MUJOCO_GL=egl`` died and took the process pool with it. Every renderer the package makes
comes from `renderer`, which remembers the first failure and raises it again without asking
MuJoCo."""

from __future__ import annotations

import os

import mujoco

__all__ = ["NoOffscreenGL", "offscreen_gl_error", "renderer"]

_FAILED: list[str] = []


class NoOffscreenGL(RuntimeError):
    """This process cannot make an OpenGL context for offscreen rendering."""


def renderer(model: mujoco.MjModel, height: int, width: int) -> mujoco.Renderer:
    """``mujoco.Renderer(model, height, width)``, or NoOffscreenGL naming the GL backend and
    MuJoCo's reason (and at once, without trying again, once a try failed here)."""
    if _FAILED:
        raise NoOffscreenGL(_FAILED[0])
    try:
        return mujoco.Renderer(model, height, width)
    except Exception as exc:  # FatalError, a GL backend's ImportError, EGL errors
        backend = os.environ.get("MUJOCO_GL", "") or "glfw (the default)"
        _FAILED.append(
            f"no OpenGL context could be made for offscreen rendering (MUJOCO_GL={backend}): {exc}"
        )
        raise NoOffscreenGL(_FAILED[0]) from None


def offscreen_gl_error() -> str | None:
    """None if this process can render offscreen, else why not: what a study asks before it
    hands picture-taking trials to its workers."""
    try:
        renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8).close()
    except NoOffscreenGL as exc:
        return str(exc)
    return None
