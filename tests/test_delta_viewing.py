"""Recording, filming and exporting the delta's cull-and-refill trial (transplanter.viewing.delta,
`trial delta_refill --record`, `render delta_refill`, `export delta_refill`): the same numbers
with and without them, the recording's entities and the cells' statuses, a valid MP4, an
exported scene that loads with the job's plugs.

Rendering runs in a subprocess with MUJOCO_GL=egl (MuJoCo picks its GL backend when it is
first imported, and this test process imported it without one)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from transplanter import cli
from transplanter.scenario.schema import load_scenario
from transplanter.twin.delta_refill import run_delta_refill
from transplanter.viewing import delta
from transplanter.viewing.playback import read_summary
from transplanter.viewing.video import RenderRefused

SEED = 10  # the first job cell (3) is inferior: a cull and a refill
SMALL = {"delta_refill.max_cells": 1, "delta_refill.image_delay_ms": 0.0,
         "delta_refill.vision": "truth"}  # fmt: skip
SETS = ["--set", "delta_refill.max_cells=1", "--set", "delta_refill.image_delay_ms=0",
        "--set", "delta_refill.vision=truth"]  # fmt: skip
RATE_HZ = 20.0


def _numbers(result_dict: dict) -> str:
    return json.dumps({k: v for k, v in result_dict.items() if k != "wall_time_s"}, sort_keys=True)


class _Keep:
    """An observer that keeps the trial's compiled model and its looks' times."""

    def __init__(self) -> None:
        self.next_t, self.times, self.model = 0.0, [], None

    def attach(self, view) -> None:
        self.model = view.model
        self.look(view)  # the power-on state

    def look(self, view) -> None:
        self.times.append(view.t)
        self.next_t = math.floor(view.t * 2 + 1e-6) / 2 + 0.5  # every 0.5 s

    def finish(self, view, result) -> None:
        self.finished = result

    def abort(self) -> None:
        pass


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    sc = load_scenario("delta_refill", SMALL)
    plain = run_delta_refill(sc, SEED)
    path = tmp_path_factory.mktemp("rec") / "delta.rrd"
    recording, keep = delta.DeltaRecording(path, RATE_HZ), _Keep()
    recorded = delta.run_observed(sc, SEED, [recording, keep])
    return plain, recorded, recording, keep, path


def test_recording_leaves_the_numbers_unchanged(runs):
    plain, recorded, *_ = runs
    assert recorded.recording_error is None
    assert _numbers(plain.to_dict()) == _numbers(recorded.to_dict())


def test_observers_look_only_at_their_frame_times(runs):
    plain, _, _, keep, _ = runs
    assert keep.times[0] == 0.0  # the power-on state, at attach
    # one look per 0.5 s of simulated time, each at the first step that reaches it
    assert len(keep.times) == math.floor(plain.sim_time_s * 2 + 1e-9) + 1
    assert all(0 <= t - k * 0.5 < 1.5e-3 for k, t in enumerate(keep.times))
    assert keep.finished is runs[1]


def test_the_recording_holds_the_delta_the_plugs_and_the_tray(runs):
    plain, _, recording, _, path = runs
    s = read_summary(path)
    moving = set(s["temporal_components"])
    for body in ("platform", "upper_arm1", "rod3b", "claws_head", "claw_left", "p003", "s000"):
        assert f"world/bodies/{body}" in moving, body
    assert "world/bodies/p004" not in moving  # a plug the job does not lift: static
    assert any(e.startswith("world/bodies/p004/") for e in s["static_components"])
    assert "world/tray_state" in moving
    for channel in ("joints/q1_cmd_deg", "joints/q1_deg", "joints/q3_deg", "platform/z_mm",
                    "claws/rotary_deg", "claws/valve", "claws/stroke_left_mm",
                    "tray/cell_003"):  # fmt: skip
        assert channel in s["scalar_channels"], channel
    t0, t1 = s["sim_time_range"]
    assert t0 == 0.0 and t1 == pytest.approx(plain.sim_time_s)
    # frames at RATE_HZ plus the power-on one and the last state off the grid
    rows = s["rows_on_sim_time"]["world/bodies/platform"]
    assert abs(rows - (plain.sim_time_s * RATE_HZ + 2)) <= 2
    # the inferior cell went through its statuses, ending refilled (as the judge says)
    assert recording.status == {3: "refilled"}
    assert plain.cells[0].culled == "binned" and plain.cells[0].refilled == "seated"
    assert s["events"] == {"cell": 4}  # culling, culled, refilling, refilled
    assert ("3D", "world") in s["blueprint_views"]


def test_cli_trial_record_writes_the_rrd_and_the_same_json(runs, tmp_path, capsys):
    plain = runs[0]
    rrd, out = tmp_path / "t.rrd", tmp_path / "t.json"
    status = cli.main(["trial", "delta_refill", "--seed", str(SEED), *SETS, "--record", str(rrd),
                       "--record-rate", "5", "--json", str(out)])  # fmt: skip
    assert status == 0
    assert "recording written to" in capsys.readouterr().out
    assert rrd.read_bytes()[:4] == b"RRF2"
    assert _numbers(json.loads(out.read_text())) == _numbers(
        json.loads(json.dumps(plain.to_dict()))
    )
    assert not list(tmp_path.glob(".*"))  # no temporary file left


def test_a_recording_that_cannot_be_made_loses_no_results(runs, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("RERUN", "off")  # rerun refuses to record
    rrd, out = tmp_path / "t.rrd", tmp_path / "t.json"
    status = cli.main(["trial", "delta_refill", "--seed", str(SEED), *SETS, "--record", str(rrd),
                       "--json", str(out)])  # fmt: skip
    assert status == 5
    assert "could not be started" in capsys.readouterr().err
    assert _numbers(json.loads(out.read_text())) == _numbers(
        json.loads(json.dumps(runs[0].to_dict()))
    )
    assert not rrd.exists() and not list(tmp_path.glob(".*"))


def test_cli_trial_record_refuses_several_seeds(tmp_path, capsys):
    status = cli.main(["trial", "delta_refill", "--seeds", "1-2", *SETS,
                       "--record", str(tmp_path / "x.rrd")])  # fmt: skip
    assert status == 2
    assert "--record" in capsys.readouterr().err
    assert not (tmp_path / "x.rrd").exists()


def test_export_writes_the_trials_scene_with_its_plugs(runs, tmp_path, capsys):
    keep = runs[3]
    out = tmp_path / "scene" / "delta.xml"
    out.parent.mkdir()
    assert cli.main(["export", "delta_refill", str(out), "--seed", str(SEED), *SETS]) == 0
    assert "written to" in capsys.readouterr().out
    assert sorted(p.name for p in (out.parent / "assets").iterdir()) == [
        "delta_base.stl", "delta_platform.stl", "plug_claw_blade.stl"
    ]  # fmt: skip
    model = mujoco.MjModel.from_xml_path(str(out))
    trial = keep.model
    assert (model.nbody, model.ngeom, model.njnt, model.nu, model.neq) == (
        trial.nbody, trial.ngeom, trial.njnt, trial.nu, trial.neq
    )  # fmt: skip
    names = [model.body(i).name for i in range(model.nbody)]
    assert names == [trial.body(i).name for i in range(trial.nbody)]
    # the job's plugs are free bodies, the others static; the cameras are there
    assert model.jnt_type[model.body("p003").jntadr[0]] == mujoco.mjtJoint.mjJNT_FREE
    assert model.jnt_type[model.body("s000").jntadr[0]] == mujoco.mjtJoint.mjJNT_FREE
    assert model.body("p004").jntnum[0] == 0
    assert {model.camera(i).name for i in range(model.ncam)} >= set(delta.DELTA_CAMERAS)
    np.testing.assert_allclose(model.geom_size, trial.geom_size, rtol=1e-5, atol=1e-9)
    # the home keyframe is the power-on state: it holds
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    seat = data.body("p003").xpos.copy()
    for _ in range(300):
        mujoco.mj_step(model, data)
    assert np.linalg.norm(data.body("platform").xpos - [0, 0, -0.8]) < 1e-3
    assert np.linalg.norm(data.body("p003").xpos - seat) < 1e-3


def test_cell_lists():
    assert delta.parse_cells("3, 40-42") == {3, 40, 41, 42}
    for bad in ("x", "5-3", "1,,2"):
        with pytest.raises(RenderRefused):
            delta.parse_cells(bad)


# -- render (the video extra) ------------------------------------------------------------------


def _headless_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "egl"
    return env


def _transplanter(*args: str):
    return subprocess.run(
        [sys.executable, "-m", "transplanter.cli", *args],
        capture_output=True,
        text=True,
        env=_headless_env(),
        timeout=300,
    )


@pytest.mark.slow
def test_render_writes_an_mp4_of_the_job_and_the_same_json(runs, tmp_path):
    iio = pytest.importorskip("imageio.v2")
    pytest.importorskip("imageio_ffmpeg")
    plain = runs[0]
    out, results = tmp_path / "clip.mp4", tmp_path / "r.json"
    run = _transplanter(
        "render", "delta_refill", "--seed", str(SEED), *SETS, "--out", str(out),
        "--json", str(results), "--width", "160", "--height", "120", "--fps", "4",
        "--camera", "trays", "--cells-of", "3", "--quiet",
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "video written to" in run.stdout
    assert _numbers(json.loads(results.read_text())) == _numbers(
        json.loads(json.dumps(plain.to_dict()))
    )
    reader = iio.get_reader(out)
    try:
        frames = [f for f in reader]
    finally:
        reader.close()
    assert frames[0].shape == (120, 160, 3)
    cell = plain.cells[0]  # its work plus the 0.5 s tail, a frame every 0.25 s
    expected = (cell.end_s + delta.CELL_TAIL_S - cell.start_s) * 4
    assert abs(len(frames) - expected) <= 2
    assert not list(tmp_path.glob(".*"))


def test_render_refusals_name_the_problem(tmp_path, capsys):
    pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / "x.mp4"
    base = ["render", "delta_refill", "--seed", str(SEED), *SETS, "--out", str(out)]
    assert cli.main([*base, "--cells-of", "5"]) == 2
    assert "not serviced by this job; its cells are 3" in capsys.readouterr().err
    assert cli.main([*base, "--camera", "funnel"]) == 2
    err = capsys.readouterr().err
    assert "no camera 'funnel'" in err and "claws_closeup" in err
    assert cli.main([*base, "--seedlings-of", "0"]) == 2
    assert "--cells-of" in capsys.readouterr().err
    assert not out.exists() and not list(tmp_path.glob(".*"))
