"""The shoot's sway (transplanter.twin.shoot): its frequency, damping and droop as set, and the
same bend as a MuJoCo body on two sprung hinges carried through the same motion."""

import math

import mujoco
import numpy as np
import pytest

from transplanter.twin.shoot import ShootSway, segment_meets_box, shoot_params

UPRIGHT = (1.0, 0.0, 0.0, 0.0)
STILL = (0.0, 0.0, 0.0)
IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
# a bridge plate 70 x 20 x 6 mm (the palm) and a 40 mm stem 1.5 mm thick from a hinge 26 mm
# over its pot's centre: the shoot's top stands 66 mm over the pot's centre
BRIDGE_HALF = (0.035, 0.010, 0.003)
STEM, STEM_RADIUS = 0.040, 0.0015


def params(sway_hz=4.0, damping_ratio=0.2):
    return shoot_params(
        mass=0.003, com_height=0.034, spread=0.085, sway_hz=sway_hz,
        damping_ratio=damping_ratio, hinge=(0.0, 0.0, 0.026),
    )  # fmt: skip


def test_a_kicked_shoot_sways_at_its_frequency_and_dies_out_at_its_damping_ratio():
    sway = ShootSway(params(4.0, 0.2))
    sway.update(0.0, UPRIGHT, STILL, STILL)
    sway.update(0.01, UPRIGHT, (0.15, 0.0, 0.0), STILL)  # a 150 mm/s kick of the pot along x
    t, theta = [], []
    for k in range(2, 300):
        sway.update(0.01 * k, UPRIGHT, (0.15, 0.0, 0.0), STILL)
        t.append(0.01 * k)
        theta.append(sway.theta_y)
    theta = np.array(theta)
    assert np.all(np.abs(sway.theta_x) < 1e-12)  # a kick along x bends about y only
    assert theta[0] < 0  # the shoot lags its pot: it bends back, against the kick
    up = np.flatnonzero((theta[:-1] < 0) & (theta[1:] >= 0))
    period = np.diff(np.array(t)[up]).mean()
    assert 1 / period == pytest.approx(4.0 * math.sqrt(1 - 0.2**2), rel=0.03)
    peaks = [np.abs(theta[a:b]).max() for a, b in zip(up[:-1], up[1:], strict=True)]
    decrement = math.exp(-2 * math.pi * 0.2 / math.sqrt(1 - 0.2**2))
    assert peaks[1] / peaks[0] == pytest.approx(decrement, rel=0.1)
    # a kick of dv swings a shoot of inertia I by about m*h*dv/(I*w)
    p = params()
    expect = p.mass * p.com_height * 0.15 / (p.inertia * 2 * math.pi * 4.0)
    assert sway.peak_rad == pytest.approx(expect, rel=0.25)


def test_a_shoot_on_a_pot_lying_on_its_side_droops_by_its_weight():
    p = params(4.0, 0.5)
    sway = ShootSway(p)
    side = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)  # pot axis along +x
    for k in range(400):
        sway.update(0.01 * k, side, STILL, STILL)
    # the pot's x axis points down: the shoot droops towards it, about the pot's y axis,
    # until its spring holds its weight's torque: k th = m g h cos(th)
    droop = sway.theta_y
    assert p.stiffness * droop == pytest.approx(
        p.mass * 9.81 * p.com_height * math.cos(droop), rel=1e-9
    )
    assert 0.2 < droop < p.mass * 9.81 * p.com_height / p.stiffness
    # it starts where gravity holds it: a pot that lies still does not set it swaying
    assert sway.peak_rad == pytest.approx(droop, rel=1e-9)
    assert sway.theta_x == 0.0


def test_a_shoot_on_a_leaning_wall_stands_upright_when_the_wall_is_pulled_upright():
    """A crooked pot's shoot stands along its wall (`mount`): with the pot upright the wall
    leans 15 deg and gravity droops the shoot off the wall's axis; tilt the pot back by
    those 15 deg, so the wall is upright, and the shoot stands straight on it."""
    phi = math.radians(15.0)
    mount = [[math.cos(phi), 0, math.sin(phi)], [0, 1, 0], [-math.sin(phi), 0, math.cos(phi)]]
    leaning = ShootSway(params(), mount=mount)
    leaning.update(0.0, UPRIGHT, STILL, STILL)
    p = params()
    # k th = m g h sin(phi + th): gravity tips the shoot further off the leaning wall
    th = leaning.theta_y
    assert p.stiffness * th == pytest.approx(
        p.mass * 9.81 * p.com_height * math.sin(phi + th), rel=1e-9
    )
    back = (math.cos(-phi / 2), 0.0, math.sin(-phi / 2), 0.0)  # the pot tilted by -15 deg
    straight = ShootSway(params(), mount=mount)
    for k in range(100):
        straight.update(0.01 * k, back, STILL, STILL)
    assert abs(straight.theta_x) < 1e-12 and abs(straight.theta_y) < 1e-12


def test_a_stiff_shoot_is_advanced_in_substeps_and_stays_stable():
    sway = ShootSway(params(sway_hz=60.0))  # a period of 17 ms, updates every 10 ms
    sway.update(0.0, UPRIGHT, STILL, STILL)
    sway.update(0.01, UPRIGHT, (0.1, 0.0, 0.0), STILL)
    for k in range(2, 200):
        sway.update(0.01 * k, UPRIGHT, (0.1, 0.0, 0.0), STILL)
    assert sway.peak_rad < 0.2 and abs(sway.theta_y) < 1e-6


def _mujoco_bend(p, accel_profile, dt=0.001):
    """Peak bend of a MuJoCo shoot on two sprung hinges atop a 100 kg carriage pushed
    through the acceleration profile, and the carriage's velocities every 10 ms."""
    spring = f'stiffness="{p.stiffness}" damping="{p.damping}"'
    i_cm = p.inertia - p.mass * p.com_height**2
    xml = f"""
    <mujoco><option timestep="{dt}" integrator="implicitfast"/>
      <worldbody><body name="base">
        <joint name="bx" type="slide" axis="1 0 0"/><joint name="by" type="slide" axis="0 1 0"/>
        <inertial pos="0 0 0" mass="100" diaginertia="1 1 1"/>
        <body name="shoot" pos="0 0 {p.hinge[2]}">
          <joint name="hx" type="hinge" axis="1 0 0" {spring}/>
          <joint name="hy" type="hinge" axis="0 1 0" {spring}/>
          <inertial pos="0 0 {p.com_height}" mass="{p.mass}"
            diaginertia="{i_cm} {i_cm} 1e-7"/>
        </body></body></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    peak, samples = 0.0, []
    for k in range(int(round(1.2 / dt))):
        a = accel_profile(k * dt)
        d.qfrc_applied[:2] = 100.0 * np.asarray(a)
        mujoco.mj_step(m, d)
        peak = max(peak, math.acos(math.cos(d.qpos[2]) * math.cos(d.qpos[3])))
        if (k + 1) % 10 == 0:
            samples.append((d.time, (d.qvel[0], d.qvel[1], 0.0)))
    return peak, samples


@pytest.mark.parametrize(
    ("accel", "speed", "sway_hz"), [(1.5, 0.15, 4.0), (20.0, 0.15, 4.0), (20.0, 0.5, 2.0)]
)
def test_the_sway_bends_as_a_mujoco_shoot_on_sprung_hinges(accel, speed, sway_hz):
    """A move along a diagonal at the paper's 150 mm/s and 1,500 mm/s^2, at 2 g, and a soft
    shoot at 500 mm/s and 2 g (bent past the 45 deg damage limit)."""
    p = params(sway_hz)
    ramp = speed / accel

    def profile(t):
        a = accel if t < ramp else -accel if 0.3 <= t < 0.3 + ramp else 0.0
        return (a * 0.8, a * 0.6)

    peak_mj, samples = _mujoco_bend(p, profile)
    sway = ShootSway(p)
    sway.update(0.0, UPRIGHT, STILL, STILL)
    for t, v in samples:
        sway.update(t, UPRIGHT, v, STILL)
    assert peak_mj > math.radians(3)
    assert sway.peak_rad == pytest.approx(peak_mj, rel=0.1)


def test_segment_meets_box_by_slab_clipping():
    half = (0.01, 0.01, 0.01)
    assert segment_meets_box((0.0, 0.0, -0.03), (0.0, 0.0, 0.025), half)  # ends inside
    assert not segment_meets_box((0.0, 0.0, -0.03), (0.0, 0.0, 0.015), half)  # stops short
    assert segment_meets_box((-0.03, 0.0, 0.0), (0.06, 0.0, 0.0), half)  # passes through
    assert not segment_meets_box((-0.03, 0.02, 0.0), (0.06, 0.0, 0.0), half)  # beside it
    assert segment_meets_box((0.02, 0.0, -0.02), (-0.03, 0.0, 0.03), half)  # a slant across


def _pressed(bridge_z: float, bridge_y: float = 0.0):
    """A shoot at rest under a bridge whose underside is `bridge_z` over the pot's centre,
    `bridge_y` off its axis: the bend it forces (rad) and the sway."""
    sway = ShootSway(params())
    sway.update(0.0, UPRIGHT, STILL, STILL)
    box = (0.0, bridge_y, bridge_z + BRIDGE_HALF[2])
    bend = sway.press_out_of_box(
        (0.0, 0.0, 0.0), IDENTITY, STEM, STEM_RADIUS, box, IDENTITY, BRIDGE_HALF
    )
    return bend, sway


def test_a_bridge_over_the_shoot_leaves_it_alone():
    bend, sway = _pressed(0.026 + STEM + 0.002)  # 2 mm over the shoot's top
    assert bend == 0.0 and sway.bend_rad == pytest.approx(0.0, abs=1e-9)


def test_a_bridge_on_the_shoot_bends_it_out_of_its_way_and_the_bend_is_its_peak():
    """The bridge's underside 30 mm over the hinge of a 40 mm stem, its centre 5 mm behind
    the stem (-y): the stem is pushed away from that centre and leans out past the plate's
    front (6.5 mm ahead counting the stem's radius, 28.5 mm up: atan(6.5 / 28.5) = 12.8 deg)
    rather than ducking under it (acos(28.5 / 40) = 44.6 deg)."""
    bend, sway = _pressed(0.026 + 0.030, bridge_y=-0.005)
    assert math.degrees(bend) == pytest.approx(math.degrees(math.atan(0.0065 / 0.0285)), abs=0.2)
    assert sway.bend_rad == pytest.approx(bend, abs=1e-6)
    assert sway.peak_rad == pytest.approx(bend, abs=1e-6)
    assert sway.theta_x < 0 and sway.theta_y == pytest.approx(0.0, abs=1e-9)  # towards +y
    assert sway.rate_x == sway.rate_y == 0.0  # an inelastic push


def test_a_bridge_centred_low_over_the_shoot_bends_it_far_past_the_damage_limit():
    """4.5 mm over the hinge (where the solid palm of old stood over the rim at Z_low): the
    stem leans out past the plate's front, 11.5 mm ahead and 3 mm up counting its radius:
    atan(11.5 / 3) = 75 deg."""
    bend, _ = _pressed(0.026 + 0.0045)
    assert math.degrees(bend) == pytest.approx(math.degrees(math.atan(0.0115 / 0.003)), abs=0.2)
    assert math.degrees(bend) > 45.0


def test_a_pressed_shoot_springs_back_when_the_bridge_is_gone():
    _, sway = _pressed(0.026 + 0.030)
    for k in range(1, 400):
        sway.update(0.005 * k, UPRIGHT, STILL, STILL)
    assert math.degrees(sway.bend_rad) < 1.0
    assert math.degrees(sway.peak_rad) > 20.0
