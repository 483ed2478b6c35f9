"""Preflight: every taught point and straight move is checked before a trial starts."""

import pytest

from conftest import paper_scenario, variant
from transplanter.machine.kinematics import fivebar as kinematics
from transplanter.scenario.assemble import assemble, machine_config
from transplanter.scenario.preflight import check_machine
from transplanter.scenario.schema import ScenarioError, load_scenario


def test_paper_program_passes(paper_twin_config):
    check_machine(paper_twin_config.machine)  # raises on any failure


def test_unreachable_taught_point_is_refused_naming_the_key(tmp_path):
    path = variant(tmp_path, {"grip_mm = [90.0, 215.0]": "grip_mm = [90.0, 340.0]"})
    with pytest.raises(ScenarioError, match=r"taught.pickup\[4\].grip_mm = \[90, 340\] mm"):
        assemble(load_scenario(path))
    assemble(load_scenario(path), preflight=False)  # the firmware may still be run on it


def test_path_through_singular_region_refused(tmp_path):
    """Both ends reachable, the straight line between them not: refused before simulating."""
    path = variant(
        tmp_path,
        {
            "drop_mm = [0.0, 140.0]": "drop_mm = [-16.0, 84.0]",
            "approach_mm = [-90.0, 180.0]": "approach_mm = [-131.0, 107.0]",
            "grip_mm = [-90.0, 215.0]": "grip_mm = [-125.0, 110.0]",
        },
    )
    machine = machine_config(load_scenario(path))
    arm = machine.kinematics
    ends = kinematics.check_points(
        arm.geometry, arm.limits, [-0.016, -0.131, -0.125], [0.084, 0.107, 0.110]
    )
    assert ends.ok.all()  # every taught point on its own is fine
    with pytest.raises(
        ScenarioError,
        match=r"taught.pickup\[0\]: the move from .* leaves the workspace: elbow angle at B",
    ):
        check_machine(machine)


def test_first_move_from_home_is_checked():
    """The drop point is reachable, but not on a straight line from the homed position."""
    machine = machine_config(paper_scenario(**{"taught.drop_mm": [80.0, 100.0]}))
    with pytest.raises(ScenarioError, match="the first move, from the homed position .* to "):
        check_machine(machine)


def test_a_timestep_too_coarse_for_the_stepper_torque_law_is_refused():
    """Z's rotor rings on its field at 1716 rad/s: 1 ms (omega*dt 1.72) runs, 2 ms (3.43, past
    the explicit step's limit of 2, where the Z drive rings itself out of step) is refused
    before anything runs, naming the largest step that runs."""
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import ScenarioError, load_scenario

    assemble(load_scenario("paper", {"physics.timestep_ms": 1.0}))
    with pytest.raises(
        ScenarioError, match=r"timestep_ms = 2 is too coarse for the z stepper .*less than 1.17 ms"
    ):
        assemble(load_scenario("paper", {"physics.timestep_ms": 2.0}))
    # without the preflight the user takes the step as given
    config = assemble(load_scenario("paper", {"physics.timestep_ms": 2.0}), preflight=False)
    assert config.scene.timestep_s == 0.002


def test_a_fine_timestep_runs():
    """The torque law is consistent in time: a finer step is as valid as the default (the lag
    converges as the step shrinks, docs/drives.md), so it is not refused."""
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import load_scenario

    for fine in (0.05, 0.25, 0.5):
        config = assemble(load_scenario("paper", {"physics.timestep_ms": fine}))
        assert config.scene.timestep_s == pytest.approx(fine * 1e-3)


def test_a_taught_speed_the_sgf_cannot_reach_is_refused():
    """The SGF solves the kinematics of each 0.1 mm point in 198 us: no move exceeds
    505 mm/s, so a faster taught speed would silently run slower; it is refused, naming the
    key and the limit, and a faster controller raises the limit."""
    assemble(load_scenario("paper", {"taught.s_high_mm_s": 500.0}))
    with pytest.raises(
        ScenarioError, match=r"taught.s_high_mm_s = 600 is faster .* no move exceeds 505 mm/s"
    ):
        assemble(load_scenario("paper", {"taught.s_high_mm_s": 600.0}))
    with pytest.raises(ScenarioError, match=r"taught.s_low_mm_s = 510 is faster"):
        assemble(load_scenario("paper", {"taught.s_low_mm_s": 510.0}))
    faster = {"taught.s_high_mm_s": 600.0, "motion.compute_time_per_point_us": 100.0}
    assemble(load_scenario("paper", faster))  # 1,000 mm/s allowed


def test_a_program_that_passed_is_not_checked_again_in_the_process(monkeypatch, tmp_path):
    """A sweep's worker runs one setting over several seeds: the program is checked once;
    a refused one is refused every time."""
    from transplanter.scenario import preflight

    calls = []
    monkeypatch.setattr(preflight, "_passed", {})
    monkeypatch.setattr(preflight, "check_machine", lambda m: calls.append(m) or check_machine(m))
    for seed in (1, 2, 3):
        assemble(paper_scenario(**{"scenario.seed": seed}))
    assert len(calls) == 1
    assemble(paper_scenario(**{"taught.z_low_mm": 30.0}))  # another program: checked
    assert len(calls) == 2
    path = variant(tmp_path, {"grip_mm = [90.0, 215.0]": "grip_mm = [90.0, 340.0]"})
    for _ in range(2):
        with pytest.raises(ScenarioError, match=r"taught.pickup\[4\].grip_mm"):
            assemble(load_scenario(path))
    assert len(calls) == 4


def test_the_pickups_must_be_the_pickup_rows_cells(tmp_path):
    """A conveyor of 6 columns under the paper's 5 pickups used to pass every check and then
    knock pots over; a pickup taught beside its cell, or two on one cell, likewise."""
    from transplanter.scenario.assemble import assemble

    assemble(load_scenario("paper"))  # the paper's five pickups over its five cells
    with pytest.raises(ScenarioError, match=r"5 pickups are taught .* for the pickup row's 6 "
                       r"cells at x = -112.5, -67.5, -22.5, 22.5, 67.5, 112.5 mm"):  # fmt: skip
        assemble(load_scenario("paper", {"conveyor.cols": 6}))
    off = variant(tmp_path, {"grip_mm = [-45.0, 215.0]": "grip_mm = [-39.0, 215.0]"}, "off.toml")
    with pytest.raises(ScenarioError, match=r"taught.pickup\[1\].grip_mm = \[-39, 215\] is 6.0 mm"
                       r" from the nearest cell's centre, more than the 5.0 mm"):  # fmt: skip
        assemble(load_scenario(off))
    near = variant(tmp_path, {"grip_mm = [-45.0, 215.0]": "grip_mm = [-42.0, 216.0]"}, "n.toml")
    assemble(load_scenario(near))  # 3.2 mm off: within the pot's play
    two = variant(tmp_path, {"grip_mm = [-45.0, 215.0]": "grip_mm = [-90.0, 215.0]"}, "two.toml")
    with pytest.raises(ScenarioError, match=r"pickup\[0\] and taught.pickup\[1\] both grip"):
        assemble(load_scenario(two))
