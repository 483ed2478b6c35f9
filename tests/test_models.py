"""Model files: generated numbers up to date, compile, run warning-free, five-bar accuracy,
stepper lag and stiffness."""

import importlib.util
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from conftest import paper_config
from transplanter.machine.kinematics import fivebar as kinematics
from transplanter.scene import SceneConfig, build_scene
from transplanter.scene.build import (
    compile_with_home,
    effector_xml,
    merge_models,
    model_files,
    mounts,
    robot_xml,
    scene_files,
    scene_spec,
)

REPO = Path(__file__).resolve().parent.parent

CFG = SceneConfig()
FULL_STEP = CFG.full_step_rad


def ik(cfg, x, y):
    """Paper working mode (elbows out) IK for a scene config."""
    return kinematics.ik(cfg.geometry(), x, y)


def run_noisy(model, seconds=2.0, seed=0):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    rng = np.random.default_rng(seed)
    base = data.ctrl.copy()
    scale = np.where(model.actuator_gear[:, 0] > 100, 0.02 * model.actuator_gear[:, 0], 0.05)
    for _ in range(int(seconds / model.opt.timestep)):
        data.ctrl[:] = base + scale * rng.standard_normal(model.nu)
        lo, hi = model.actuator_ctrlrange.T
        limited = model.actuator_ctrllimited.astype(bool)
        data.ctrl[limited] = np.clip(data.ctrl[limited], lo[limited], hi[limited])
        mujoco.mj_step(model, data)
    return data


def files_model():
    """The robot's, its effector's and the workcell's files as they are, merged as build_scene
    merges them (the effector at the robot's mount)."""
    return merge_models(scene_files(), attach=mounts(SceneConfig())).compile()


def load_make_models():
    spec = importlib.util.spec_from_file_location("make_models", REPO / "scripts/make_models.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_model_files_are_what_make_models_writes():
    """The models' XML carries SceneConfig()'s numbers: run scripts/make_models.py if this
    fails."""
    make_models = load_make_models()
    for name, text in make_models.generate(REPO / "models").items():
        assert (REPO / "models" / name).read_text() == text, f"models/{name} is stale"


def model_arrays(model):
    out = {}
    for name in dir(model):
        value = getattr(model, name) if not name.startswith("_") else None
        if isinstance(value, np.ndarray):
            out[name] = value
    return out


def test_default_config_changes_nothing_in_the_model_files():
    """build_scene's config steps, applied with SceneConfig(), give exactly the model files."""
    files = files_model()
    cfg = SceneConfig()
    applied = compile_with_home(scene_spec(cfg), cfg)
    a, b = model_arrays(files), model_arrays(applied)
    assert a.keys() == b.keys()
    differ = [name for name in a if not np.array_equal(a[name], b[name])]
    assert differ == []
    # each file's `home` holds the scene's home of its own joints and actuators
    home = applied.key("home")
    for xml, joints, actuators in (
        (robot_xml(), ("z", "theta1", "phi1", "theta2", "phi2"), ("theta1", "theta2", "z")),
        (effector_xml("parallel_jaw"), ("wrist", "jaw_left", "jaw_right"), ("gripper", "wrist")),
    ):
        own = mujoco.MjModel.from_xml_path(str(xml))
        assert own.key("home").qpos.tolist() == [
            home.qpos[applied.joint(j).qposadr[0]] for j in joints
        ]
        assert own.key("home").ctrl.tolist() == [
            home.ctrl[applied.actuator(n).id] for n in actuators
        ]


def test_merging_one_file_gives_the_model_of_that_file():
    """merge_models changes no array of a file's model (only the mesh paths it records)."""
    merged = merge_models([robot_xml()], name="fivebar").compile()
    direct = mujoco.MjModel.from_xml_path(str(robot_xml()))
    a, b = model_arrays(merged), model_arrays(direct)
    assert a.keys() == b.keys()
    assert [n for n in a if not np.array_equal(a[n], b[n])] == []
    assert merged.names == direct.names


def test_merging_refuses_an_include_and_two_assets_of_one_name(tmp_path):
    including = tmp_path / "including.xml"
    including.write_text(f'<mujoco><include file="{robot_xml()}"/></mujoco>')
    with pytest.raises(ValueError, match="include"):
        merge_models([including])
    files, jaw = [], (effector_xml("parallel_jaw").parent / "assets" / "jaw.stl").read_bytes()
    for k in (1, 2):
        (tmp_path / f"m{k}" / "assets").mkdir(parents=True)
        (tmp_path / f"m{k}" / "assets" / "box.stl").write_bytes(jaw[: 84 + 50 * k])
        files.append(tmp_path / f"m{k}" / f"m{k}.xml")
        files[-1].write_text(
            f'<mujoco><compiler meshdir="assets"/><asset><mesh name="m{k}" file="box.stl"/>'
            "</asset></mujoco>"
        )
    with pytest.raises(ValueError, match="box.stl"):
        merge_models(files)


def test_another_config_is_applied_over_the_files():
    """Longer links move the elbow and get heavier inertia; the keyframe closes the chain."""
    cfg = SceneConfig(l1_m=0.14, active_link_mass_kg=0.08, rows=1, cols=1)
    model = build_scene(cfg, seed=0).model
    files = mujoco.MjModel.from_xml_path(str(robot_xml()))
    assert model.body("passive1").pos.tolist() == [0.14, 0, -0.015]
    assert model.body("link1").mass[0] == pytest.approx(0.08)
    assert model.body("link1").inertia[0] > 1.5 * files.body("link1").inertia[0]
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    assert np.linalg.norm(data.site("c1").xpos - data.site("c2").xpos) < 1e-9


def _bridge_and_plates(model, data):
    """The palm's (the bridge's) underside and the side plates' ends over the grip centre (m)."""
    mujoco.mj_forward(model, data)
    grip_z = data.site("grip_center").xpos[2]
    bridge_bottom = data.geom("palm").xpos[2] - model.geom("palm").size[2]
    plates = [
        (data.geom(g).xpos[2] - model.geom(g).size[2], data.geom(g).xpos[2] + model.geom(g).size[2])
        for g in ("side_plate_left", "side_plate_right")
    ]
    jaw_top = data.geom("jaw_left").xpos[2] + model.geom("jaw_left").size[2]
    return (
        bridge_bottom - grip_z,
        [(lo - grip_z, hi - grip_z) for lo, hi in plates],
        jaw_top - grip_z,
    )


def test_the_bridge_stands_over_the_grip_centre_on_side_plates_from_the_jaws():
    """The palm is a bridge 68 mm over the grip centre (gripper.bridge_clearance_mm), carried by
    side plates from the jaws' top edges (22.5 mm up); at the paper's Z_low (34 mm) its
    underside is 102 mm over the belt, above the tallest shoot of the paper's pots (52 mm,
    sd 1 mm, and a 35-45 mm shoot); the column still fits under the wrist servo."""
    for model in (files_model(), build_scene(paper_config(1).scene, seed=1).model):
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        clearance, plates, jaw_top = _bridge_and_plates(model, data)
        assert clearance == pytest.approx(0.068, abs=1e-9)
        assert jaw_top == pytest.approx(0.0225, abs=1e-9)
        assert plates == [pytest.approx((0.0225, 0.068), abs=1e-9)] * 2
        assert model.geom("palm").size[2] == pytest.approx(0.003)
        assert model.geom("column").size[1] > 0
    scene = build_scene(paper_config(40).scene, seed=1)
    pots = scene.pots
    tallest = float(np.max(pots.height + pots.stem_length))
    assert 0.034 + clearance > tallest + 0.002 and tallest > 0.094


def test_the_bridge_clearance_is_a_config_value_and_must_fit_the_gripper():
    cfg = SceneConfig(rows=1, cols=1, bridge_clearance_m=0.050)
    model = build_scene(cfg, seed=0).model
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    clearance, plates, _ = _bridge_and_plates(model, data)
    assert clearance == pytest.approx(0.050, abs=1e-9)
    assert plates[0] == pytest.approx((0.0225, 0.050), abs=1e-9)
    for bad in (0.0225, 0.072):  # down to the jaws, up into the wrist servo
        with pytest.raises(ValueError, match="bridge_clearance_m"):
            SceneConfig(bridge_clearance_m=bad)


def test_merged_model_files_run_without_warnings():
    """The robot with its workcell, without pots (each folder's files alone:
    test_model_dirs.py)."""
    data = run_noisy(files_model())
    assert data.warning.number.sum() == 0
    assert np.all(np.isfinite(data.qpos))


def test_built_scene_runs_without_warnings():
    scene = build_scene(SceneConfig(rows=2, cols=5), seed=3)
    data = run_noisy(scene.model)
    assert data.warning.number.sum() == 0


def test_home_keyframe_closes_the_loop_and_matches_fk():
    model = merge_models([robot_xml()], "fivebar", attach=mounts(CFG)).compile()  # with its jaws
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    gap = np.linalg.norm(data.site("c1").xpos - data.site("c2").xpos)
    assert gap < 1e-5
    phi1, phi2 = CFG.kinematics().passive_angles(CFG.power_on_theta1_rad, CFG.power_on_theta2_rad)
    assert data.joint("phi1").qpos[0] == pytest.approx(phi1, abs=1e-5)
    assert data.joint("phi2").qpos[0] == pytest.approx(phi2, abs=1e-5)
    assert data.site("grip_center").xpos[2] == pytest.approx(0.150, abs=1e-9)


def workspace_points(n, seed=0):
    """Random points of x in [-100, 100] mm, y in [120, 240] mm (the design workspace); their
    IK lies inside the joint ranges (theta1 in [75, 240] deg, theta2 in [-60, 105] deg)."""
    rng = np.random.default_rng(seed)
    points = []
    for _ in range(n):
        x, y = rng.uniform(-0.1, 0.1), rng.uniform(0.12, 0.24)
        t1, t2 = ik(CFG, x, y)
        assert CFG.theta1_range_rad[0] < t1 < CFG.theta1_range_rad[1]
        assert CFG.theta2_range_rad[0] < t2 < CFG.theta2_range_rad[1]
        points.append((x, y))
    return np.array(points)


def test_grip_center_reaches_ik_targets():
    scene = build_scene(SceneConfig(rows=1, cols=1), seed=0)
    model, data = scene.model, scene.make_data()
    errors = []
    *field, z = scene.joint_positions(data)  # the fields start at power-on
    field = np.array(field)
    for target in workspace_points(50):
        goal = np.array(ik(CFG, *target))
        for i in range(300):  # the fields turn to the target's IK in 0.2 s (min jerk), rest
            u = min(i / 200, 1.0)
            now = field + (goal - field) * u**3 * (10 - 15 * u + 6 * u * u)
            speed = (goal - field) * 30 * u * u * (1 - u) ** 2 / 0.2
            scene.hold_motors(data, [*now, z], [*speed, 0.0])
            mujoco.mj_step(model, data)
        errors.append(np.hypot(*(data.site("grip_center").xpos[:2] - target)))
        field = goal
    assert max(errors) < 0.0005, max(errors)


def test_loop_stays_closed_in_a_fast_move():
    scene = build_scene(SceneConfig(rows=1, cols=1), seed=0)
    model, data = scene.model, scene.make_data()
    start, end = np.array([-0.08, 0.22]), np.array([0.08, 0.20])
    home = scene.joint_positions(data)
    goal = np.array([*ik(CFG, *start), 0.12])
    for i in range(500):  # to the start in 0.3 s (all three fields, min jerk), then rest
        u = min(i / 300, 1.0)
        now = home + (goal - home) * u**3 * (10 - 15 * u + 6 * u * u)
        scene.hold_motors(data, now, (goal - home) * 30 * u * u * (1 - u) ** 2 / 0.3)
        mujoco.mj_step(model, data)
    steps = int(np.linalg.norm(end - start) / 0.5 / model.opt.timestep)
    gaps = []
    previous = goal
    for i in range(1, steps + 1):  # 0.5 m/s on average (min jerk: 0.94 m/s at the middle)
        u = i / steps
        p = start + (end - start) * u**3 * (10 - 15 * u + 6 * u * u)
        field = np.array([*ik(CFG, *p), 0.12])
        scene.hold_motors(data, field, (field - previous) / model.opt.timestep)
        previous = field
        mujoco.mj_step(model, data)
        gaps.append(np.linalg.norm(data.site_xpos[scene.c1_site] - data.site_xpos[scene.c2_site]))
    assert max(gaps) < 5e-5, max(gaps)
    assert np.linalg.norm(data.site("grip_center").xpos[:2] - end) < 0.002


def max_motor_lag(speed_rad_s):
    """Ramp theta1's field from home (195 deg) to 100 deg at speed_rad_s (at the arm), theta2
    and Z held at home; return the max lag of motor 1 behind its field (motor rad)."""
    scene = build_scene(SceneConfig(rows=1, cols=1), seed=0)
    model, data = scene.model, scene.make_data()
    t0, t1 = CFG.power_on_theta1_rad, math.radians(100)
    q = scene.joint_positions(data)  # theta2 and Z stay here; the chain closes all the way
    lag = 0.0
    n = int(abs(t1 - t0) / speed_rad_s / model.opt.timestep)
    for i in range(0, n + 200):
        s = min(i / n, 1.0)
        speed = -speed_rad_s if i < n else 0.0
        scene.hold_motors(data, [t0 + (t1 - t0) * s, q[1], q[2]], [speed, 0.0, 0.0])
        mujoco.mj_step(model, data)
        field = scene.motor_gears[0] * (t0 + (t1 - t0) * min((i + 1) / n, 1.0))
        motor = scene.motor_gears[0] * data.qpos[scene.motor_qpos_adr[0]]
        lag = max(lag, abs(field - motor))
    return lag


def test_overspeed_lags_by_steps_and_normal_move_does_not():
    """40 rad/s at the arm is 19 rev/s at the motor, where the pull-out torque has fallen to
    0.19 N m (corner 8 rev/s): the rotor falls more than two full steps behind its field
    (it slips; counting the lost steps is sim.py's job). 2 rad/s lags well under one."""
    assert max_motor_lag(40.0) > 2 * FULL_STEP
    assert max_motor_lag(2.0) < FULL_STEP


@pytest.mark.parametrize("steps_per_rev", [200, 400])
def test_stepper_actuators_are_torque_with_damping_on_relative_motion(steps_per_rev):
    """ctrl is the motor's torque (N m at the shaft through the gear); the velocity bias is
    the rotor's damping, 2 x 0.2 x sqrt(K x J_rotor) with K the torque law's small-signal
    stiffness, holding torque x rotor teeth (steps_per_rev / 4); no force limit (the law
    peaks at the pull-out torque); the lead screw's friction is Z's frictionloss."""
    cfg = SceneConfig(rows=1, cols=1, steps_per_rev=steps_per_rev)
    model = build_scene(cfg, seed=0).model
    stiffness = 0.45 * steps_per_rev / 4
    damping = 2 * 0.2 * math.sqrt(stiffness * 5.4e-6)
    for name in ("theta1", "theta2", "z"):
        act = model.actuator(name)
        assert act.gainprm[0] == 1.0
        assert act.biasprm[:3].tolist() == pytest.approx([0.0, 0.0, -damping])
        assert not model.actuator_forcelimited[act.id]
        assert model.jnt_dofadr[act.trnid[0]] >= 0
    z_dof = model.jnt_dofadr[model.joint("z").id]
    weight = model.body_subtreemass[model.body("platform").id] * 9.81
    assert model.dof_frictionloss[z_dof] == pytest.approx(weight * (1 / 0.35 - 1))
    assert model.dof_damping[z_dof] == 0.0


def test_limit_switches_trip_at_the_homing_positions():
    scene = build_scene(SceneConfig(rows=1, cols=1), seed=0)
    data = scene.make_data()
    assert not scene.limit_switches(data).any()
    adr = scene.motor_qpos_adr
    data.qpos[adr] = [math.radians(200.5), math.radians(-20.5), 0.161]
    assert scene.limit_switches(data).tolist() == [True, True, True, False]
    data.qpos[adr[2]] = 0.004
    assert scene.limit_switches(data).tolist() == [True, True, False, True]


def test_exported_scene_is_the_scene_a_trial_builds(tmp_path):
    """transplanter export: one MJCF with its meshes beside it that compiles to the same
    bodies, geoms and joints as the in-memory scene's decorated model (the physics model
    without the pots' decor), and rolls out as the physics model does for 1 s."""
    from transplanter.cli import main

    assert main(["export", "paper", str(tmp_path / "scene.xml"), "--seed", "3"]) == 0
    exported = mujoco.MjModel.from_xml_path(str(tmp_path / "scene.xml"))
    cfg = paper_config(**{"scenario.seed": 3}).scene
    scene = build_scene(cfg, seed=3)
    built = scene.render_model
    for n in ("nbody", "ngeom", "njnt", "nq", "nv", "nu", "nmesh", "ncam", "nkey", "neq"):
        assert getattr(exported, n) == getattr(built, n), n
    # MuJoCo's XML writer keeps 6 significant digits: the numbers agree to that
    np.testing.assert_allclose(exported.geom_size, built.geom_size, rtol=5e-6)
    np.testing.assert_allclose(exported.body_mass, built.body_mass, rtol=5e-6)
    runs = []
    for model in (exported, scene.model):
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        for _ in range(1000):
            mujoco.mj_step(model, data)
        runs.append(data.qpos.copy())
    np.testing.assert_allclose(runs[0], runs[1], atol=1e-4)  # 0.1 mm, 0.1 mrad after 1 s
    assert sorted(p.name for p in (tmp_path / "assets").iterdir()) == sorted(
        p.name
        for xml in model_files()
        if (xml.parent / "assets").is_dir()
        for p in (xml.parent / "assets").iterdir()
    )  # the robot's (none), its effector's and the workcell's meshes


def test_export_never_writes_a_mesh_through_a_planted_link(tmp_path, capsys):
    """assets/NAME.stl are names export derives: a link planted there is replaced by the mesh
    itself (its target untouched, a dangling one's target not created); an assets/ that is
    a link is refused."""
    from transplanter.cli import main

    assert main(["export", "paper", str(tmp_path / "a" / "scene.xml")]) == 2  # no a/ yet
    (tmp_path / "a").mkdir()
    assert main(["export", "paper", str(tmp_path / "a" / "scene.xml")]) == 0
    first, second = sorted((tmp_path / "a" / "assets").iterdir())[:2]
    victim = tmp_path / "victim.txt"
    victim.write_text("someone else's file")
    (tmp_path / "b" / "assets").mkdir(parents=True)
    (tmp_path / "b" / "assets" / first.name).symlink_to(victim)
    (tmp_path / "b" / "assets" / second.name).symlink_to(tmp_path / "created.txt")
    assert main(["export", "paper", str(tmp_path / "b" / "scene.xml")]) == 0
    assert victim.read_text() == "someone else's file"
    assert not (tmp_path / "created.txt").exists()
    for mesh in (first, second):
        written = tmp_path / "b" / "assets" / mesh.name
        assert not written.is_symlink() and written.read_bytes() == mesh.read_bytes()
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == ["assets", "scene.xml"]
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "assets").symlink_to(tmp_path / "b" / "assets", target_is_directory=True)
    capsys.readouterr()
    assert main(["export", "paper", str(tmp_path / "c" / "scene.xml")]) == 2
    assert "assets is a symbolic link" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "c").iterdir()) == ["assets"]


def test_named_cameras_look_at_what_they_are_named_for():
    model = files_model()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    targets = {
        "overview": np.array([0.0, 0.18, 0.03]),  # the arm over the pickup row
        "funnel": data.xpos[model.body("drop_tube").id],
        "gripper_closeup": data.site_xpos[model.site("grip_center").id],
    }
    for name, target in targets.items():
        cam = model.camera(name).id
        view = -data.cam_xmat[cam].reshape(3, 3)[:, 2]  # a camera looks along its -z
        to_target = target - data.cam_xpos[cam]
        cos = view @ to_target / np.linalg.norm(to_target)
        assert cos > 0.97, name  # the target is within about 14 deg of the view axis


def test_export_on_a_full_disk_says_so_in_one_line_and_leaves_nothing(
    tmp_path, monkeypatch, capsys
):
    """A full disk used to end in an OSError traceback with a truncated mesh left behind."""
    import errno

    import transplanter.scene as scene_package
    from transplanter.cli import main

    def full_disk(cfg, seed, out):
        (Path(out).parent / "assets").mkdir()
        (Path(out).parent / "assets" / "jaw.stl").write_bytes(b"solid half")  # cut short
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(scene_package, "export_scene", full_disk)
    assert main(["export", "paper", str(tmp_path / "scene.xml")]) == 5
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "No space left on device" in err[0]
    assert list(tmp_path.iterdir()) == []  # no truncated mesh, no staging directory
