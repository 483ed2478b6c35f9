"""transplanter.machine.kinematics.workspace and transplanter.scenario.reach: an arm's
workspace as its own kinematics' check decides it, and whether a job's key points fit in it
from some placement: every packaged cell's robot reaches its job; the robots refused the
trays are refused by the spans compared, not by a list."""

from __future__ import annotations

import numpy as np
import pytest

from transplanter import kinds
from transplanter.machine.kinematics.gantry import GantryKinematics
from transplanter.machine.kinematics.workspace import placement, workspace
from transplanter.scenario import reach
from transplanter.scenario.schema import ScenarioError, load_scenario, packaged_scenarios


def test_the_gantrys_workspace_is_its_travel_box():
    space = workspace(GantryKinematics())  # travel 300 x 260 x 155 mm (the [gantry] defaults)
    assert space.step_m == pytest.approx(0.010)
    # voxels centred at every 10 mm from each travel's low end to its high end
    np.testing.assert_allclose(space.span_m, [0.310, 0.260, 0.160], atol=1e-9)
    lo = space.origin + np.argwhere(space.reach).min(axis=0) * space.step_m
    np.testing.assert_allclose(lo, [-0.150, 0.040, 0.005], atol=0.0051)


def test_a_line_fits_only_where_and_as_it_is_turned():
    space = workspace(GantryKinematics())
    along = np.array([[x, 0.0, 0.0] for x in np.linspace(0, 0.290, 30)])
    fit = placement(space, along)
    assert fit.fits and fit.turn_deg == 0
    # 290 mm along y is longer than Y's 260 mm travel: it fits turned onto X
    fit = placement(space, along[:, [1, 0, 2]])
    assert fit.fits and fit.turn_deg in (90, 270)
    too_long = placement(space, along * 1.2)  # 348 mm: longer than either travel
    assert not too_long.fits and too_long.shift_m is None
    np.testing.assert_allclose(too_long.points_span_m, [0.348, 0, 0], atol=1e-9)
    # the shift found puts every point on a reachable voxel (the kinematics' own check)
    fit = placement(space, along)
    turned = along + fit.shift_m
    assert GantryKinematics().check(turned + [0.002, 0.0, 0.0]).ok.all()


def test_the_five_bars_workspace_is_decided_by_its_own_check():
    from transplanter.kinds import kinematics_class

    kin = kinematics_class("fivebar")()
    space = workspace(kin)
    idx = np.argwhere(space.reach)
    centres = space.origin + idx * space.step_m
    assert kin.check(centres).ok.all() and len(idx) > 1000
    outside = space.origin + np.argwhere(~space.reach) * space.step_m
    assert not kin.check(outside).ok.any()


RUNNABLE = [
    n for n in packaged_scenarios() if kinds.job(load_scenario(n).workcell.kind).uses_robot()
]


@pytest.mark.parametrize("name", RUNNABLE)
def test_every_packaged_cells_robot_reaches_its_jobs_key_points(name):
    sc = load_scenario(name)
    fit = reach.reach(sc)
    assert fit is not None and fit.fits, (name, fit)
    assert reach.reach_refusal(sc) is None


def test_a_bench_that_moves_no_robot_has_no_key_points():
    assert reach.reach(load_scenario("plug_bench")) is None


@pytest.mark.parametrize("robot", ["fivebar", "serial4", "gantry"])
def test_the_trays_are_out_of_these_robots_reach_and_the_trial_says_by_how_much(robot):
    sc = load_scenario("delta_refill", {"robot.kind": robot})
    why = reach.reach_refusal(sc)
    assert why.startswith(f"no placement of the {robot} robot reaches the plug_trays job's key")
    assert "they span 660 x 558 x 100 mm (x, y, z)" in why
    from transplanter.twin.delta_refill import require_delta

    with pytest.raises(ScenarioError, match="no placement of the") as info:
        require_delta(sc)
    assert why in str(info.value)


def test_a_users_larger_gantry_reaches_the_trays_and_is_refused_for_its_host():
    big = {"robot.kind": "gantry", "gantry.x_min_mm": -400.0, "gantry.x_max_mm": 400.0,
           "gantry.y_min_mm": -400.0, "gantry.y_max_mm": 400.0}  # fmt: skip
    sc = load_scenario("delta_refill", big)
    fit = reach.reach(sc)
    assert fit.fits and reach.reach_refusal(sc) is None
    np.testing.assert_allclose(fit.workspace_span_m, [0.810, 0.810, 0.160], atol=1e-9)
    from transplanter.twin.delta_refill import require_delta

    with pytest.raises(ScenarioError, match="its host drives the delta's own controller"):
        require_delta(sc)
