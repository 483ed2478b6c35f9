"""The plug-in claws and the plug's physics on the standalone bench (docs/plug_claws.md):
the plug is held through contact only, the stripper drops it into the target cell, the
substrate's laws move hold and retention the expected way, the rotary setting decides which
leaves are struck, and the outcome is deterministic and converged in the timestep."""

import copy
import math

import mujoco
import numpy as np
import pytest

from transplanter.scene import kinds
from transplanter.scene.effectors import plug_claws
from transplanter.scene.effectors.plug_claws import ClawCycle, PlugClawsConfig
from transplanter.scene.plug_bench import (
    BenchConfig,
    build_bench,
    centred_seedling,
    measure_hold,
    model_xml,
    run_pick,
)
from transplanter.scene.plug_physics import PlugPhysics
from transplanter.scene.plug_substrate import PlugsConfig, Substrate, from_table
from transplanter.scene.plug_tray import draw_tray

OPTIMUM = PlugsConfig(moisture_pct=65.0, age_d=25.0)  # the paper's A1 B2
LOW_ACCEL = BenchConfig(extraction_accel_m_s2=20.0)


def pick(moisture=65.0, age=25.0, accel=20.0, **bench):
    return run_pick(
        PlugsConfig(moisture_pct=moisture, age_d=age),
        bench=BenchConfig(extraction_accel_m_s2=accel, **bench),
    )


# --- the model -------------------------------------------------------------------------------


def test_plug_claws_is_an_effector_kind_with_the_contract():
    module = kinds.effector("plug_claws")
    assert module is plug_claws
    for name in ("apply", "add_canopy_contact", "home_joints", "home_ctrl"):
        assert callable(getattr(module, name))
    cfg = PlugClawsConfig()
    assert plug_claws.home_joints(cfg) == {"rotary": 0.0, "claw_left": 0.0, "claw_right": 0.0}
    v = cfg.stroke_speed_m_s
    assert plug_claws.home_ctrl(cfg) == [0.0, -v, -v]


def test_apply_refuses_a_scene_without_the_claws():
    from transplanter.scene.build import robot_xml

    spec = mujoco.MjSpec.from_file(str(robot_xml()))  # the five-bar with its parallel jaws
    with pytest.raises(plug_claws.ClawsNotInScene, match="claws_mount"):
        plug_claws.apply(spec, PlugClawsConfig())


def test_apply_with_the_defaults_leaves_the_model_file_as_it_is():
    """plug_claws.xml holds the defaults: apply() with PlugClawsConfig() changes no number."""
    plain = mujoco.MjModel.from_xml_path(str(model_xml()))
    spec = mujoco.MjSpec.from_file(str(model_xml()))
    plug_claws.apply(spec, PlugClawsConfig())
    applied = spec.compile()
    for attr in ("body_pos", "body_quat", "jnt_range", "geom_pos", "geom_size"):
        np.testing.assert_allclose(getattr(applied, attr), getattr(plain, attr), atol=2e-6)
    for attr in (
        "actuator_gainprm",
        "actuator_biasprm",
        "actuator_ctrlrange",
        "actuator_forcerange",
    ):
        np.testing.assert_allclose(getattr(applied, attr), getattr(plain, attr), rtol=1e-4)


def test_the_cylinder_numbers_follow_pressure_bore_and_stroke_time():
    cfg = PlugClawsConfig()
    assert cfg.extend_force_n == pytest.approx(0.5e6 * math.pi / 4 * 0.01**2)  # 39.27 N
    assert cfg.retract_force_n == pytest.approx(0.5e6 * math.pi / 4 * (0.01**2 - 0.004**2))
    # 3 + 2 + 3 + 32 mm of vertical travel along a slide 12 deg from vertical
    assert cfg.stroke_m == pytest.approx(0.040 / math.cos(math.radians(12)))
    assert cfg.stroke_speed_m_s == pytest.approx(cfg.stroke_m / 0.150)
    higher = PlugClawsConfig(pressure_mpa=0.6)
    assert higher.extend_force_n == pytest.approx(cfg.extend_force_n * 1.2)


def test_the_bench_has_no_weld_or_equality_and_the_claws_meet_only_the_socket_and_leaves():
    tray = draw_tray(1)
    cell = next(c for c in tray.cells if c.kind == "cross_lr")
    model = build_bench(seedling=centred_seedling(cell, tray.geometry)).compile()
    assert model.neq == 0  # no weld, no connect, no joint coupling: contact only
    assert model.nexclude == 0 and model.npair == 0

    def collide(a, b):
        return bool(
            (model.geom_contype[a] & model.geom_conaffinity[b])
            or (model.geom_contype[b] & model.geom_conaffinity[a])
        )

    plug = model.body("plug").id
    plug_geoms = [i for i in range(model.ngeom) if model.geom_bodyid[i] == plug]
    for claw in plug_claws.CLAWS:
        met = sorted(model.geom(g).name for g in plug_geoms if collide(model.geom(claw).id, g))
        assert "plug_socket" in met and "plug_substrate" not in met
        assert all(n == "plug_socket" or n.startswith(("plug_leaf_", "plug_petiole_")) for n in met)
        tray = [i for i in range(model.ngeom) if "_wall" in (model.geom(i).name or "")]
        assert not any(collide(model.geom(claw).id, w) for w in tray)
    for stripper in plug_claws.STRIPPERS:
        assert collide(model.geom(stripper).id, model.geom("plug_substrate").id)


# --- the valve sequence ----------------------------------------------------------------------


def test_claw_cycle_timings():
    cfg = PlugClawsConfig()
    cycle = ClawCycle(cfg)
    assert cycle.rotate(0.0, 90.0) == pytest.approx(0.250)
    assert cycle.ctrl(0.125)[0] == pytest.approx(math.pi / 4)
    assert cycle.phase(0.1) == "rotating" and not cycle.ready(0.26)
    assert cycle.ready(0.28)  # 250 ms swing + 30 ms settle
    t_end = cycle.extend(0.3)
    assert t_end == pytest.approx(0.45)
    assert cycle.phase(0.4) == "extending" and cycle.phase(0.46) == "extended"
    assert cycle.ctrl(0.4)[1:] == pytest.approx([cfg.stroke_speed_m_s] * 2)
    assert cycle.ctrl(0.29)[1:] == pytest.approx([-cfg.stroke_speed_m_s] * 2)  # before: held back
    cycle.retract(1.0)
    assert cycle.ctrl(0.9)[1] > 0 and cycle.ctrl(1.0)[1] < 0
    assert cycle.phase(1.1) == "retracting" and cycle.phase(1.2) == "retracted"
    with pytest.raises(ValueError):
        cycle.rotate(2.0, 45.0)


# --- (a) a pick through contact ----------------------------------------------------------


def test_the_claws_hold_the_plug_through_lift_and_move_and_the_stripper_drops_it_in():
    r = run_pick(OPTIMUM, bench=LOW_ACCEL)
    seat = -3.0  # the plug's top, 3 mm below the tray's top
    # the claws went in 30-33 mm (32 nominal, less the plug pressed 1 mm onto its floor)
    assert 29.5 < r.tip_depth_mm < 33.0
    # lifted 100 mm with the claws, carried 150 mm sideways, lowered to 8 mm above its seat
    assert r.track_mm["lifted"][2] - seat == pytest.approx(100.0, abs=2.0)
    assert r.track_mm["moved"][0] == pytest.approx(150.0, abs=1.0)
    assert r.track_mm["retract"][2] - seat == pytest.approx(8.0, abs=2.0)
    # the stripper pushed it off the retracting claws, it fell into the target cell
    assert r.stripper_peak_n > 0.5
    assert r.held and r.in_target
    x, y, z = r.final_xyz_mm
    assert (x, y) == pytest.approx((150.0, 0.0), abs=1.0) and z == pytest.approx(seat, abs=1.0)
    assert 0.85 < r.retention < 0.99
    assert r.peak_load_n < r.pin_capacity_n


def test_the_neighbour_plug_stays_in_its_cell():
    spec = build_bench(OPTIMUM)
    model = spec.compile()
    data = mujoco.MjData(model)
    z0 = None
    for _ in range(300):
        mujoco.mj_step(model, data)
        z0 = z0 if z0 is not None else float(data.body("neighbour").xpos[2])
    assert float(data.body("neighbour").xpos[2]) == pytest.approx(z0, abs=5e-4)


# --- (b) the substrate decides --------------------------------------------------------------


def test_a_wet_young_plug_pulled_fast_is_dropped_the_optimum_is_held():
    wet = pick(moisture=85.0, age=20.0, accel=40.0)
    assert not wet.held and not wet.in_target and wet.retention == 0.0
    assert wet.dropped_at_s is not None and wet.dropped_at_s < wet.times_s["lifted"]
    best = pick(moisture=65.0, age=25.0, accel=20.0)
    assert best.held and best.in_target and best.retention > 0.80


def test_a_wet_plug_at_low_acceleration_arrives_with_less_substrate():
    wet = pick(moisture=85.0, age=20.0, accel=20.0)
    best = pick()
    assert wet.held and wet.in_target
    assert wet.retention < best.retention - 0.10
    assert wet.mass0_g > 2 * best.mass0_g  # 25 g against 11 g: water


# --- (c) monotone in the expected direction -----------------------------------------------


def test_retention_falls_with_moisture_and_acceleration_and_rises_with_age():
    by_moisture = [pick(moisture=w, accel=20.0).retention for w in (65.0, 75.0, 85.0)]
    assert by_moisture[0] > by_moisture[1] > by_moisture[2] > 0.0
    by_age = [pick(age=a, accel=20.0).retention for a in (20.0, 25.0, 30.0)]
    assert by_age[0] < by_age[1] < by_age[2]
    by_accel = [pick(accel=a).retention for a in (20.0, 30.0, 40.0)]
    assert by_accel[0] > by_accel[1] > by_accel[2]


def test_the_friction_hold_falls_with_moisture_and_rises_with_age():
    """What the contact alone carries (measured by pulling the lifted plug off the claws)."""
    by_moisture = [measure_hold(PlugsConfig(moisture_pct=w)) for w in (65.0, 75.0, 85.0)]
    assert by_moisture[0] > by_moisture[1] > by_moisture[2] > 2.0
    by_age = [measure_hold(PlugsConfig(moisture_pct=75.0, age_d=a)) for a in (20.0, 25.0, 30.0)]
    assert by_age[0] < by_age[1] < by_age[2]
    # the contact carries more than the substrate round the pins: the shear law decides drops
    for w in (65.0, 75.0, 85.0):
        sub = Substrate(PlugsConfig(moisture_pct=w))
        assert measure_hold(sub.cfg) > sub.pin_capacity_n


# --- (d) leaves and the rotary setting -------------------------------------------------------


@pytest.fixture(scope="module")
def crossing():
    tray = draw_tray(1)
    lr = next(c for c in tray.cells if c.kind == "cross_lr" and c.truth == "healthy_lr")
    ud = next(c for c in tray.cells if c.kind == "cross_ud" and c.truth == "healthy_ud")
    return centred_seedling(lr, tray.geometry), centred_seedling(ud, tray.geometry)


def test_at_0_deg_the_stripper_strikes_left_right_crossing_leaves_at_90_it_does_not(crossing):
    lr, ud = crossing
    struck = run_pick(OPTIMUM, bench=BenchConfig(rotary_deg=0.0), seedling=lr).leaf_damage
    spared = run_pick(OPTIMUM, bench=BenchConfig(rotary_deg=90.0), seedling=lr).leaf_damage
    assert len(struck) >= 1 and spared == []
    names = set(plug_claws.CLAWS) | set(plug_claws.STRIPPERS)
    for d in struck:
        assert d.by in names and d.leaf.startswith(("plug_leaf_", "plug_petiole_"))
        assert d.force_n > PlugClawsConfig().leaf_damage_force_n
    # an up-down crossing seedling: the converse
    assert run_pick(OPTIMUM, bench=BenchConfig(rotary_deg=0.0), seedling=ud).leaf_damage == []
    assert len(run_pick(OPTIMUM, bench=BenchConfig(rotary_deg=90.0), seedling=ud).leaf_damage) >= 1


def test_a_higher_damage_threshold_spares_the_leaves(crossing):
    lr, _ = crossing
    tough = PlugClawsConfig(leaf_damage_force_n=50.0)
    assert run_pick(OPTIMUM, tough, BenchConfig(rotary_deg=0.0), seedling=lr).leaf_damage == []


# --- (e) determinism, (f) timestep ------------------------------------------------------


def test_same_inputs_give_the_same_result_bit_for_bit(crossing):
    lr, _ = crossing
    a = run_pick(OPTIMUM, bench=LOW_ACCEL, seedling=lr)
    b = run_pick(OPTIMUM, bench=LOW_ACCEL, seedling=lr)
    assert a.retention == b.retention and a.peak_load_n == b.peak_load_n
    assert a.final_xyz_mm == b.final_xyz_mm and a.leaf_damage == b.leaf_damage
    assert a.track_mm == b.track_mm


@pytest.mark.parametrize(
    ("moisture", "age", "accel"), [(65.0, 25.0, 20.0), (75.0, 20.0, 40.0), (85.0, 20.0, 40.0)]
)
def test_the_outcome_is_converged_at_1_and_0_5_ms(moisture, age, accel):
    coarse = pick(moisture, age, accel, timestep_ms=1.0)
    fine = pick(moisture, age, accel, timestep_ms=0.5)
    assert (coarse.held, coarse.in_target) == (fine.held, fine.in_target)
    assert coarse.retention == pytest.approx(fine.retention, abs=0.005)
    assert coarse.peak_load_n == pytest.approx(fine.peak_load_n, rel=0.05)


def test_the_hold_is_converged_at_1_and_0_5_ms():
    assert measure_hold(OPTIMUM, timestep_ms=1.0) == pytest.approx(
        measure_hold(OPTIMUM, timestep_ms=0.5), rel=0.05
    )


# --- the substrate's laws --------------------------------------------------------------------


def test_the_plug_mass_comes_from_its_volume_and_wet_density():
    sub = Substrate(OPTIMUM)
    # 39 mm of a 30 -> 20 mm frustum below a 3 mm empty top: 24.0 cm^3
    assert sub.volume_m3 * 1e6 == pytest.approx(23.96, abs=0.02)
    assert sub.wet_density_kg_m3 == pytest.approx(160.0 / 0.35)
    assert sub.mass_kg * 1e3 == pytest.approx(10.95, abs=0.02)
    soaked = Substrate(PlugsConfig(moisture_pct=95.0))
    assert soaked.wet_density_kg_m3 == pytest.approx(160.0 + 900.0)  # capped at saturation


def test_the_laws_move_the_right_way():
    young, old = (Substrate(PlugsConfig(age_d=a)) for a in (10.0, 30.0))
    assert young.root_binding == 0.0 and 0.8 < old.root_binding < 0.9
    assert old.cohesion_pa > young.cohesion_pa and old.loose_fraction < young.loose_fraction
    dry, wet = (Substrate(PlugsConfig(moisture_pct=w)) for w in (60.0, 90.0))
    assert wet.cohesion_pa < dry.cohesion_pa and wet.wall_adhesion_pa > dry.wall_adhesion_pa
    assert wet.pin_friction < dry.pin_friction
    sub = Substrate(OPTIMUM)
    assert sub.lost_fraction(0.0) == 0.0
    losses = [sub.lost_fraction(f) for f in (0.5, 1.0, 2.0, 10.0)]
    assert losses == sorted(losses) and losses[-1] == pytest.approx(sub.loose_fraction)
    assert sub.cell_adhesion_n(0.0) > sub.cell_adhesion_n(0.02) > sub.cell_adhesion_n(0.05) == 0


def test_a_table_of_keys_is_read_strictly():
    cfg = from_table(PlugsConfig, {"moisture_pct": 75, "age_d": 30}, "plugs")
    assert (cfg.moisture_pct, cfg.age_d) == (75.0, 30.0)
    with pytest.raises(ValueError, match="moisture"):
        from_table(PlugsConfig, {"moisture": 75}, "plugs")
    with pytest.raises(ValueError):
        PlugsConfig(moisture_pct=100.0)


def test_the_cells_adhesion_loads_the_pins_and_the_loss_follows_the_peak_load():
    sticky = run_pick(OPTIMUM, bench=LOW_ACCEL)
    free = run_pick(
        PlugsConfig(moisture_pct=65.0, age_d=25.0, wall_adhesion_kpa=0.0), bench=LOW_ACCEL
    )
    # the adhesion (0.47 N at the optimum) is most of the peak load the pins carry
    assert sticky.peak_load_n - free.peak_load_n == pytest.approx(0.47, abs=0.1)
    assert free.retention > sticky.retention
    for r in (sticky, free):
        lost = Substrate(OPTIMUM).lost_fraction(r.peak_load_n)
        assert r.mass_g == pytest.approx(r.mass0_g * (1.0 - lost), rel=1e-12)
        assert r.retention == pytest.approx(1.0 - lost, rel=1e-12)


def test_too_little_pressure_leaves_the_claws_short_of_their_stops():
    weak = run_pick(OPTIMUM, PlugClawsConfig(pressure_mpa=0.05), LOW_ACCEL)
    full = run_pick(OPTIMUM, PlugClawsConfig(pressure_mpa=0.5), LOW_ACCEL)
    assert full.tip_depth_mm - weak.tip_depth_mm > 1.0
    assert run_pick(OPTIMUM, PlugClawsConfig(pressure_mpa=0.2), LOW_ACCEL).tip_depth_mm == (
        pytest.approx(full.tip_depth_mm, abs=0.05)
    )


def _bench_plug_with_substrate_lost():
    """The bench's plug after its pins carried 0.8 N (its mass and inertia cut by the loss)."""
    sub = Substrate(OPTIMUM)
    model = build_bench(OPTIMUM).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    physics = PlugPhysics(model, data, "plug", sub)
    physics.pin_load = lambda _data: 0.8  # the load a lift puts on the pins, without the lift
    physics.after_step(data, 0.0, carried=True)
    assert physics.mass_kg == pytest.approx(physics.mass0 * (1 - sub.lost_fraction(0.8)))
    assert physics.mass_kg < 0.95 * physics.mass0
    return model, data, physics


def test_a_cut_plug_mass_leaves_the_subtree_masses_as_mujoco_computes_them():
    model, data, _ = _bench_plug_with_substrate_lost()
    fresh = copy.deepcopy(model)
    mujoco.mj_setConst(fresh, mujoco.MjData(fresh))
    np.testing.assert_allclose(model.body_subtreemass, fresh.body_subtreemass, rtol=1e-12)


def test_a_dropped_plug_tumbling_in_the_air_keeps_its_angular_momentum():
    """Seed 8's tray: a plug that lost substrate, then fell off the pins tumbling (18 rad/s
    across its axis), spun up with no force on it and blew the state up 0.3 s later while the
    subtree masses were those of the compiled plug."""
    model, data, physics = _bench_plug_with_substrate_lost()
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    qa, va = physics.qadr, physics.vadr
    data.qpos[qa : qa + 7] = [0.0, 2.0, 20.0, 0.5053, -0.0546, -0.8573, 0.0819]  # far from all
    data.qvel[va : va + 6] = [-0.24, -0.04, -1.13, -1.49, -18.03, 1.72]  # seed 8's, at 80.3 s
    b = physics.body

    def spin(d):
        return np.linalg.norm(model.body_inertia[b] * d.qvel[va + 3 : va + 6])  # body frame

    l0 = spin(data)
    for _ in range(1000):
        mujoco.mj_step(model, data)
    assert data.time == pytest.approx(1.0)  # no reset
    assert spin(data) == pytest.approx(l0, rel=1e-3)
