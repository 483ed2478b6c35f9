"""The delta's cull-and-refill trial (transplanter.twin.delta_refill): the scene, the drives,
the controller's refusals, the job through contact, pose judgement, determinism, the JSON."""

import json
import math

import mujoco
import numpy as np
import pytest

from transplanter import cli
from transplanter.machine.delta_drives import DeltaController, joint_limits_refusal
from transplanter.machine.kinematics.delta import DeltaKinematics
from transplanter.machine.motion import MotionConfig, plan_line
from transplanter.machine.rig import DirectLink, SimulatedEndstops
from transplanter.machine.sgf import SGFConfig
from transplanter.scenario.schema import load_scenario
from transplanter.scene.delta_scene import (
    DeltaSceneConfig,
    JobCells,
    build_delta_spec,
    compile_scene,
)
from transplanter.scene.effectors import plug_claws
from transplanter.scene.plug_physics import PlugPhysics, stripper_push
from transplanter.scene.plug_substrate import Substrate
from transplanter.scene.plug_tray import draw_tray
from transplanter.scene.robots import delta as delta_robot
from transplanter.twin import delta_refill
from transplanter.twin.delta_refill import run_delta_refill

KIN = DeltaKinematics()
# the physics from the drawn truth (the pipeline's grading: tests/test_delta_grading.py)
SMALL = {"delta_refill.max_cells": 1, "delta_refill.image_delay_ms": 0.0,
         "delta_refill.vision": "truth"}  # fmt: skip
SEED = 10  # first job cell inferior, first healthy supply seedling a left-right crosser


def _scenario(**over):
    return load_scenario("delta_refill", {**SMALL, **over})


@pytest.fixture(scope="module")
def pair():
    sc = _scenario()
    return run_delta_refill(sc, SEED), run_delta_refill(sc, SEED)


def _home_scene():
    """Seed SEED's scene for a job culling planting cell 3 and refilling from supply cell 0,
    at power-on (home pose, drives and claws holding it), forward-computed: (scene config,
    planting tray, model, data)."""
    q0 = tuple(float(v) for v in KIN.joints(np.array([0.0, 0.0, -0.8])))
    cfg = DeltaSceneConfig(home_q_rad=q0)
    planting, supply = draw_tray(SEED), draw_tray(SEED + 1000003)
    model = compile_scene(build_delta_spec(cfg, planting, supply, JobCells((3,), (), (0,))))
    data = mujoco.MjData(model)
    data.qpos[:] = delta_robot.home_qpos(model, cfg, (0.0, 0.0, -0.8))
    data.ctrl[:3] = delta_robot.home_ctrl(cfg)
    data.ctrl[3:6] = plug_claws.home_ctrl(cfg.claws)
    mujoco.mj_forward(model, data)
    return cfg, planting, model, data


def test_the_scene_builds_without_welds_and_holds_home():
    cfg, _, model, data = _home_scene()
    # the only equalities are the delta's six closed-chain connects: nothing glues a plug
    assert model.neq == 6
    assert all(model.eq_type[i] == mujoco.mjtEq.mjEQ_CONNECT for i in range(model.neq))
    assert {model.equality(i).name for i in range(model.neq)} == {
        f"close{i}{s}" for i in (1, 2, 3) for s in "ab"
    }
    assert model.body("claws_mount").parentid == model.body("platform").id
    seat = data.body("p003").xpos.copy()
    for _ in range(500):
        mujoco.mj_step(model, data)
    assert np.linalg.norm(data.body("platform").xpos - [0, 0, -0.8]) < 1e-3
    assert np.linalg.norm(data.body("p003").xpos - seat) < 1e-3


@pytest.mark.parametrize("cell", [20, 92])  # a plug the job leaves (static), an empty cell
def test_a_dropped_plug_lands_on_the_tray_not_through_it(cell):
    """A plug off the pins over a cell the job does not touch lands on that cell's plug (its
    surface 3 mm below the walls' top) or, where the cell is empty, on the tray's plate."""
    cfg, planting, model, data = _home_scene()
    assert (planting.cells[cell].seedling is None) == (cell == 92)
    qa = model.jnt_qposadr[model.joint("p003").id]
    x, y = cfg.cell_xy("planting", cell)
    height = 0.039  # the plug: 42 mm cell less its surface 3 mm below the top
    data.qpos[qa : qa + 3] = [x, y, cfg.tray_top_m + height + 0.02]  # its bottom 20 mm above
    for _ in range(800):
        mujoco.mj_step(model, data)
    bottom = data.qpos[qa + 2] - height
    rest = cfg.tray_top_m - (0.003 if cell != 92 else 0.042 + 0.002)
    assert bottom == pytest.approx(rest, abs=1e-3)
    assert np.linalg.norm(data.qvel[model.jnt_dofadr[model.joint("p003").id] :][:3]) < 1e-3


def test_a_plug_off_the_pins_but_wedged_in_the_stripper_is_judged_jammed():
    """Seed 7's refill that sheared off the pins on a dropped cull and rode wedged between the
    stripper's blocks: `jammed`, not `dropped` (a plug off the pins lying on the tray)."""
    cfg, _, model, data = _home_scene()
    sub = Substrate(cfg.plugs)
    cull, refill = PlugPhysics(model, data, "p003", sub), PlugPhysics(model, data, "s000", sub)
    judge = delta_refill.DeltaRefillJudge(model, cfg, (0.4, 0.0), 0.006)
    here = cfg.cell_xy("planting", 3)
    assert judge.culled(data, cull, here) == "left"  # in its seat: never lifted
    assert judge.refilled(data, refill, here) == "not_seated"  # still in the supply tray
    block = model.geom("stripper_left").id
    underside = data.geom_xpos[block][2] - model.geom_size[block][2]
    mount = data.body("claws_mount").xpos
    for plug in (cull, refill):
        plug.dropped_at_s = 1.0
        qa = plug.qadr
        data.qpos[qa : qa + 3] = [mount[0], mount[1], underside + 0.005]  # top in the head
        mujoco.mj_forward(model, data)
        assert stripper_push(model, data, plug.name) > 0.0
        data.qpos[qa : qa + 3] = [mount[0], mount[1], cfg.tray_top_m + 0.2]  # free, apart
    data.qpos[cull.qadr : cull.qadr + 3] = [mount[0], mount[1], underside + 0.005]
    mujoco.mj_forward(model, data)
    assert judge.culled(data, cull, here) == "jammed"
    assert judge.refilled(data, refill, here) == "dropped"
    data.qpos[cull.qadr : cull.qadr + 3] = [mount[0], mount[1], cfg.tray_top_m + 0.2]
    data.qpos[refill.qadr : refill.qadr + 3] = [mount[0], mount[1], underside + 0.005]
    mujoco.mj_forward(model, data)
    assert judge.culled(data, cull, here) == "dropped"
    assert judge.refilled(data, refill, here) == "jammed"


def _homed_controller(accel_m_s2=5.0):
    sc = _scenario()
    kin = DeltaKinematics.from_scenario(sc)
    cfg = SGFConfig(
        kinematics=kin,
        motion=MotionConfig(
            resolution_m=5e-4,
            accel_m_s2=accel_m_s2,
            profile="scurve",
            compute_time_per_point_s=1e-4,
        ),  # fmt: skip
        homing=DeltaKinematics.homing_from_scenario(sc),
    )
    controller = DeltaController(cfg)
    q0 = kin.joints(np.array([0.0, 0.0, -0.8]))
    link = DirectLink(controller.sgf, SimulatedEndstops(cfg, q0))
    link.t = 0.0
    replies = link.send("G28")
    assert replies[-1].startswith("ok"), replies
    return controller, link.t + 1.0


def test_a_move_beyond_a_joint_limit_is_refused_naming_it():
    controller, t = _homed_controller()
    controller.receive("G1 X-300 Y0 Z-1000 S200", t)
    replies = controller.poll(t + 0.01)
    assert replies and replies[0].startswith("error:33")
    assert "q1" in replies[0] and "outside [-40, 80] deg" in replies[0]
    assert controller.sgf.position_xyz[2] < 0  # nothing moved: still where homing left it


def test_a_move_asking_more_than_a_max_is_refused_before_it_starts():
    controller, t = _homed_controller(accel_m_s2=60.0)
    before = controller.pulses_at(t)[0].copy()
    controller.receive("G1 X200 Y200 Z-800 S2000", t)
    replies = controller.poll(t + 0.01)
    assert replies[0].startswith("error:33") and "A_max 2500.0 deg/s^2" in replies[0]
    np.testing.assert_array_equal(controller.pulses_at(t + 1.0)[0], before)
    # the check itself, on the same move at a gentle acceleration: accepted
    start = controller.sgf.position_xyz
    move = plan_line(KIN.steps_of_point(start), start, np.array([0.2, 0.2, -0.8]), 0.5, KIN,
                     MotionConfig(resolution_m=5e-4, accel_m_s2=2.0, profile="scurve",
                                  compute_time_per_point_s=1e-4))  # fmt: skip
    assert joint_limits_refusal(KIN, move) is None


def test_a_culled_plug_ends_in_the_bin_and_a_refill_is_seated_by_contact(pair):
    r, _ = pair
    (cell,) = r.cells
    assert cell.truth == "inferior" and cell.culled == "binned"
    assert cell.refilled == "seated" and 0.5 < cell.retention < 1.0
    assert r.fault is None and r.failures == {} and r.valid
    assert r.dropped == 0 and r.operations == 1
    assert cell.rotary_deg == 90.0  # the refill seedling crosses left-right


def test_torque_starved_drives_lag_and_fault():
    r = run_delta_refill(_scenario(**{"delta.joint_torque_limit_nm": 2.0}), SEED)
    assert r.fault is not None and r.fault.startswith("Err24.0 position deviation excess")
    assert r.failures.get("drive_alarm") == 1
    assert max(r.peak_following_error_deg) > 2.0
    assert not any(c.refilled == "seated" for c in r.cells)


def test_pose_judgement_off_damages_the_crossing_leaves(pair):
    on, _ = pair
    off = run_delta_refill(_scenario(**{"delta_refill.pose_judgement": False}), SEED)
    assert on.leaf_damage_rate == 0.0
    assert off.leaf_damage_rate > on.leaf_damage_rate
    (cell,) = off.cells
    assert cell.rotary_deg == 0.0
    assert cell.leaf_damage and cell.leaf_damage[0]["by"].startswith("stripper")


def test_the_plugs_moisture_set_in_the_scenario_is_the_physics_moisture(pair):
    wet = run_delta_refill(_scenario(**{"plugs.moisture_pct": 75.0}), SEED)
    (dry_cell,), (wet_cell,) = pair[0].cells, wet.cells
    assert dry_cell.retention == pytest.approx(0.87946, abs=1e-5)  # 65 %: the default
    assert wet_cell.retention == pytest.approx(0.84889, abs=1e-5)  # 15.3 g, less cohesive
    assert wet_cell.refilled == "seated"


def test_same_seed_same_json(pair):
    a, b = (r.to_dict() for r in pair)
    for d in (a, b):
        d.pop("wall_time_s")
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def test_the_json_has_the_paper_columns_with_definitions(tmp_path, capsys):
    out = tmp_path / "r.json"
    status = cli.main(["trial", "delta_refill", "--seed", str(SEED), "--json", str(out),
                       "--set", "delta_refill.max_cells=1",
                       "--set", "delta_refill.image_delay_ms=0",
                       "--set", "delta_refill.vision=truth"])  # fmt: skip
    assert status == 0
    d = json.loads(out.read_text())
    for name in ("time_per_operation_s", "plants_per_hour", "trays_per_hour",
                 "leaf_damage_rate", "tray_leaf_damage_rate", "substrate_retention"):  # fmt: skip
        assert isinstance(d[name], float) and math.isfinite(d[name]), name
        assert name in d["definitions"]
    assert isinstance(d["dropped"], int) and isinstance(d["failures"], dict)
    assert isinstance(d["cells"], list) and d["cells"][0]["culled"] == "binned"
    out_plain = capsys.readouterr().out  # the summary leads: the meanings under --explain
    assert "what each number means: --explain" in out_plain
    assert "time_per_operation_s:" not in out_plain
    status = cli.main(["trial", "delta_refill", "--seed", str(SEED), "--explain",
                       "--set", "delta_refill.max_cells=1",
                       "--set", "delta_refill.image_delay_ms=0",
                       "--set", "delta_refill.vision=truth"])  # fmt: skip
    assert status == 0 and "time_per_operation_s" in capsys.readouterr().out


def test_the_splines_take_less_time_than_lines_for_the_same_cell(pair):
    spline, _ = pair
    lines = run_delta_refill(_scenario(**{"motion.planner": "lines"}), SEED)
    assert spline.planner == "bspline5" and lines.planner == "lines"
    for r in (spline, lines):
        (cell,) = r.cells
        assert cell.culled == "binned" and cell.refilled == "seated", r.planner
        assert r.fault is None and r.dropped == 0
        # the arms' measured speed stays far inside V_max; the servos never give more than
        # tau_max (their force range), the following error stays under the alarm
        assert max(r.peak_joint_speed_deg_s) < 720.0
        assert max(r.peak_joint_torque_nm) <= 12.0 + 1e-9
        assert max(r.peak_following_error_deg) < 2.0
    # seed 10's cell: 5.64 s with splines against 8.93 s with lines (no image delay)
    assert spline.tray_time_s < 0.7 * lines.tray_time_s
    assert max(spline.peak_joint_speed_deg_s) > max(lines.peak_joint_speed_deg_s)


def test_the_time_per_operation_is_the_work_without_the_trays_own_time(pair):
    """An operation's time is the work from the claws' arrival at the first cell to the end
    of the last operation: the image delay, the approach from the homed machine and the last
    lift are the tray's (in `tray_time_s`, and so in trays and plants per hour)."""
    r, _ = pair
    (cell,) = r.cells
    assert r.time_per_operation_s == r.work_time_s / r.operations
    # the cell's record starts before the approach from the homed machine (lines: up, across,
    # down); the work starts when the claws reach the cell
    assert cell.start_s + 1.0 < cell.end_s - r.work_time_s
    assert r.tray_time_s > r.work_time_s + 1.0
    waited = run_delta_refill(_scenario(**{"delta_refill.image_delay_ms": 2000.0}), SEED)
    assert waited.time_per_operation_s == pytest.approx(r.time_per_operation_s, abs=1e-9)
    assert waited.tray_time_s == pytest.approx(r.tray_time_s + 2.0, abs=1e-9)
    assert waited.trays_per_hour < r.trays_per_hour


def test_the_scenario_timestep_is_the_physics_step():
    sc = _scenario(**{"physics.timestep_ms": 0.5})
    spec = build_delta_spec(
        delta_refill._scene_config(sc, KIN),
        draw_tray(SEED),
        draw_tray(SEED + 1),
        JobCells((), (), ()),
    )
    assert compile_scene(spec).opt.timestep == 0.0005


def test_a_step_that_goes_unstable_stops_the_trial_and_voids_its_verdicts(monkeypatch):
    """MuJoCo resets the whole state when a value blows up (seed 7's tray: a dropped plug
    wedged into a refilled cell at 11 m/s): the trial stops at that step with the fault
    naming the body, instead of running the reset world on and judging it (the drives'
    alarm, then every cell failed)."""
    real_step = mujoco.mj_step

    def step(model, data):
        if 0.5 <= data.time < 0.5 + 0.5 * model.opt.timestep:  # a huge speed on a plug
            plug = next(
                j for j in range(model.njnt)
                if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
                and model.joint(j).name.startswith("s")
            )  # fmt: skip
            data.qvel[model.jnt_dofadr[plug]] = 1e12
        real_step(model, data)

    monkeypatch.setattr(mujoco, "mj_step", step)
    r = run_delta_refill(_scenario(), SEED)
    assert not r.valid and r.fault.startswith(delta_refill.UNSTABLE)
    assert "at 0.500 s" in r.fault and "QVEL" in r.fault and ": s0" in r.fault
    assert r.failures == {"unstable": 1}
    assert r.sim_time_s == pytest.approx(0.5, abs=1e-9)  # not a step after it
    (cell,) = r.cells
    assert cell.culled == "void" and cell.refilled == "void"


def test_a_partial_trays_rates_are_the_whole_trays(pair):
    """A run of delta_refill.max_cells cells reports the whole tray's plants and trays per
    hour: the serviced cells' work and plants scaled by the plants the grading asks of the
    tray over theirs, the tray's own time (image delay, approach, last lift, tray change)
    counted once, so that the rate does not depend on how many cells the run serviced."""
    r, _ = pair
    sc = _scenario()
    planting, supply = delta_refill._trays(sc, SEED)
    grades = delta_refill.from_truth(planting, supply)
    cells, plants = delta_refill.tray_work(grades)
    assert r.rate_basis == "whole_tray_estimate" and r.cells_to_service == cells > 1
    inferior = sum(1 for c in grades.planting.cells if c.grade == "inferior")
    assert plants == 2 * inferior + (cells - inferior)  # a cull and a refill, or a refill
    (cell,) = r.cells
    assert cell.grade == "inferior" and cell.culled == "binned" and cell.refilled == "seated"
    scale = plants / 2  # this cell's two plants
    change = sc.delta_refill.tray_change_s
    cycle = r.tray_time_s - r.work_time_s + change + r.work_time_s * scale
    assert r.trays_per_hour == pytest.approx(3600 / cycle, rel=1e-12)
    assert r.plants_per_hour == pytest.approx(3600 * 2 * scale / cycle, rel=1e-12)
    # the tray as run would have spread the tray's own time over one cell: far slower
    assert r.plants_per_hour > 2 * 3600 * 2 / (r.tray_time_s + change)


def _rate_and_spread(r, change_s: float) -> tuple[float, float]:
    """A partial tray's plants per hour and its standard error from the serviced cells'
    spread: the work per plant is a ratio estimate over the cells (each cell's duration over
    its plants: a cull and a refill 2, a refill 1), carried to the whole tray's rate."""
    d = np.array([c.end_s - c.start_s for c in r.cells])
    p = np.array([2.0 if c.grade == "inferior" else 1.0 for c in r.cells])
    n = len(d)
    w = r.work_time_s / p.sum()  # the run's work per plant, as the estimate takes it
    ratio = d.sum() / p.sum()
    se_w = math.sqrt(((d - ratio * p) ** 2).sum() / (n * (n - 1))) / p.mean()
    own = r.tray_time_s - r.work_time_s + change_s  # the tray's own time, counted once
    plants = r.plants_per_hour * own / (3600 - r.plants_per_hour * w)  # the tray's plants
    rate = 3600 * plants / (own + w * plants)
    return rate, 3600 * plants**2 / (own + w * plants) ** 2 * se_w


def test_three_and_six_cells_give_the_whole_trays_rate_within_their_spread():
    """The rate of a partial tray does not depend on how many cells the run serviced: three
    and six cells of seed 1's tray agree within the spread of their cells' work per plant
    (1678 and 1653 plants/h here; the whole tray, 23 cells, 1648: docs/delta.md)."""
    over = {"delta_refill.vision": "truth"}
    three = run_delta_refill(
        load_scenario("delta_refill", {**over, "delta_refill.max_cells": 3}), 1
    )
    six = run_delta_refill(load_scenario("delta_refill", {**over, "delta_refill.max_cells": 6}), 1)
    change = load_scenario("delta_refill").delta_refill.tray_change_s
    (r3, se3), (r6, se6) = _rate_and_spread(three, change), _rate_and_spread(six, change)
    assert (r3, r6) == (pytest.approx(three.plants_per_hour), pytest.approx(six.plants_per_hour))
    assert three.cells_to_service == six.cells_to_service == 23
    assert se3 > 0 and se6 > 0
    assert abs(r3 - r6) < 2 * math.hypot(se3, se6)
