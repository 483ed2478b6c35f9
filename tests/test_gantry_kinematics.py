"""transplanter.machine.kinematics.gantry: the Cartesian gantry's kinematics (the identity),
its travel as typed refusals, its belt and screw drives and its homing, from a scenario's
[gantry] and through the SGF (`plan_program`)."""

from __future__ import annotations

import numpy as np
import pytest

from transplanter.errors import RefusalReason
from transplanter.kinds import kinematics_class
from transplanter.machine.kinematics import UnreachableError
from transplanter.machine.kinematics.gantry import HOMING_DIRS, GantryKinematics
from transplanter.machine.planner import PlanError, plan_program
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import ScenarioError, load_scenario


def test_the_registry_makes_the_gantry_by_name():
    assert kinematics_class("gantry") is GantryKinematics


def test_the_joints_are_the_coordinates_both_ways():
    kin = GantryKinematics()
    pts = np.array([[-0.09, 0.215, 0.034], [0.1, 0.05, 0.15]])
    np.testing.assert_array_equal(kin.joints(pts), pts)
    np.testing.assert_array_equal(kin.point(kin.joints(pts)), pts)
    report = kin.check(pts)
    assert report.ok.all() and report.reasons == ("", "")


def test_a_point_past_an_axis_travel_is_refused_with_its_numbers():
    kin = GantryKinematics()
    report = kin.check([[0.0, 0.1, 0.1], [0.2, 0.1, 0.001]])
    assert report.ok.tolist() == [True, False]
    assert np.isnan(report.joints[1]).all()
    x, z = report.refusals[1]
    assert x.reason is RefusalReason.JOINT_LIMIT and x.subject == "x axis"
    assert (x.value, x.low, x.high) == pytest.approx((200.0, -150.0, 150.0))
    assert z.subject == "z axis" and z.value == pytest.approx(1.0) and z.low == pytest.approx(5.0)
    with pytest.raises(UnreachableError, match=r"point 1 .* x axis 200.0 mm outside \[-150, 150\]"):
        kin.require([[0.0, 0.1, 0.1], [0.2, 0.1, 0.1]])
    assert kin.limit_target([0.0, 0.35, 0.1]).subject == "y axis"
    assert kin.limit_target([0.0, 0.1, 0.1]) is None


def test_belts_and_screw_give_the_step_counts_of_their_leads():
    kin = GantryKinematics()
    x, y, z = kin.axes
    # a 40 mm belt lead at 200 x 8 microsteps: 40 a mm; the T8 screw at 200 x 16: 400 a mm
    assert x.drive.steps_per_unit == pytest.approx(40_000.0)
    assert y.drive.steps_per_unit == pytest.approx(40_000.0)
    assert z.drive.steps_per_unit == pytest.approx(400_000.0)
    assert all(a.linear for a in kin.axes)
    # homing: X and Y to the low ends of their travel, Z up
    assert HOMING_DIRS == (-1, -1, 1)
    assert (x.home_position, y.home_position, z.home_position) == (-0.150, 0.040, 0.160)
    assert kin.lower_hard_limits == ((2, 3),)
    np.testing.assert_array_equal(kin.steps_of_point([0.1, 0.2, 0.05]), [4000, 8000, 20000])


def test_the_scenario_section_makes_the_gantry_and_its_homing():
    s = load_scenario("gantry_pots", {"gantry.x_max_mm": 250.0, "gantry.belt_lead_mm": 60.0})
    machine = machine_config(s)
    kin = machine.kinematics
    assert isinstance(kin, GantryKinematics)
    assert kin.x_window_m == pytest.approx((-0.150, 0.250))
    assert kin.axes[0].drive.lead_m == pytest.approx(0.060)
    homing = machine.sgf.homing
    assert homing.dirs == (-1, -1, 1) and homing.first_cycle == (2,)
    assert homing.rate_hz == (1600.0, 1600.0, 16000.0)
    # a seek covers the whole travel and 20 mm more: 420 mm of X at 60 mm a revolution
    assert homing.max_steps[0] == round(0.420 * 200 * 8 / 0.060)


def test_a_travel_whose_ends_cross_is_refused_by_key():
    with pytest.raises(ScenarioError, match="gantry.y_min_mm must be below gantry.y_max_mm"):
        load_scenario("gantry_pots", {"gantry.y_min_mm": 400.0})


def test_the_sgf_homes_the_gantry_and_draws_its_lines():
    machine = machine_config(load_scenario("gantry_pots"))
    rows = plan_program(machine, "G28\nG90\nG1 X90 Y215 Z34 S150\nM114\n")
    # the line: net steps are the coordinate changes from where G28 left the slides (1 mm
    # off each switch) at 40 microsteps a mm on X and Y, 400 on Z
    homed = np.array([-0.149, 0.041, 0.159])
    target = np.array([0.090, 0.215, 0.034])
    per_m = np.array([40_000.0, 40_000.0, 400_000.0])
    np.testing.assert_array_equal(rows[2].steps, np.rint(target * per_m) - np.rint(homed * per_m))
    # 308 mm of diagonal at 150 mm/s: Z's 125 mm at its 20 kHz (50 mm/s) bounds the line
    length = float(np.linalg.norm(target - homed))
    assert rows[2].duration_s >= 0.125 / 0.050 - 1e-9
    assert rows[2].duration_s > length / 0.150
    assert rows[3].replies[0].startswith("X:90.000 Y:215.000 Z:34.000")


def test_the_sgf_refuses_a_line_past_the_travel():
    machine = machine_config(load_scenario("gantry_pots"))
    # the target is refused before the line is drawn (RepRapFirmware's LimitPosition)
    with pytest.raises(PlanError, match=r"error:33 x axis 200.0 mm outside \[-150, 150\]") as info:
        plan_program(machine, "G28\nG1 X200 Y100 Z50 S100\n")
    assert info.value.line_no == 2


def test_the_default_section_homes_at_the_rate_the_steppers_follow():
    """A gantry scenario that leaves out the homing rates gets the packaged scenario's 1600
    microsteps/s, the rate at which X follows from rest (tests/test_gantry_trial.py)."""
    import tomllib

    from conftest import ROOT

    path = ROOT / "scenarios" / "gantry_pots.toml"
    packaged = tomllib.loads(path.read_text())["gantry"]
    rates = machine_config(load_scenario("gantry_pots")).sgf.homing
    from transplanter.scenario.schema import DEFAULT_SECTIONS

    for key in ("homing_rate_xy_hz", "homing_locate_rate_xy_hz"):
        assert DEFAULT_SECTIONS["gantry"][key] == packaged[key]
    assert rates.rate_hz[:2] == (1600.0, 1600.0)


def test_the_class_defaults_are_the_sections_defaults():
    """GantryKinematics() and the scene's GantryParams() (a gantry built in code, without a
    scenario) are the catalogue build of the [gantry] section's defaults, the one place
    those numbers are given (its kind module's SECTIONS)."""
    from transplanter.kinds.robots.gantry import SECTIONS
    from transplanter.scene.robots.gantry import GantryParams

    d = SECTIONS["gantry"].defaults
    windows = [v / 1e3 for a in "xyz" for v in (d[f"{a}_min_mm"], d[f"{a}_max_mm"])]
    arm, params = GantryKinematics(), GantryParams()
    assert [*arm.x_window_m, *arm.y_window_m, *arm.z_window_m] == pytest.approx(windows)
    assert [*params.x_window_m, *params.y_window_m, *params.z_window_m] == pytest.approx(windows)
    assert params.belt_lead_m == pytest.approx(d["belt_lead_mm"] / 1e3)
    assert arm.drives_xyz[0].lead_m == pytest.approx(d["belt_lead_mm"] / 1e3)
    assert arm.drives_xyz[0].microsteps == d["belt_microsteps"]
    for name in ("bridge_mass_kg", "carriage_mass_kg", "ram_mass_kg", "guide_friction_n"):
        assert getattr(params, name) == pytest.approx(d[name]), name
    assert params.beam_height_m == pytest.approx(d["beam_height_mm"] / 1e3)
