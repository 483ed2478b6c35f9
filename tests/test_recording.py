"""Recording a trial to .rrd and reading it back (viewing.recording, viewing.playback)."""

from __future__ import annotations

import math
import os
import re

import mujoco
import numpy as np
import pytest
import rerun as rr

from transplanter.viewing.playback import read_summary, replay
from transplanter.viewing.recording import RecordingConfig, TrialRecorder

MJCF = """
<mujoco>
  <option timestep="0.001"/>
  <asset>
    <mesh name="wedge" vertex="0 0 0  0.04 0 0  0 0.04 0  0 0 0.04"/>
    <material name="red" rgba="0.9 0.1 0.1 1"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.1" rgba="0.8 0.8 0.8 1"/>
    <geom name="hidden_collider" type="sphere" size="0.05" pos="1 1 1" group="3"/>
    <geom name="invisible" type="sphere" size="0.05" pos="1 1 1" rgba="1 1 1 0"/>
    <body name="post" pos="0.3 0 0.1">
      <geom name="post_cyl" type="cylinder" size="0.02 0.1" material="red"/>
    </body>
    <body name="box" pos="0 0 0.5">
      <freejoint/>
      <geom name="box_geom" type="box" size="0.03 0.02 0.01" rgba="0.1 0.6 0.1 1"/>
    </body>
    <body name="arm" pos="-0.3 0 0.3">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.01"/>
      <geom name="link" type="capsule" fromto="0 0 0 0.2 0 0" size="0.015"/>
      <geom type="mesh" mesh="wedge" pos="0.2 0 0"/>
      <body name="ball" pos="0.2 0 0.05">
        <geom name="ball_geom" type="ellipsoid" size="0.02 0.03 0.01" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

DURATION_S = 2.0
RATE_HZ = 60.0
SCALARS = ("motors/theta1", "motors/theta2", "gripper/angle")


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(MJCF)


def _run_trial(model, path, **kwargs):
    """Step 2 s at 1 ms with frame() at every step, 2 grasps and 2 releases."""
    data = mujoco.MjData(model)
    data.qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "hinge")]] = 0.3
    mujoco.mj_forward(model, data)
    events = {0.4: "grasp", 0.9: "release", 1.2: "grasp", 1.7: "release"}
    with TrialRecorder(model, path, rate_hz=RATE_HZ, scalar_names=SCALARS, **kwargs) as rec:
        rec.frame(data.time, data, np.array([0.0, 0.0, 0.0]))
        n_steps = round(DURATION_S / model.opt.timestep)
        for _ in range(n_steps):
            mujoco.mj_step(model, data)
            rec.frame(data.time, data, np.array([data.qpos[7], math.sin(data.time), data.time]))
            for t_event, kind in events.items():
                if abs(data.time - t_event) < 0.5 * model.opt.timestep:
                    rec.event(data.time, kind, f"{kind} at {t_event}", seedling=3)
    return rec, data


@pytest.fixture(scope="module")
def trial(model, tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "trial.rrd"
    rec, data = _run_trial(model, path)
    return path, rec, data, read_summary(path)


def test_file_is_complete_and_written_atomically(trial):
    path, rec, _, summary = trial
    assert path.is_file() and path.stat().st_size > 0
    assert not path.with_name(path.name + ".tmp").exists()
    assert rec.closed
    assert summary["application_id"] == "transplanter"
    assert summary["has_blueprint"]
    assert summary["blueprint_views"] == [
        ("3D", "world"),
        ("TextLog", "events"),
        ("TimeSeries", "scalars/gripper"),
        ("TimeSeries", "scalars/motors"),
    ]


def test_static_geometry_for_every_visible_geom(trial):
    _, _, _, summary = trial
    static = summary["static_components"]
    expected_shapes = {
        "world/bodies/world/floor": "Boxes3D:half_sizes",
        "world/bodies/post/post_cyl": "Cylinders3D:radii",
        "world/bodies/box/box_geom": "Boxes3D:half_sizes",
        "world/bodies/arm/link": "Capsules3D:radii",
        "world/bodies/arm/geom_6": "Mesh3D:vertex_positions",
        "world/bodies/ball/ball_geom": "Ellipsoids3D:half_sizes",
    }
    for entity, component in expected_shapes.items():
        assert component in static[entity], (entity, static.get(entity))
        assert "Transform3D:quaternion" in static[entity]
    assert "Mesh3D:vertex_normals" in static["world/bodies/arm/geom_6"]
    geom_entities = {e for e in summary["entity_paths"] if e.count("/") == 3}
    assert geom_entities == set(expected_shapes)  # group 3 and alpha 0 geoms are left out


def test_moving_bodies_have_poses_on_sim_time_static_bodies_do_not(trial):
    _, rec, _, summary = trial
    n_frames = rec.n_frames
    assert abs(n_frames - (DURATION_S * RATE_HZ + 1)) <= 1
    for body in ("box", "arm", "ball"):
        entity = f"world/bodies/{body}"
        assert {"Transform3D:translation", "Transform3D:quaternion"} <= set(
            summary["temporal_components"][entity]
        )
        assert summary["rows_on_sim_time"][entity] == n_frames
    for body in ("world", "post"):
        entity = f"world/bodies/{body}"
        assert entity not in summary["temporal_components"]
        assert "Transform3D:translation" in summary["static_components"][entity]


def test_time_range_matches_simulated_time(trial):
    _, _, data, summary = trial
    t_min, t_max = summary["sim_time_range"]
    assert t_min == pytest.approx(0.0, abs=1e-9)
    assert data.time == pytest.approx(DURATION_S, abs=1e-9)
    assert DURATION_S - 1.0 / RATE_HZ <= t_max <= DURATION_S + 1e-9


def test_scalar_channels_and_events(trial):
    _, rec, _, summary = trial
    assert summary["scalar_channels"] == sorted(SCALARS)
    for name in SCALARS:
        assert summary["rows_on_sim_time"][f"scalars/{name}"] == rec.n_frames
    assert summary["events"] == {"grasp": 2, "release": 2}
    assert rec.event_counts == {"grasp": 2, "release": 2}
    assert summary["rows_on_sim_time"]["events"] == 4


def test_frames_fall_on_the_rate_grid(model, tmp_path):
    data = mujoco.MjData(model)
    rec = TrialRecorder(model, tmp_path / "grid.rrd", rate_hz=50.0)
    recorded = []
    for _ in range(1000):
        mujoco.mj_step(model, data)
        if rec.due(data.time):
            recorded.append(data.time)
        rec.frame(data.time, data)
    rec.close()
    # First frame at the first call (t = 1 ms), then one per 20 ms grid slot up to 1 s.
    assert len(recorded) == rec.n_frames == 51
    assert recorded[0] == pytest.approx(0.001)
    np.testing.assert_allclose(recorded[1:], 0.02 * np.arange(1, 51), atol=1e-9)


def _last_value(path, entity, component, static):
    """The last row of one component of one entity, read with rerun's reader."""
    stream = rr.chunk.RrdReader(path).store().stream().filter(is_static=static)
    chunks = [c for c in stream if c.entity_path == "/" + entity]
    column = chunks[-1].to_record_batch().column(component).to_pylist()
    return np.array(column[-1])


def test_recorded_poses_and_geometry_match_mujoco(model, tmp_path):
    data = mujoco.MjData(model)
    path = tmp_path / "pose.rrd"
    with TrialRecorder(model, path, rate_hz=10.0, blueprint=False) as rec:
        for _ in range(300):
            mujoco.mj_step(model, data)
            rec.frame(data.time, data)
    # Frames at t = 1 ms, 0.1, 0.2, 0.3 s: the last one is the final state of data.
    assert rec.n_frames == 4
    assert not read_summary(path)["has_blueprint"]
    body_ids = {b: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in ("box", "arm")}
    for body, body_id in body_ids.items():
        entity = f"world/bodies/{body}"
        position = _last_value(path, entity, "Transform3D:translation", static=False)[0]
        xyzw = _last_value(path, entity, "Transform3D:quaternion", static=False)[0]
        np.testing.assert_allclose(position, data.xpos[body_id], atol=1e-6)
        np.testing.assert_allclose(xyzw, data.xquat[body_id][[1, 2, 3, 0]], atol=1e-6)
    assert data.xpos[body_ids["box"]][2] < 0.4  # the box fell: a moved pose was compared
    assert abs(data.xquat[body_ids["arm"]][0]) < 0.999  # the arm swung: a rotation was compared

    link = "world/bodies/arm/link"  # capsule from 0 to 0.2 m along x, radius 15 mm
    np.testing.assert_allclose(
        _last_value(path, link, "Capsules3D:translations", static=True)[0], [0, 0, -0.1]
    )
    np.testing.assert_allclose(_last_value(path, link, "Capsules3D:lengths", static=True), [0.2])
    np.testing.assert_allclose(
        _last_value(path, link, "Transform3D:translation", static=True)[0], [0.1, 0, 0], atol=1e-9
    )
    mesh = "world/bodies/arm/geom_6"  # a tetrahedron: 4 faces, one vertex per face corner
    vertices = _last_value(path, mesh, "Mesh3D:vertex_positions", static=True)
    assert len(vertices) == 12
    post_colour = _last_value(path, "world/bodies/post/post_cyl", "Cylinders3D:colors", True)
    assert int(post_colour[0]) == 0xE61A1AFF  # the material's rgba 0.9 0.1 0.1 1


def test_flushes_in_batches_without_losing_frames(model, tmp_path):
    data = mujoco.MjData(model)
    path = tmp_path / "batched.rrd"
    config = RecordingConfig(flush_frames=7)
    with TrialRecorder(model, path, rate_hz=100.0, config=config) as rec:
        for _ in range(500):
            mujoco.mj_step(model, data)
            rec.frame(data.time, data)
    summary = read_summary(path)
    assert rec.n_frames == 51  # t = 1 ms, then 10 ms .. 500 ms
    assert summary["rows_on_sim_time"]["world/bodies/box"] == 51
    assert summary["sim_time_range"] == pytest.approx((0.001, 0.5))


def test_close_is_idempotent_and_blocks_further_frames(model, tmp_path):
    data = mujoco.MjData(model)
    rec = TrialRecorder(model, tmp_path / "twice.rrd")
    rec.frame(0.0, data)
    rec.close()
    size = (tmp_path / "twice.rrd").stat().st_size
    rec.close()
    assert (tmp_path / "twice.rrd").stat().st_size == size
    with pytest.raises(RuntimeError, match="closed"):
        rec.frame(1.0, data)
    with pytest.raises(RuntimeError, match="closed"):
        rec.event(1.0, "grasp", "late")


def test_two_recordings_coexist(model, tmp_path):
    data = mujoco.MjData(model)
    first = TrialRecorder(model, tmp_path / "a.rrd", scalar_names=["x"])
    second = TrialRecorder(model, tmp_path / "b.rrd", scalar_names=["y", "z"])
    for _ in range(100):
        mujoco.mj_step(model, data)
        first.frame(data.time, data, [1.0])
        second.frame(data.time, data, [2.0, 3.0])
    second.close()
    first.close()
    assert read_summary(tmp_path / "a.rrd")["scalar_channels"] == ["x"]
    assert read_summary(tmp_path / "b.rrd")["scalar_channels"] == ["y", "z"]


def test_bad_input_is_rejected(model, tmp_path):
    data = mujoco.MjData(model)
    with pytest.raises(ValueError, match=r"\.rrd"):
        TrialRecorder(model, tmp_path / "trial.txt")
    with pytest.raises(FileNotFoundError, match="does not exist"):
        TrialRecorder(model, tmp_path / "missing_dir" / "trial.rrd")
    with pytest.raises(ValueError, match="rate_hz"):
        TrialRecorder(model, tmp_path / "r.rrd", rate_hz=0.0)
    with pytest.raises(ValueError, match="unique"):
        TrialRecorder(model, tmp_path / "r.rrd", scalar_names=["a", "a"])
    with pytest.raises(ValueError, match="path like"):
        TrialRecorder(model, tmp_path / "r.rrd", scalar_names=["motors//x"])
    rec = TrialRecorder(model, tmp_path / "r.rrd", scalar_names=["a", "b"])
    with pytest.raises(ValueError, match="expected 2"):
        rec.frame(0.0, data, [1.0])
    with pytest.raises(ValueError, match="needs scalars"):
        rec.frame(0.0, data)
    rec.frame(0.5, data, [1.0, 2.0])
    with pytest.raises(ValueError, match="new TrialRecorder"):
        rec.frame(0.1, data, [1.0, 2.0])
    with pytest.raises(ValueError, match="kind"):
        rec.event(0.6, "", "no kind")
    rec.close()


def test_disabled_rerun_is_an_error_not_an_empty_file(model, tmp_path, monkeypatch):
    monkeypatch.setenv("RERUN", "off")
    with pytest.raises(RuntimeError, match="RERUN"):
        TrialRecorder(model, tmp_path / "off.rrd")
    assert not list(tmp_path.iterdir())


# Starts a recorder with no byte left to write (a file-size limit of 0 on this child process:
# a full disk, as the write calls see it) and prints what it raised.
_FULL_DISK = (
    "import resource, signal, sys\n"
    "import mujoco\n"
    "from transplanter.viewing.recording import RecordingError, TrialRecorder\n"
    "model = mujoco.MjModel.from_xml_string(sys.argv[1])\n"
    "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
    "resource.setrlimit(resource.RLIMIT_FSIZE, (0, resource.RLIM_INFINITY))\n"
    "try:\n"
    "    TrialRecorder(model, sys.argv[2])\n"
    "except RecordingError as exc:\n"
    "    print(exc)\n"
)


def test_a_recording_that_cannot_be_started_says_why_and_leaves_no_file(tmp_path):
    """On a full disk rerun's save raised a RuntimeError out of TrialRecorder (a traceback
    from `trial --record`) and left its .rrd.*.tmp file; now a RecordingError, nothing left."""
    import subprocess
    import sys

    rrd = tmp_path / "full.rrd"
    run = subprocess.run(
        [sys.executable, "-c", _FULL_DISK, MJCF, str(rrd)],
        capture_output=True,
        text=True,
        timeout=120,  # a bound, not a clock: it ends in about a second
    )
    assert run.returncode == 0, run.stderr
    assert f"the recording {str(rrd)!r} could not be written" in run.stdout
    assert "File too large" in run.stdout  # the write's own error, as rerun reports it
    assert not list(tmp_path.iterdir())


def test_replay_without_display_explains_how_to_view(trial, monkeypatch, capsys):
    path = trial[0]
    monkeypatch.setattr("sys.platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert replay(path) == 2
    message = capsys.readouterr().err
    assert "no display" in message
    assert f"rerun {path.name}" in message
    assert "--serve-web" in message


def test_replay_and_read_summary_reject_missing_or_wrong_files(tmp_path, capsys):
    assert replay(tmp_path / "nope.rrd") == 1
    assert "does not exist" in capsys.readouterr().err
    text_file = tmp_path / "notes.txt"
    text_file.write_text("not a recording")
    assert replay(text_file) == 1
    assert ".rrd" in capsys.readouterr().err
    with pytest.raises(FileNotFoundError, match="does not exist"):
        read_summary(tmp_path / "nope.rrd")


def test_replay_says_a_file_is_not_a_recording_even_without_a_display(
    tmp_path, monkeypatch, capsys
):
    """A text file named .rrd used to get the 'no display' advice, never that it is no
    recording."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    fake = tmp_path / "x.rrd"
    fake.write_text("not a recording")
    assert replay(fake) == 1
    err = capsys.readouterr().err
    assert "is not a rerun recording" in err and "no display" not in err


def test_replay_names_a_directory_or_a_fifo_and_asks_for_a_recording_file(
    tmp_path, monkeypatch, capsys
):
    """A directory or a FIFO given to replay was said not to exist. It is named for what it
    is, with what replay needs, before any viewer starts; the FIFO is never read (no
    writer: a read would block)."""

    def no_viewer(command):  # pragma: no cover - refused before any viewer
        raise AssertionError(f"a viewer started: {command}")

    monkeypatch.setattr("sys.platform", "linux")
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr("subprocess.Popen", no_viewer)
    folder = tmp_path / "trial.rrd"
    folder.mkdir()
    fifo = tmp_path / "pipe.rrd"
    os.mkfifo(fifo)
    for path, kind in ((folder, "a directory"), (fifo, "a named pipe (FIFO)")):
        assert replay(path) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"is {kind}, not a recording" in err[0], err
        assert "give a recording file (.rrd" in err[0] and "does not exist" not in err[0]
        with pytest.raises(ValueError, match=f"is {re.escape(kind)}, not a recording"):
            read_summary(path)


def test_read_summary_rejects_a_cut_off_file(trial, tmp_path):
    cut = tmp_path / "cut.rrd"
    cut.write_bytes(trial[0].read_bytes()[:3000])
    with pytest.raises(ValueError, match="not a complete rerun recording"):
        read_summary(cut)


def test_replay_with_display_starts_the_viewer_on_the_file(trial, monkeypatch):
    started = []

    class FakeViewer:
        def __init__(self, command):
            started.append(command)

        def wait(self):
            return 0

    monkeypatch.setattr("sys.platform", "linux")
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr("subprocess.Popen", FakeViewer)
    assert replay(trial[0]) == 0
    (command,) = started
    assert command[-1] == str(trial[0])
    assert "rerun" in " ".join(command[:-1])


def test_forced_final_frame_lands_off_the_grid(tmp_path):
    """force=True records the last state of a trial even between frame times."""
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>"
    )
    data = mujoco.MjData(model)
    path = tmp_path / "f.rrd"
    rec = TrialRecorder(model, path, rate_hz=10.0)
    rec.frame(0.0, data)
    rec.frame(0.05, data)  # not due: 10 Hz
    rec.frame(0.05, data, force=True)
    rec.close()
    assert rec.n_frames == 2
    assert read_summary(path)["sim_time_range"] == pytest.approx((0.0, 0.05))
