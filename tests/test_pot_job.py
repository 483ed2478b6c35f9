"""The pot line's economies for every robot on it (transplanter.twin.pot_job and the
conveyor_tube workcell): resting pots sleep with `physics.sleep`, a long belt is a window of
live rows whose rows enter at each index, and the index's drawn error is the five-bar's, so
that the delta's and the serial arm's scenes cost what the five-bar's does."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

from transplanter.scenario.assemble import fuzzy_gripper_config, judge_config
from transplanter.scenario.schema import load_scenario
from transplanter.scene.effectors import fuzzy_gripper
from transplanter.scene.robots.delta import quiet_prefix_note
from transplanter.twin import delta_pots, serial_pots
from transplanter.twin.pot_job import PotJob, pot_line

SLEEP = int(mujoco.mjtEnableBit.mjENBL_SLEEP)


def _delta_scene(overrides: dict, seed: int = 1):
    sc = load_scenario("delta_pots", overrides)
    spec, line, _, pots = delta_pots.scene_spec(sc, seed)
    with quiet_prefix_note():
        model = spec.compile()
    return sc, model, line, pots


def _serial_scene(overrides: dict, seed: int = 1):
    sc = load_scenario("serial_arm_pots", overrides)
    spec, _, line = serial_pots._scene(sc, seed)
    with quiet_prefix_note():
        model = spec.compile()
    return sc, model, line


@pytest.mark.parametrize("sleep", [True, False])
def test_the_line_sleeps_its_resting_pots_under_every_robot(sleep):
    """`physics.sleep` is what the scene does under the delta and the serial arm, as under
    the five-bar (the workcell applies it, not the robot)."""
    _, model, _, _ = _delta_scene({"physics.sleep": sleep})
    assert bool(model.opt.enableflags & SLEEP) is sleep
    _, model, _ = _serial_scene({"physics.sleep": sleep})
    assert bool(model.opt.enableflags & SLEEP) is sleep


def test_resting_pots_fall_asleep_in_the_deltas_scene():
    """With sleep on, the 40 pots standing on the belt fall asleep within a second while the
    delta hangs at its power-on pose (their trees leave the solver); with it off none does."""
    for sleep, asleep in ((True, 40), (False, 0)):
        sc, model, line, _ = _delta_scene({"physics.sleep": sleep})
        data = mujoco.MjData(model)
        delta_pots.power_on(sc, model, data, fuzzy_gripper_config(sc))
        bodies = [model.body(f"pot_{r}_{c}").id for r in range(line.rows)
                  for c in range(line.cols)]  # fmt: skip
        trees = model.body_treeid[bodies]
        for _ in range(1000):
            mujoco.mj_step(model, data)
        assert int((data.tree_asleep[trees] >= 0).sum()) == asleep


def test_a_long_belt_is_a_window_of_live_rows_whose_rows_enter_at_each_index():
    """32 rows with `conveyor.live_rows = 12`: the delta's scene holds 12 rows of pot bodies
    (a body per pot would be 160); the job's index (`PotJob.index`) lets the rows that fit
    enter, as the five-bar's twin does, and starts the drive."""
    sc, model, line, pots = _delta_scene({"conveyor.rows": 32, "scenario.seedlings": 5})
    assert line.windowed and line.body_rows == 12
    names = {model.body(b).name for b in range(model.nbody)}
    assert sum(n.startswith("pot_") for n in names) == 12 * 5
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    scene = pot_line(model, line, pots, fuzzy_gripper.PARTS)
    loop = SimpleNamespace(model=model, data=data, after_step=[], k=0)
    job = PotJob(loop, scene, judge_config(sc), [(0.0, line.pickup_row_y_m)], 0.06, 5)
    window = scene.window
    assert window is not None and window.next_row == 12
    # the pickup row's pots parked (the judge's, on landing) free a row of slots
    for pot in range(5):
        window.release(data, pot)
    assert window.next_row == 13 and window.live().size == 60
    job.index(0.0, 0.6)
    assert window.indexes == 1 and job.conveyor.armed(data)


def test_the_index_error_is_the_five_bars_stream():
    """`conveyor.index_error_sd_mm` is read under every robot, drawn from the trial's seed
    on the stream the five-bar's twin draws it from: the same errors, index by index."""
    from transplanter.scene.conveyor import INDEX_ERROR_STREAM

    sc, model, line, pots = _delta_scene({"conveyor.index_error_sd_mm": 0.5})
    assert line.conveyor_index_error_sd_m == pytest.approx(0.0005)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    scene = pot_line(model, line, pots, fuzzy_gripper.PARTS)
    loop = SimpleNamespace(model=model, data=data, after_step=[], k=0)
    job = PotJob(loop, scene, judge_config(sc), [(0.0, line.pickup_row_y_m)], 0.06, 5, seed=7)
    drawn = []
    job.conveyor.start = lambda d, t, total, error_m=0.0: drawn.append(error_m)
    for _ in range(3):
        job.index(0.0, 0.6)
    expected = 0.0005 * np.random.default_rng((7, INDEX_ERROR_STREAM)).standard_normal(3)
    assert drawn == pytest.approx(expected.tolist(), abs=0.0)


@pytest.mark.parametrize("name", ["delta_pots", "serial_arm_pots"])
def test_the_trial_command_runs_the_line_asleep(name, tmp_path):
    """`trial --set physics.sleep=true` runs the delta's and the serial arm's pot jobs (it
    was refused while their scenes kept every body awake); the first pot lands."""
    import json

    from transplanter import cli

    out = tmp_path / "one.json"
    status = cli.main(["trial", name, "--seedlings", "1", "--quiet", "--set",
                       "physics.sleep=true", "--json", str(out)])  # fmt: skip
    assert status == 0
    d = json.loads(out.read_text())
    assert d["overrides"]["physics.sleep"] is True and d["outcomes"] == {"success": 1}


@pytest.mark.parametrize(("name", "camera"), [("delta_pots", "overview"),
                                              ("serial_arm_pots", "overview")])  # fmt: skip
def test_render_films_the_pot_job_and_writes_the_trials_json(name, camera, tmp_path):
    """`render delta_pots` and `render serial_arm_pots` run the pot job as `trial` does (the
    same JSON but wall time) and film it: a frame every 1/fps s of simulated time from the
    power-on state (viewing.loop_video.LoopVideo, an observer that changes nothing)."""
    import json
    import os
    import subprocess
    import sys

    iio = pytest.importorskip("imageio.v2")
    pytest.importorskip("imageio_ffmpeg")
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "egl"
    out, filmed, plain = tmp_path / "pot.mp4", tmp_path / "filmed.json", tmp_path / "plain.json"

    def run(*args):
        return subprocess.run([sys.executable, "-m", "transplanter.cli", *args], env=env,
                              capture_output=True, text=True, timeout=600)  # fmt: skip

    made = run(
        "render",
        name,
        "--seedlings",
        "1",
        "--out",
        str(out),
        "--json",
        str(filmed),
        "--width",
        "96",
        "--height",
        "72",
        "--fps",
        "2",
        "--camera",
        camera,
        "--quiet",
    )
    assert made.returncode == 0, made.stderr
    assert "video of the pot job written to" in made.stdout
    assert run("trial", name, "--seedlings", "1", "--json", str(plain),
               "--quiet").returncode == 0  # fmt: skip
    a, b = (json.loads(p.read_text()) for p in (filmed, plain))
    for d in (a, b):
        d.pop("wall_time_s"), d.pop("real_time_factor")
    assert a == b
    reader = iio.get_reader(out)
    try:
        frames = [f for f in reader]
    finally:
        reader.close()
    assert frames[0].shape == (72, 96, 3)
    assert abs(len(frames) - (math.floor(a["sim_time_s"] * 2) + 1)) <= 1


def test_export_writes_the_serial_arms_pot_scene_with_the_pots_decor(tmp_path, capsys):
    """`export serial_arm_pots` writes the trial's scene (the same bodies, joints,
    equalities and actuators, the arm on its pedestal, the station sensors) with the pots'
    decor drawn, meshes beside it; MuJoCo loads it; the viewer still refuses with its
    reason."""
    from transplanter import cli

    out = tmp_path / "pots.xml"
    assert cli.main(["export", "serial_arm_pots", str(out)]) == 0
    assert "scene of serial_arm_pots (seed 1) written to" in capsys.readouterr().out
    loaded = mujoco.MjModel.from_xml_path(str(out))
    sc = load_scenario("serial_arm_pots")
    drawn = serial_pots.scene_spec(sc, 1, decor=True)[0].compile()
    physics = serial_pots.scene_spec(sc, 1)[0].compile()
    sizes = lambda m: (m.nbody, m.njnt, m.neq, m.nu, m.ngeom, m.nmesh)  # noqa: E731
    assert sizes(loaded) == sizes(drawn)
    assert sizes(physics)[:4] == sizes(drawn)[:4] and physics.ngeom < drawn.ngeom
    assert loaded.geom("pedestal").id >= 0 and loaded.site("station_sensor_c0").id >= 0
    import xml.etree.ElementTree as ET

    files = {m.get("file") for m in ET.parse(out).getroot().iter("mesh") if m.get("file")}
    assert files and all((tmp_path / "assets" / Path(f).name).is_file() for f in files)
    assert cli.main(["view", "serial_arm_pots"]) == 2


def test_export_writes_the_deltas_pot_scene_with_the_pots_decor(tmp_path, capsys):
    """`export delta_pots` writes the trial's scene (the same bodies, joints, equalities and
    actuators) with the pots' decor drawn, meshes beside it; MuJoCo loads it."""
    from transplanter import cli

    out = tmp_path / "pots.xml"
    assert cli.main(["export", "delta_pots", str(out)]) == 0
    assert "scene of delta_pots (seed 1) written to" in capsys.readouterr().out
    loaded = mujoco.MjModel.from_xml_path(str(out))
    sc = load_scenario("delta_pots")
    with quiet_prefix_note():
        drawn = delta_pots.scene_spec(sc, 1, decor=True)[0].compile()
        physics = delta_pots.scene_spec(sc, 1)[0].compile()
    sizes = lambda m: (m.nbody, m.njnt, m.neq, m.nu, m.ngeom, m.nmesh)  # noqa: E731
    assert sizes(loaded) == sizes(drawn)
    assert sizes(physics)[:4] == sizes(drawn)[:4] and physics.ngeom < drawn.ngeom
    import xml.etree.ElementTree as ET

    files = {m.get("file") for m in ET.parse(out).getroot().iter("mesh") if m.get("file")}
    assert files and all((tmp_path / "assets" / Path(f).name).is_file() for f in files)


class _FakeViewer:
    """mujoco.viewer.launch_passive's handle, closed after `close_after` syncs (None: open
    until the run's end, then closed by the user)."""

    def __init__(self, close_after=None):
        self.cam = SimpleNamespace(type=None, fixedcamid=-1)
        self.syncs, self.texts, self.close_after, self.closed = 0, [], close_after, False
        self.times = []

    def __call__(self, model, data, **kw):
        self.data = data
        return self

    def is_running(self):
        if self.close_after is None:
            return self.texts[-1:] == [] or "finished" not in str(self.texts[-1])
        return self.syncs < self.close_after

    def set_texts(self, texts):
        self.texts.append(texts)

    def sync(self):
        self.syncs += 1
        self.times.append(float(self.data.time))

    def close(self):
        self.closed = True


@pytest.mark.parametrize("scenario", ["delta_pots", "serial_arm_pots"])
def test_view_shows_a_pot_job_live_with_the_trials_results(scenario, monkeypatch, capsys):
    """`view` of a pot job on the loop: the viewer synced as the physics runs (its clock
    moving on), the same results as `trial`, the last state held until the window closes."""
    import mujoco.viewer

    from transplanter import cli
    from transplanter.viewing import video

    fake = _FakeViewer()
    monkeypatch.setattr(video, "has_display", lambda: True)
    monkeypatch.setattr(mujoco.viewer, "launch_passive", fake)
    assert cli.main(["view", scenario, "--seedlings", "1", "--speed", "100"]) == 0
    out = capsys.readouterr().out
    assert "1/1 seedlings into the tube" in out
    assert fake.syncs >= 3 and fake.times == sorted(fake.times) and fake.times[-1] > 5.0
    assert "finished" in str(fake.texts[-1]) and fake.closed
    assert fake.cam.fixedcamid >= 0  # the overview camera


def test_closing_the_viewer_stops_the_pot_job(monkeypatch, capsys):
    import mujoco.viewer

    from transplanter import cli
    from transplanter.viewing import video

    fake = _FakeViewer(close_after=5)
    monkeypatch.setattr(video, "has_display", lambda: True)
    monkeypatch.setattr(mujoco.viewer, "launch_passive", fake)
    assert cli.main(["view", "delta_pots", "--seedlings", "2", "--speed", "100"]) == 0
    out = capsys.readouterr().out
    assert "viewer closed at t = " in out and "seedlings into the tube" not in out
    assert fake.closed and fake.syncs == 5
