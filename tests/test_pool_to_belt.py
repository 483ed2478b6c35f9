"""The pool_to_belt workcell (seed 004's experiment): tomatoes queued in the sloping lane
settle with the lead one at the pick station, the next rolls in when it is lifted, sensor 1
tells a tomato at the station from an empty one, the belt carries a placed tomato away, the
draws are deterministic and within their ranges, and `[pool_to_belt]` reaches the physics.
No arm: the workcell's own world (floor, light) with apply/populate."""

import dataclasses
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from conftest import ROOT
from transplanter.machine.fuzzy_gripper import NO_ECHO, UltrasonicSensor
from transplanter.scenario.schema import ScenarioError, load_scenario
from transplanter.scene import kinds
from transplanter.scene.build import workcell_xml
from transplanter.scene.workcells import pool_to_belt as ptb

CELL = kinds.workcell("pool_to_belt")
SENSOR = UltrasonicSensor()


def world(cfg: ptb.PoolToBeltConfig, seed: int = 3):
    """The workcell with its tomatoes at a 1 ms step: (model, data, tomatoes)."""
    spec = mujoco.MjSpec.from_file(str(workcell_xml("pool_to_belt")))
    spec.option.timestep = 0.001
    CELL.apply(spec, cfg)
    tomatoes = CELL.populate(spec, cfg, seed, False)
    model = spec.compile()
    data = mujoco.MjData(model)
    for joint, value in CELL.home_joints(cfg).items():
        data.joint(joint).qpos[0] = value
    return model, data, tomatoes


def run(model, data, seconds: float, until=None) -> float | None:
    """Step `seconds`; the time (s from now) `until(data)` first held, else None."""
    start, when = data.time, None
    while data.time < start + seconds - 1e-9:
        mujoco.mj_step(model, data)
        if when is None and until is not None and until(data):
            when = data.time - start
    return when


def lift_to(model, data, name: str, xyz) -> None:
    """Take a tomato out (its free joint set to xyz, at rest), as the arm lifts it."""
    body = model.body(name)
    qadr = model.jnt_qposadr[body.jntadr[0]]
    vadr = model.jnt_dofadr[body.jntadr[0]]
    data.qpos[qadr : qadr + 7] = [*xyz, 1.0, 0.0, 0.0, 0.0]
    data.qvel[vadr : vadr + 6] = 0.0


def sensor_reading(model, data) -> float:
    mujoco.mj_forward(model, data)
    return SENSOR.reading(ptb.station_distances(model, data, SENSOR.beam_directions()))


def error_mm(data, tomato, cfg) -> float:
    return 1e3 * float(
        np.linalg.norm(data.body(tomato.name).xpos - ptb.station_xyz(cfg, tomato.diameter_m))
    )


def test_the_queue_settles_with_the_lead_tomato_at_the_station():
    cfg = ptb.PoolToBeltConfig()
    model, data, tomatoes = world(cfg)
    assert [t.name for t in tomatoes] == [f"tomato{i:02d}" for i in range(cfg.count)]
    run(model, data, 2.0)
    assert error_mm(data, tomatoes[0], cfg) < 3.0
    # the queue lies in the lane behind it, in order, on its centre line
    xs = [data.body(t.name).xpos[0] for t in tomatoes]
    assert xs == sorted(xs)
    assert all(abs(data.body(t.name).xpos[1] - cfg.station_y_m) < 0.002 for t in tomatoes)
    assert float(np.abs(data.qvel).max()) < 0.05  # at rest


@pytest.mark.parametrize("seed", [3, 11])
def test_the_next_tomato_rolls_in_when_the_lead_one_is_lifted(seed):
    cfg = ptb.PoolToBeltConfig()
    model, data, (lead, nxt, *_) = world(cfg, seed)
    run(model, data, 1.0)
    lift_to(model, data, lead.name, ptb.place_xyz(cfg, lead.diameter_m))  # onto the belt
    arrived = run(model, data, 1.5, lambda d: error_mm(d, nxt, cfg) < 3.0)
    assert arrived is not None and arrived < 1.5
    assert error_mm(data, nxt, cfg) < 3.0
    assert ptb.on_belt(model, data, cfg, lead.name)


def test_sensor_1_sees_a_tomato_at_the_station_and_nothing_when_the_lane_is_empty():
    cfg = ptb.PoolToBeltConfig(count=1)
    model, data, (lead,) = world(cfg)
    run(model, data, 0.5)
    near = sensor_reading(model, data)
    assert near < 0.05  # "Near"
    # the MuJoCo rangefinder on the same site agrees with the beam's axis
    axis = ptb.station_distances(model, data)[0]
    assert data.sensor("station_range").data[0] == pytest.approx(axis, abs=1e-9)
    assert axis == pytest.approx(cfg.sensor_offset_m - lead.radius_m, abs=0.003)
    lift_to(model, data, lead.name, [0.0, 0.5, 0.5])  # far away, out of the beam
    run(model, data, 0.01)
    empty = sensor_reading(model, data)
    assert empty == NO_ECHO or empty > 0.20


def test_a_tomato_placed_on_the_belt_is_carried_away():
    cfg = ptb.PoolToBeltConfig(count=1)
    model, data, (tomato,) = world(cfg)
    spot = ptb.place_xyz(cfg, tomato.diameter_m)
    lift_to(model, data, tomato.name, spot)
    ptb.start_belt(data)
    run(model, data, 3.0)
    carried = float(np.linalg.norm(data.body(tomato.name).xpos[:2] - spot[:2]))
    assert carried >= 0.050
    assert ptb.on_belt(model, data, cfg, tomato.name)
    assert ptb.belt_travel_m(data) == pytest.approx(3.0 * cfg.belt_speed_m_s, rel=0.05)
    # it went the way the belt runs (theta1 = 90 deg: world -x, away from the pool)
    assert data.body(tomato.name).xpos[0] < spot[0] - 0.04
    # a tomato still in the lane is not on the belt
    lift_to(model, data, tomato.name, ptb.station_xyz(cfg, tomato.diameter_m))
    mujoco.mj_forward(model, data)
    assert not ptb.on_belt(model, data, cfg, tomato.name)


def test_draws_are_deterministic_and_within_their_ranges():
    cfg = ptb.PoolToBeltConfig(count=12)
    a, b = ptb.draw_tomatoes(cfg, 7), ptb.draw_tomatoes(cfg, 7)
    assert a == b
    assert a != ptb.draw_tomatoes(cfg, 8)
    d = np.array([t.diameter_m for t in a])
    m = np.array([t.mass_kg for t in a])
    f = np.array([t.friction for t in a])
    assert np.all((cfg.diameter_min_m <= d) & (d <= cfg.diameter_max_m))
    assert np.all((cfg.mass_min_kg <= m) & (m <= cfg.mass_max_kg))
    assert np.all((cfg.friction_low <= f) & (f <= cfg.friction_high))
    assert len(set(d)) == len(d)
    # the lead one starts at the station, the others queued up the lane
    assert np.allclose(a[0].pos, ptb.station_xyz(cfg, a[0].diameter_m))
    assert all(p.pos[0] < q.pos[0] for p, q in zip(a, a[1:], strict=False))


def test_populate_builds_the_drawn_bodies():
    cfg = ptb.PoolToBeltConfig()
    model, _, tomatoes = world(cfg)
    for t in tomatoes:
        body = model.body(t.name)
        assert body.mass[0] == pytest.approx(t.mass_kg)
        assert model.geom(t.name).size[0] == pytest.approx(t.radius_m)
        assert model.geom(t.name).friction[0] == pytest.approx(t.friction)
    assert CELL.leaf_proxies(cfg, tomatoes) == ()
    assert CELL.MODEL == "pool_to_belt"
    assert CELL.JUDGE == "transplanter.twin.serial_arm:PoolToBeltJudge"


def test_scenario_keys_reach_the_physics():
    sc = load_scenario("serial_arm", {"pool_to_belt.belt_speed_mm_s": 40, "pool_to_belt.count": 2})
    cfg = ptb.pool_config(sc)
    assert cfg.belt_speed_m_s == pytest.approx(0.040) and cfg.count == 2
    assert ptb.pool_config(load_scenario("paper")) == ptb.PoolToBeltConfig()
    model, data, tomatoes = world(cfg)
    assert len(tomatoes) == 2
    ptb.start_belt(data)
    run(model, data, 1.0)
    assert ptb.belt_travel_m(data) == pytest.approx(0.040, rel=0.05)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ({"pool_to_belt.belt_speed_mm_s": 0}, "pool_to_belt.belt_speed_mm_s"),
        ({"pool_to_belt.diameter_min_mm": 80}, "diameter_min_mm must not be above"),
        ({"pool_to_belt.sensor_offset_mm": 30}, "inside the largest tomato"),
        ({"pool_to_belt.belt_width_mm": 60}, "does not fit between the belt's side walls"),
        ({"pool_to_belt.belt_speed_m_s": 0.02}, "pool_to_belt"),
    ],
)
def test_bad_values_are_refused_with_the_key_named(override, message):
    with pytest.raises(ScenarioError, match=message):
        load_scenario("serial_arm", override)
    with pytest.raises(ScenarioError, match="no kind of this scenario reads|wrong unit"):
        load_scenario("paper", override)  # the five-bar's job reads no [pool_to_belt]


def test_the_config_refuses_what_the_schema_refuses():
    with pytest.raises(ValueError, match="PoolToBeltConfig"):
        ptb.PoolToBeltConfig(diameter_min_m=0.08)
    with pytest.raises(ValueError, match="belt_width"):
        ptb.PoolToBeltConfig(belt_width_m=0.06)
    fields = {f.name for f in dataclasses.fields(ptb.PoolToBeltConfig)}
    from transplanter.scenario.schema import SECTIONS

    assert fields == {f.name for f in dataclasses.fields(SECTIONS["pool_to_belt"])}


def test_the_xml_holds_the_defaults_numbers():
    script = ROOT / "scripts" / "make_pool_to_belt_model.py"
    done = subprocess.run([sys.executable, str(script), "--check"], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
