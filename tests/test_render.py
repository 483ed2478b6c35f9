"""Videos of trials: `transplanter render`, `trial --clips-of-failures`, `view` without display.

Rendering runs in a subprocess with MUJOCO_GL=egl: MuJoCo picks its GL backend when it is
first imported, and this test process imported it without one."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import pytest

from transplanter import cli
from transplanter.twin.results import SeedlingRecord
from transplanter.viewing.video import _FrameClock, cycle_window, parse_indices, parse_size

iio = pytest.importorskip("imageio.v2")
pytest.importorskip("imageio_ffmpeg")


def _headless_env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "egl"
    env.update(extra)
    return env


def _transplanter(*args: str, env: dict[str, str] | None = None, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "transplanter.cli", *args],
        capture_output=True,
        text=True,
        env=env or _headless_env(),
        cwd=cwd,
        timeout=300,
    )


def _frames(path) -> list:
    reader = iio.get_reader(path)
    try:
        return [f for f in reader]  # list(reader) asks len(), which is inf for a stream
    finally:
        reader.close()


def _grid_frames(t0: float, t1: float, fps: float) -> int:
    """Frame times k / fps within [t0, t1]."""
    return math.floor(t1 * fps + 1e-9) - math.ceil(t0 * fps - 1e-9) + 1


def _without_wall_time(d: dict) -> dict:
    return {k: v for k, v in d.items() if k not in ("wall_time_s", "real_time_factor", "clips")}


@pytest.mark.slow
def test_render_writes_an_mp4_of_the_whole_trial(tmp_path):
    out, results = tmp_path / "clip.mp4", tmp_path / "r.json"
    run = _transplanter(
        "render", "paper", "--seedlings", "1", "--out", str(out), "--json", str(results),
        "--width", "160", "--height", "120", "--fps", "10", "--quiet",
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "video written to" in run.stdout
    frames = _frames(out)
    duration = json.loads(results.read_text())["sim_time_s"]
    assert abs(len(frames) - duration * 10) <= 1
    assert frames[0].shape == (120, 160, 3)
    assert not list(tmp_path.glob(".*.tmp"))  # the temporary file was moved into place


@pytest.mark.slow
def test_render_seedlings_of_films_only_that_cycle(tmp_path):
    out, results = tmp_path / "one.mp4", tmp_path / "r.json"
    run = _transplanter(
        "render", "paper", "--seedlings", "2", "--seedlings-of", "1", "--out", str(out),
        "--json", str(results), "--width", "160", "--height", "120", "--fps", "10", "--quiet",
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    d = json.loads(results.read_text())
    rec = d["per_seedling"][1]
    n = len(_frames(out))
    # a frame is taken at the first physics step at or after its time: one may fall out
    assert abs(n - _grid_frames(rec["t_start_s"], rec["t_release_s"] + 0.5, 10)) <= 1
    assert n < d["sim_time_s"] * 10 / 2  # far fewer than the whole trial's


@pytest.mark.slow
def test_clips_of_failures_one_clip_per_failure_and_the_same_results(tmp_path):
    """z_low 22 mm: the jaw tips strike the belt and every seedling fails."""
    clips, with_clips, without = tmp_path / "clips", tmp_path / "a.json", tmp_path / "b.json"
    common = ("trial", "paper", "--seedlings", "2", "--set", "taught.z_low_mm=22", "--quiet")
    run = _transplanter(*common, "--clips-of-failures", str(clips), "--json", str(with_clips))
    assert run.returncode == 0, run.stderr
    d = json.loads(with_clips.read_text())
    assert d["successes"] == 0
    expected = {f"seedling_{r['index']:03d}_{r['outcome']}.mp4" for r in d["per_seedling"]}
    assert {p.name for p in clips.iterdir()} == expected
    assert {os.path.basename(c["path"]) for c in d["clips"]} == expected
    for c in d["clips"]:
        frames = _frames(c["path"])
        assert len(frames) == c["frames"] and frames[0].shape == (240, 320, 3)
        rec = d["per_seedling"][c["seedling"]]
        assert abs(c["frames"] - _grid_frames(rec["t_start_s"], rec["t_release_s"] + 0.5, 15)) <= 1
    assert "failure clip(s) written" in run.stdout
    # rendering only reads the state: the same trial without clips gives the same results
    run = _transplanter(*common, "--json", str(without))
    assert run.returncode == 0, run.stderr
    assert _without_wall_time(d) == _without_wall_time(json.loads(without.read_text()))


@pytest.mark.slow
def test_clips_of_failures_writes_nothing_for_a_successful_trial(tmp_path):
    clips, results = tmp_path / "clips", tmp_path / "r.json"
    run = _transplanter(
        "trial", "paper", "--seedlings", "2", "--clips-of-failures", str(clips),
        "--json", str(results), "--clip-fps", "10", "--clip-size", "160x120", "--quiet",
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    d = json.loads(results.read_text())
    assert d["successes"] == 2 and d["clips"] == []
    assert list(clips.iterdir()) == []
    assert "no failure clips" in run.stdout


def test_render_without_a_gl_context_says_so(tmp_path):
    env = _headless_env(MUJOCO_GL="glfw")  # GLFW needs a display: none here
    run = _transplanter("render", "paper", "--seedlings", "1", "--out", str(tmp_path / "a.mp4"),
                        env=env)  # fmt: skip
    assert run.returncode == 2
    assert "no OpenGL context could be made" in run.stderr and "MUJOCO_GL=egl" in run.stderr
    assert not list(tmp_path.iterdir())  # no video, no temporary file


def test_view_without_a_display_exits_2(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.setattr(sys, "platform", "linux")
    assert cli.main(["view", "paper", "--seedlings", "1"]) == 2
    err = capsys.readouterr().err
    assert "no display" in err and "transplanter render" in err


@pytest.mark.parametrize(
    "args, message",
    [
        (["--width", "161"], "even number"),
        (["--fps", "0"], "frame rate above 0"),
        (["--fps", "2000"], "at most 240"),
        (["--seedlings", "2", "--seedlings-of", "5"], "seedling 5 is not in this trial"),
        (["--seedlings-of", "a"], "is not N or N-M"),
        (["--camera", "nosuch"], "no camera 'nosuch'"),
    ],
)
def test_render_refuses_bad_options(tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    out = tmp_path / "a.mp4"
    assert cli.main(["render", "paper", "--out", str(out), *args]) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_render_refuses_an_output_that_is_not_mp4(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    assert cli.main(["render", "paper", "--out", str(tmp_path / "a.avi")]) == 2
    assert "must end in .mp4" in capsys.readouterr().err


def test_video_commands_without_the_extra_name_it(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # import fails
    assert cli.main(["render", "paper", "--out", str(tmp_path / "a.mp4")]) == 2
    assert "pip install 'transplanter[video]'" in capsys.readouterr().err
    clips = ["trial", "paper", "--clips-of-failures", str(tmp_path / "c")]
    assert cli.main(clips) == 2
    assert "pip install 'transplanter[video]'" in capsys.readouterr().err
    assert cli.main([*clips, "--clip-size", "320by240"]) == 2
    assert not (tmp_path / "c").exists()  # nothing made for a refused command


def test_clips_of_failures_refuses_a_file_as_directory(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    (tmp_path / "f").write_text("")
    argv = ["trial", "paper", "--seedlings", "1", "--clips-of-failures", str(tmp_path / "f")]
    assert cli.main(argv) == 2
    assert "cannot hold the clips" in capsys.readouterr().err


def test_frame_clock_takes_one_frame_per_interval_on_the_step_grid():
    clock, dt = _FrameClock(30.0), 0.001
    taken = [k * dt for k in range(2001) if clock.due(k * dt)]
    assert len(taken) == math.floor(2.0 * 30) + 1
    assert all(abs(t - round(t * 30) / 30) < dt for t in taken)


def test_cycle_window_runs_from_first_line_to_release_plus_tail():
    recs = [SeedlingRecord(index=i, pickup=i) for i in range(3)]
    assert cycle_window(recs, 0) == (None, None)
    recs[0].t_start_s = 1.0
    assert cycle_window(recs, 0) == (1.0, None)
    recs[0].t_release_s = 4.0
    assert cycle_window(recs, 0) == (1.0, 4.5)
    recs[1].t_start_s, recs[2].t_start_s = 5.0, 9.0  # seedling 1 never released
    assert cycle_window(recs, 1) == (5.0, 9.0)


def test_size_and_index_lists():
    assert parse_size("320x240") == (320, 240)
    assert parse_indices("1,3-4", 5) == {1, 3, 4}


class _FakeHandle:
    def __init__(self, running_for: int) -> None:
        self.left, self.texts, self.synced, self.closed = running_for, [], 0, False

    def is_running(self) -> bool:
        self.left -= 1
        return self.left >= 0

    def set_texts(self, texts) -> None:
        self.texts.append(texts)

    def sync(self) -> None:
        self.synced += 1

    def close(self) -> None:
        self.closed = True


class _FakeScene:
    """Counts the mirrors of the physics state onto the decorated model the viewer draws."""

    def __init__(self) -> None:
        self.mirrored = 0

    def render_data(self, data):
        self.mirrored += 1
        return data


class _FakeTwin:
    time = 0.0
    data = None

    def __init__(self) -> None:
        self.scene = _FakeScene()


def test_live_viewer_paces_shows_the_verdicts_and_stops_when_closed(monkeypatch):
    import transplanter.viewing.live as live
    from transplanter.twin.results import Outcome

    clock = {"now": 0.0}
    monkeypatch.setattr(live.time, "perf_counter", lambda: clock["now"])
    monkeypatch.setattr(live.time, "sleep", lambda s: clock.__setitem__("now", clock["now"] + s))
    viewer = live.LiveViewer(speed=2.0)
    viewer.handle = _FakeHandle(running_for=2)
    viewer.records = [SeedlingRecord(index=i, pickup=i) for i in range(2)]
    viewer.records[0].outcome = Outcome.NOT_GRIPPED
    twin = _FakeTwin()
    twin.time = 1.0
    viewer.step(twin)
    assert clock["now"] == pytest.approx(0.5)  # 1 s simulated at 2x: half a second of wall
    left, right = viewer.handle.texts[-1][2:]
    assert "last verdict" in left and "0: not_gripped" in right and "1 / 2" in right
    twin.time = 2.0
    viewer.step(twin)
    assert twin.scene.mirrored == viewer.handle.synced == 2  # mirrored before each sync
    with pytest.raises(KeyboardInterrupt):  # the window was closed: the trial stops
        twin.time = 3.0
        viewer.step(twin)
    assert viewer.closed and viewer.closed_at == 3.0
    viewer.finish(twin, interrupted=True)
    assert viewer.handle.closed
