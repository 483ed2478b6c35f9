"""Unit conversions: the G-code words' units (mm, mm/s, mm/min, ms) against the SI firmware."""

from pathlib import Path

import numpy as np
import pytest

from transplanter import units
from transplanter.machine.config import power_on_joints
from transplanter.machine.gcode import parse_line
from transplanter.machine.pgf import LinePhase, build_program
from transplanter.machine.rig import SimulatedEndstops
from transplanter.machine.sgf import SGF, SGFConfig
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import load_scenario

PAPER = Path(__file__).resolve().parents[1] / "scenarios" / "paper.toml"


def _homed_sgf():
    config = SGFConfig()
    sgf, endstops = SGF(config), SimulatedEndstops(config, power_on_joints(config))
    t = _run(sgf, endstops, "G28", 0.0)[1]
    return sgf, endstops, t


def _run(sgf, endstops, line, t):
    sgf.receive(line, t)
    t0 = t
    for _ in range(20_000):
        replies = sgf.poll(t, endstops.read(sgf.pulses_at(np.array([t]))[0]))
        if replies:
            return replies, t, t - t0
        t_next = sgf.next_event_time()
        t = t + 1e-3 if sgf.homing or t_next is None else max(t, t_next)
    raise AssertionError(f"{line} never answered")


def test_f_in_mm_per_min_and_s_in_mm_per_s_give_the_same_move():
    durations = {}
    for word in ("S20", "F1200"):  # 20 mm/s = 1200 mm/min
        sgf, endstops, t = _homed_sgf()
        replies, t, _ = _run(sgf, endstops, "G1 X0 Y200 Z100 S100", t)
        replies, t, took = _run(sgf, endstops, f"G1 Y220 {word}", t)
        assert replies == ["ok"]
        durations[word] = took
    assert durations["S20"] == pytest.approx(durations["F1200"], abs=1e-12)
    # 20 mm at 20 mm/s plus the 2 m/s^2 ramps (v/a = 10 ms): about 1.01 s
    assert durations["S20"] == pytest.approx(0.020 / 0.020 + 0.020 / 2.0, abs=5e-3)


def test_positions_are_mm_on_the_wire_and_m_inside():
    sgf, endstops, t = _homed_sgf()
    _run(sgf, endstops, "G1 X12.5 Y190 Z40 S100", t)
    np.testing.assert_allclose(sgf.position_xyz, [0.0125, 0.190, 0.040], atol=1e-15)
    assert np.all(sgf.position_xyz / units.M_PER_MM == pytest.approx([12.5, 190.0, 40.0]))


def test_dwell_p_is_milliseconds():
    sgf, endstops, t = _homed_sgf()
    _, _, took = _run(sgf, endstops, "G4 P375", t)
    assert took == pytest.approx(375 * units.S_PER_MS) == pytest.approx(0.375)


def test_pgf_writes_mm_mm_per_s_and_ms():
    machine = machine_config(load_scenario(PAPER))
    eeprom = machine.eeprom
    program = build_program(eeprom, machine.pgf)
    words = {line.phase: parse_line(line.text).words for line in program[:40]}
    to_drop = words[LinePhase.TO_DROP]
    mm = units.M_PER_MM
    assert to_drop["X"] == pytest.approx(eeprom.drop_xy_m[0] / mm, abs=5e-4)
    assert to_drop["Y"] == pytest.approx(eeprom.drop_xy_m[1] / mm, abs=5e-4)
    assert to_drop["Z"] == pytest.approx(eeprom.z_up_m / mm, abs=5e-4)
    assert to_drop["S"] == pytest.approx(eeprom.s_high_m_s / mm, abs=5e-4)  # mm/s
    assert words[LinePhase.LIFT]["S"] == pytest.approx(eeprom.s_low_m_s / mm, abs=5e-4)
    assert words[LinePhase.CLOSE_WAIT]["P"] == pytest.approx(
        machine.pgf.close_dwell_s / units.S_PER_MS, abs=5e-4
    )  # ms
    # paper.toml: drop_mm = [0.0, 140.0], s_high_mm_s = 150.0
    assert (to_drop["X"], to_drop["Y"], to_drop["S"]) == (0.0, 140.0, 150.0)


def test_conversion_factors_agree_with_each_other():
    assert units.MM_PER_MIN_TO_M_S * 60.0 == pytest.approx(units.M_PER_MM)
    assert 6000 * units.MM_PER_MIN_TO_M_S == pytest.approx(100 * units.M_PER_MM)
