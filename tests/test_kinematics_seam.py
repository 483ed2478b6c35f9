"""The kinematics seam: a kind of arm written only here (a Cartesian XYZ gantry on three lead
screws) is registered by name and drives the whole firmware side: the scenario picks it with
`[robot] kind`, the SGF homes it, interpolates its moves and refuses what it cannot reach, and
`transplanter plan` plans a G-code file with it. Nothing outside this file knows the gantry."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from transplanter import cli
from transplanter.errors import Refusal, RefusalReason, TransplanterError
from transplanter.machine import kinematics as registry
from transplanter.machine.axes import Axis
from transplanter.machine.homing import HomingConfig
from transplanter.machine.kinematics import Kinematics, ReachReport, UnreachableError
from transplanter.machine.kinematics.base import as_points
from transplanter.machine.planner import PlanError, plan_program
from transplanter.machine.steppers import StepperDrive
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import ScenarioError, load_scenario

LEAD_M = 0.008  # T8 screws: 400 microsteps per mm at 1/16


@dataclass(frozen=True)
class GantryKinematics(Kinematics):
    """X, Y, Z slides on lead screws: joints are the coordinates."""

    kind = "test_gantry"
    x_max_m: float = 0.300
    y_max_m: float = 0.250
    z_min_m: float = 0.005
    z_max_m: float = 0.160

    @property
    def axes(self) -> tuple[Axis, ...]:
        windows = ((0.0, self.x_max_m), (0.0, self.y_max_m), (self.z_min_m, self.z_max_m))
        return tuple(
            Axis(name, StepperDrive(name, ratio=1.0, lead_m=LEAD_M), hi, (lo, hi))
            for name, (lo, hi) in zip("xyz", windows, strict=True)
        )

    def joints(self, xyz) -> np.ndarray:
        return np.asarray(xyz, dtype=np.float64).copy()

    def point(self, joints) -> np.ndarray:
        return np.asarray(joints, dtype=np.float64).copy()

    def check(self, xyz) -> ReachReport:
        pts = as_points(xyz)
        refusals = []
        for p in pts:
            out = []
            for axis, value in zip(self.axes, p, strict=True):
                lo, hi = axis.window
                if not lo <= value <= hi:
                    out.append(
                        Refusal(
                            RefusalReason.JOINT_LIMIT, f"{axis.name} slide", value * 1e3,
                            lo * 1e3, hi * 1e3, "mm",
                        )
                    )  # fmt: skip
            refusals.append(tuple(out))
        ok = np.array([not r for r in refusals])
        return ReachReport(joints=pts.copy(), ok=ok, refusals=tuple(refusals))

    @classmethod
    def from_scenario(cls, scenario) -> GantryKinematics:
        return cls(z_min_m=scenario.limits.z_min_m, z_max_m=scenario.limits.z_max_m)

    @classmethod
    def homing_from_scenario(cls, scenario) -> HomingConfig:
        return HomingConfig(rate_hz=(8000.0, 8000.0, 8000.0), dirs=(1, 1, 1), first_cycle=(2,))


@pytest.fixture
def gantry():
    registry.register(GantryKinematics.kind, GantryKinematics)
    yield GantryKinematics
    registry._REGISTERED.pop(GantryKinematics.kind, None)


PROGRAM = """G28
G90
G1 X100 Y50 Z40 S50
G1 X250 Y200 S100 ; a diagonal at the gantry's far corner, out of the five-bar's reach
G1 Z120 S30
M114
"""


def _gantry_machine():
    return machine_config(load_scenario("paper", {"robot.kind": GantryKinematics.kind}))


def test_the_scenario_builds_the_registered_kind(gantry):
    machine = _gantry_machine()
    assert isinstance(machine.kinematics, GantryKinematics)
    assert [a.name for a in machine.kinematics.axes] == ["x", "y", "z"]
    # homing's unset pull-offs come from the drives: 1 mm of each slide
    assert machine.sgf.homing.pulloff_steps == (400, 400, 400)


def test_plan_runs_a_program_through_the_sgf_with_the_gantry(gantry):
    rows = plan_program(_gantry_machine(), PROGRAM)
    assert [row.line_no for row in rows] == [1, 2, 3, 4, 5, 6]
    home = np.array([0.300, 0.250, 0.160])
    pulloff = 0.001
    homed = home - pulloff
    # net steps of each line are the coordinate changes at 400 microsteps per mm
    targets = [(0.100, 0.050, 0.040), (0.250, 0.200, 0.040), (0.250, 0.200, 0.120)]
    previous = homed
    for row, target in zip(rows[2:5], targets, strict=True):
        expected = np.rint(np.array(target) / LEAD_M * 3200) - np.rint(previous / LEAD_M * 3200)
        np.testing.assert_array_equal(row.steps, expected)
        previous = np.array(target)
    # the first move: 200 mm along x at 50 mm/s takes at least 4 s
    assert rows[2].duration_s > math.dist(homed, targets[0]) / 0.050
    assert rows[5].replies[0].startswith("X:250.000 Y:200.000 Z:120.000 A:")


def test_the_gantry_refuses_what_it_cannot_reach_with_typed_reasons(gantry):
    with pytest.raises(PlanError) as info:
        plan_program(_gantry_machine(), "G28\nG1 X350 Y10 Z50 S50\n")
    assert info.value.line_no == 2
    assert "error:33" in str(info.value)
    # every interpolated point is checked: the first one past the slide's end is named
    assert "x slide 300.1 mm outside [0, 300] mm" in str(info.value)
    assert "interpolated point 50" in str(info.value)
    kin = GantryKinematics()
    with pytest.raises(UnreachableError) as err:
        kin.require([[0.1, 0.1, 0.1], [0.1, 0.3, 0.1]])
    assert err.value.index == 1
    (refusal,) = err.value.refusals
    assert refusal.reason is RefusalReason.JOINT_LIMIT and refusal.subject == "y slide"
    assert refusal.as_dict()["high"] == pytest.approx(250.0)
    assert isinstance(err.value, TransplanterError)


def test_transplanter_plan_prints_the_gantry_plan(gantry, tmp_path, capsys):
    program = tmp_path / "gantry.gcode"
    program.write_text(PROGRAM)
    status = cli.main(
        ["plan", str(program), "--scenario", "paper", "--set", "robot.kind=test_gantry"]
    )
    out = capsys.readouterr().out
    assert status == 0
    assert "total" in out and "G1 X250 Y200 S100" in out


def test_an_unknown_kind_is_refused_with_the_known_ones():
    known = "known kinds: delta, fivebar, gantry, serial4"
    with pytest.raises(ScenarioError, match=f"unknown robot kind 'delta_x'; {known}"):
        machine_config(load_scenario("paper", {"robot.kind": "delta_x"}))


def test_a_kind_that_cannot_be_made_from_a_scenario_is_refused_by_name():
    @dataclass(frozen=True)
    class NoScenario(GantryKinematics):
        kind = "test_no_scenario"

        from_scenario = classmethod(Kinematics.from_scenario.__func__)

    registry.register(NoScenario.kind, NoScenario)
    try:
        with pytest.raises(ScenarioError, match="'test_no_scenario' .* cannot be made from"):
            machine_config(load_scenario("paper", {"robot.kind": "test_no_scenario"}))
    finally:
        registry._REGISTERED.pop(NoScenario.kind, None)
