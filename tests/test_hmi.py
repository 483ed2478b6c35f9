"""The HMI: the 20x4 LCD and 4x4 keypad teach mode (transplanter.machine.hmi) and running a trial
from the image it writes (config.with_eeprom)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import ROOT, paper_scenario
from transplanter.errors import Refusal, RefusalReason
from transplanter.machine.eeprom import EepromImage
from transplanter.machine.hmi import (
    KEYS,
    LCD_COLS,
    LCD_ROWS,
    Hmi,
    KeyScriptError,
    parse_keys,
    refusal_note,
    run_keys,
    sgf_note,
    terminal_key,
)
from transplanter.scenario.assemble import EEPROM_OVERRIDE, assemble, machine_config, with_eeprom
from transplanter.scenario.schema import ScenarioError

TEACH_PAPER = ROOT / "tests" / "hmi" / "teach_paper.keys"


@pytest.fixture(scope="module")
def machine():
    return machine_config(paper_scenario())


@pytest.fixture
def hmi(machine):
    return Hmi(machine)


def keys(hmi: Hmi, text: str) -> Hmi:
    return run_keys(hmi, parse_keys(text))


def moves(hmi: Hmi) -> list[str]:
    return [line for _, line, _ in hmi.port.log if line.startswith("G1")]


# -- key scripts -------------------------------------------------------------------------


def test_key_scripts_skip_spaces_and_comments():
    assert parse_keys("1 0 5#") == ["1", "0", "5", "#"]
    assert parse_keys("12 ; a comment with # and x\n *D\n") == ["1", "2", "*", "D"]
    assert len(KEYS) == 16 and set(KEYS) == set("0123456789ABCD*#")


@pytest.mark.parametrize(
    ("text", "where"),
    [("1 0 x#", "position 5"), ("1#\n 2a", "line 2, column 3"), ("1\u0662", "position 2")],
)
def test_a_bad_key_is_refused_with_its_position_and_the_valid_keys(text, where):
    with pytest.raises(KeyScriptError, match=where) as caught:
        parse_keys(text, "--keys")
    assert "0-9 A B C D * #" in str(caught.value)


def test_press_refuses_a_non_key(hmi):
    with pytest.raises(ValueError, match="not a key"):
        hmi.press("E")


# -- power-on and the LCD ----------------------------------------------------------------


def test_power_on_homes_the_sgf_and_shows_the_menu(hmi, machine):
    sgf = machine.sgf
    home = sgf.kinematics.point_of_steps(sgf.homed_steps)
    np.testing.assert_allclose(hmi.position, home, atol=1e-6)
    np.testing.assert_array_equal(hmi.steps, sgf.homed_steps)
    assert [line for _, line, _ in hmi.port.log][:2] == ["G28", "G90"]
    assert hmi.port.sgf.homed
    assert hmi.lcd == (
        "Homed X0 Y79 Z159   ",
        ">1 Pickups  Mpp --- ",
        " 2 Drop point       ",
        " 3 Z_up / Z_low     ",
    )


def test_every_screen_is_four_ascii_lines_of_twenty(machine):
    hmi = Hmi(machine)
    screens = []
    run_keys(hmi, parse_keys(TEACH_PAPER.read_text()), lambda i, k, h: screens.append(h.lcd))
    for screen in screens:
        assert len(screen) == LCD_ROWS
        assert all(len(line) == LCD_COLS and line.isascii() for line in screen)


def test_menus_scroll_with_a_and_b_and_back_with_star(hmi):
    keys(hmi, "BBB")
    assert hmi.lcd[0].startswith("MENU") and hmi.lcd[0].endswith("4/6")
    assert ">4 Speeds" in "".join(hmi.lcd)
    keys(hmi, "BBB")  # stops at the last item
    assert hmi.lcd[-1].startswith(">6 Write EEPROM")
    keys(hmi, "A#")  # 5 Home arm (G28)
    assert hmi.lcd[0].startswith("Homed")
    keys(hmi, "3")
    assert hmi.lcd[0].startswith("Z LEVELS")
    keys(hmi, "*")
    assert hmi.lcd[0].startswith("MENU")
    keys(hmi, "1 4")
    assert hmi.lcd[0] == "Set M_pp first: 0".ljust(20)
    keys(hmi, "C")
    assert hmi.lcd[0] == "Key C: no use here".ljust(20)


# -- jogging -------------------------------------------------------------------------------


def test_jog_goes_to_the_next_multiple_of_the_step(hmi):
    keys(hmi, "2")  # Drop point
    keys(hmi, "1")  # jog its position
    assert hmi.lcd[0].startswith("Drop pos") and hmi.lcd[0].endswith("s10")
    y0 = hmi.position[1]
    keys(hmi, "2")
    assert hmi.position[1] == pytest.approx(0.080) and y0 < 0.080
    keys(hmi, "5")
    assert hmi.lcd[3] == "Step 1 mm".ljust(20) and hmi.lcd[0].endswith("s1")
    keys(hmi, "2")
    assert hmi.position[1] == pytest.approx(0.081)
    keys(hmi, "5 2 8 8")  # step 0.1
    assert hmi.position[1] == pytest.approx(0.0809)
    keys(hmi, "5 8")  # step 10 again: down to the next multiple of 10 mm
    assert hmi.lcd[0].endswith("s10")
    assert moves(hmi) == [
        "G1 X0.0 Y80.0 Z159.0 S20",
        "G1 X0.0 Y81.0 Z159.0 S20",
        "G1 X0.0 Y81.1 Z159.0 S20",
        "G1 X0.0 Y81.0 Z159.0 S20",
        "G1 X0.0 Y80.9 Z159.0 S20",
        "G1 X0.0 Y80.0 Z159.0 S20",
    ]
    assert hmi.lcd[1:3] == ("X    0.0  Y   80.0  ", "Z  159.0  #sto *bk  ")
    np.testing.assert_allclose(hmi.port.sgf.position_xyz, [0.0, 0.080, 0.159], atol=1e-12)


def test_a_jog_beyond_the_arm_limits_is_refused_on_the_lcd_and_does_not_move(hmi):
    keys(hmi, "2 1")
    before, steps = hmi.position.copy(), hmi.port.sgf.logical_steps
    raw = hmi.port.sgf.raw_pulses
    keys(hmi, "4")  # X- from the home position: elbow B folds past its limit
    assert hmi.lcd[3] == "NO elbow B 14.98<15".ljust(20)
    assert "elbow angle at B 14.98 deg outside [15, 165] deg" in hmi.last_refusal
    assert moves(hmi) == []  # checked before anything was sent
    np.testing.assert_array_equal(hmi.position, before)
    np.testing.assert_array_equal(hmi.port.sgf.logical_steps, steps)
    np.testing.assert_array_equal(hmi.port.sgf.raw_pulses, raw)
    keys(hmi, "6")  # the next key clears the reason; X+ is refused the same way
    assert hmi.lcd[3].startswith("NO ")
    keys(hmi, "2")  # Y+ is fine
    assert hmi.lcd[3] == "X4/6 Y8/2 Z9/3 5stp "
    assert len(moves(hmi)) == 1


def test_a_jog_past_the_z_range_is_refused(hmi):
    keys(hmi, "2 1 3")  # Z 159 -> 160, limit switch 3
    assert hmi.position[2] == pytest.approx(0.160)
    keys(hmi, "3")
    assert hmi.lcd[3] == "NO Z 170 > 160".ljust(20)
    assert hmi.last_refusal == "Z 170.000 mm outside [5, 160] mm"
    assert hmi.position[2] == pytest.approx(0.160)
    keys(hmi, "5 5")  # step 0.1: still above
    keys(hmi, "3")
    assert hmi.lcd[3] == "NO Z 160.1 > 160".ljust(20)
    assert len(moves(hmi)) == 1


def test_motor_limits_are_named_far_out(hmi):
    keys(hmi, "2 1" + "2" * 18 + "6" * 13)  # up to Y 250, then along +X to the limit
    assert hmi.lcd[3] == "NO motor1 79.97<80".ljust(20)
    assert hmi.position[0] == pytest.approx(0.120)


def test_the_sgfs_own_refusal_is_shown(hmi, monkeypatch):
    monkeypatch.setattr(hmi, "check_move", lambda target: None)  # skip the HMI's check
    keys(hmi, "2 1")
    before = hmi.position.copy()
    keys(hmi, "4")
    assert moves(hmi) == ["G1 X-10.0 Y79.0 Z159.0 S20"]
    assert hmi.port.log[-2][2][-1].startswith("error:33")
    assert hmi.lcd[3] == "SGF33 bad target".ljust(20)  # the pendant reads the wire's code
    assert hmi.last_refusal.startswith("error:33 target position not reachable")
    np.testing.assert_array_equal(hmi.position, before)


def test_refusals_fit_the_lcd_from_their_numbers():
    unreach = Refusal(RefusalReason.OUT_OF_WORKSPACE, "|C-O1|", 0.4, 0.08, 0.32, "m")
    assert unreach.short() == "out of reach"
    assert Refusal(RefusalReason.ILL_CONDITIONED, "condition", 12.3, None, 10).short() == (
        "near singularity"
    )
    transmission = Refusal(
        RefusalReason.PARALLEL_SINGULARITY, "transmission angle", 151.2, 30.0, 150.0, "deg",
        label="transm.",
    )  # fmt: skip
    assert transmission.short() == "transm. 151.2>150"
    assert transmission.short(16) == "transm.151.2>150"
    assert transmission.short(13) == "transm. limit"
    assert transmission.short(12) == "transm."
    assert sgf_note("error:9 position unknown: home first with G28") == "SGF9 not homed"
    assert refusal_note("x" * 50) == "NO " + "x" * 17


# -- numeric entry --------------------------------------------------------------------------


def test_numeric_entry_checks_the_range_and_the_format(hmi):
    keys(hmi, "1 0")
    assert hmi.lcd == (
        "Pickups M_pp        ",
        "1-10 now ---        ",
        "new _               ",
        "D=. C=del #ok *back ",
    )
    keys(hmi, "11#")
    assert hmi.lcd[3] == "Range 1-10".ljust(20) and hmi.data.m_pp is None
    keys(hmi, "CC0#")
    assert hmi.lcd[3].startswith("Range 1-10")
    keys(hmi, "C D")
    assert hmi.lcd[3] == "Whole number".ljust(20)
    keys(hmi, "#")
    assert hmi.lcd[3] == "Type a value".ljust(20)
    keys(hmi, "5#")
    assert hmi.data.m_pp == 5 and hmi.lcd[0] == "Saved M_pp 5".ljust(20)
    assert hmi.lcd[1] == ">0 Mpp (count) 5    "


def test_z_levels_stay_in_the_z_range_and_in_order(hmi, machine):
    keys(hmi, "3 1 170#")
    assert hmi.lcd[1] == "5-160 now ---".ljust(20) and hmi.lcd[3] == "Range 5-160".ljust(20)
    keys(hmi, "CCC60#")
    assert hmi.data.z_up == pytest.approx(0.060)
    keys(hmi, "2 60#")
    assert hmi.lcd[3] == "Z_low>=Z_up 60".ljust(20) and hmi.data.z_low is None
    keys(hmi, "C C 34D1234#")
    assert hmi.lcd[3] == "Max 3 decimals".ljust(20)
    keys(hmi, "C#")
    assert hmi.data.z_low == pytest.approx(0.034123)
    keys(hmi, "1 34#")
    assert hmi.lcd[3] == "Z_up<=Z_low 34.123".ljust(20) and hmi.data.z_up == pytest.approx(0.06)
    keys(hmi, "*")  # cancel keeps the old value
    assert hmi.lcd[0].startswith("Z LEVELS") and hmi.data.z_up == pytest.approx(0.06)


def test_angles_and_speeds_have_their_eeprom_ranges(hmi):
    keys(hmi, "2 2 180D5#")
    assert hmi.lcd[3] == "Range 0-180".ljust(20)
    keys(hmi, "CC#")
    assert hmi.data.drop_wrist == 180.0
    keys(hmi, "2 1D234#")
    assert hmi.lcd[3] == "Max 2 decimals".ljust(20)
    keys(hmi, "* * 4 2 6553D6#")
    assert hmi.lcd[1] == "0.1-6553.5 now ---".ljust(20)
    assert hmi.lcd[3] == "Range 0.1-6553.5".ljust(20)
    keys(hmi, "CCCCCC0D05#")
    assert hmi.lcd[3] == "Max 1 decimals".ljust(20)
    keys(hmi, "C#")
    assert hmi.lcd[3] == "Range 0.1-6553.5".ljust(20)
    keys(hmi, "CCC 123456789")
    assert hmi.lcd[2] == "new 12345678_".ljust(20) and hmi.lcd[3] == "Max 8 characters".ljust(20)
    keys(hmi, "CCCCCCCC 150D5#")
    assert hmi.data.s_high == pytest.approx(0.1505)


# -- writing the image ----------------------------------------------------------------------


def test_the_scripted_session_teaches_the_paper_image_byte_for_byte(machine, tmp_path):
    out = tmp_path / "taught.eeprom"
    hmi = Hmi(machine, out)
    run_keys(hmi, parse_keys(TEACH_PAPER.read_text()))
    assert hmi.writes == 1
    assert hmi.lcd[3].startswith("Written CRC ")
    expected = machine_config(paper_scenario()).eeprom.to_bytes()
    assert out.read_bytes() == expected == hmi.image_bytes
    assert hmi.lcd[3] == f"Written CRC {int.from_bytes(expected[232:236], 'little'):08x}"
    assert EepromImage.load(out) == machine.eeprom
    assert [p.name for p in tmp_path.iterdir()] == ["taught.eeprom"]  # no temporary left


def test_write_refuses_an_incomplete_image_and_names_what_is_missing(hmi):
    keys(hmi, "6#")
    assert hmi.lcd[3] == "NO M_pp not set".ljust(20) and hmi.writes == 0
    keys(hmi, "* 1 0 2# *")
    keys(hmi, "3 1 60# 2 34# * 4 1 60# 2 150# * 2 2 135# * 6#")
    assert hmi.lcd[3] == "NO drop point not set"[:20]


def test_write_runs_the_preflight(machine):
    hmi = Hmi(machine, image=machine.eeprom)  # --from an image: everything is set
    hmi.data.grip[2] = (0.0, 0.40)  # not taught by jogging: out of reach
    keys(hmi, "6#")
    assert hmi.lcd[3] == "NO P3 grip unreach.".ljust(20)
    assert hmi.last_refusal.startswith("taught.pickup[2].grip_mm = [0, 400] mm cannot be reached")
    assert hmi.image_bytes is None


def test_write_refuses_what_the_trial_would_refuse(machine, tmp_path):
    """S_l = S_h = 0.1 mm/s lie in the pendant's range, but a move then outlasts the PGF's
    30 s reply timeout, so `trial --eeprom` would refuse the image: the pendant runs the
    trial's whole check of the program and writes nothing."""
    out = tmp_path / "slow.eeprom"
    hmi = Hmi(machine, out, image=machine.eeprom)
    hmi.data.s_low = hmi.data.s_high = 0.0001
    keys(hmi, "6#")
    assert hmi.writes == 0 and not out.exists()
    assert hmi.last_refusal.startswith("bus.reply_timeout_s = 30 s is too short")
    assert hmi.lcd[3].startswith("NO bus.reply_timeou")


def test_a_session_from_an_image_rewrites_it_unchanged(machine, tmp_path):
    out = tmp_path / "same.eeprom"
    hmi = Hmi(machine, out, image=machine.eeprom)
    keys(hmi, "1")
    assert hmi.lcd[1:] == (">0 Mpp (count) 5    ", " 1 Pickup 1   AGE   ", " 2 Pickup 2   AGE   ")
    keys(hmi, "1")
    assert hmi.lcd[1:] == (">1 Appr -90.0 180.0 ", " 2 Grip -90.0 215.0 ", " 3 Elbow 112.4      ")
    keys(hmi, "* * 6#")
    assert out.read_bytes() == machine.eeprom.to_bytes()
    keys(hmi, "* 1 0 3# * 6#")  # fewer pickups: slots 4 and 5 are not written
    assert EepromImage.load(out).m_pp == 3


def test_a_failed_write_says_so(machine, tmp_path):
    out = tmp_path / "gone" / "x.eeprom"
    hmi = Hmi(machine, out, image=machine.eeprom)
    keys(hmi, "6#")
    assert hmi.lcd[3] == "NO write failed".ljust(20) and hmi.writes == 0
    assert "gone" in hmi.last_refusal


def test_hmi_out_on_a_full_disk_says_so_in_one_line_exit_5_and_leaves_no_part(
    tmp_path, monkeypatch, capsys
):
    """A full disk at Write EEPROM ended with exit 1, as if the keys had never asked for the
    write: it is one line naming --out and the disk, exit 5, and the file is as it was (no
    part of the image, no temporary file)."""
    import errno
    from pathlib import Path

    from transplanter.cli import main

    def full_disk(path, data):  # the disk fills up part way through the image
        with open(path, "wb") as f:
            f.write(data[:100])
        raise OSError(errno.ENOSPC, "No space left on device")

    out = tmp_path / "taught.eeprom"
    out.write_bytes(b"the image of yesterday")
    monkeypatch.setattr(Path, "write_bytes", full_disk)
    assert main(["hmi", "paper", "--out", str(out), "--keys-file", str(TEACH_PAPER)]) == 5
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("--out:"), err
    assert str(out) in err[0] and "No space left on device" in err[0]
    assert out.read_bytes() == b"the image of yesterday"
    assert [p.name for p in tmp_path.iterdir()] == ["taught.eeprom"]


def test_terminal_keys_map_onto_the_keypad():
    assert [terminal_key(k) for k in "09aD*#"] == ["0", "9", "A", "D", "*", "#"]
    assert terminal_key("enter") == "#" and terminal_key("backspace") == "C"
    assert terminal_key("up") == "A" and terminal_key("down") == "B"
    assert terminal_key("escape") == "*" and terminal_key(".") == "D"
    assert terminal_key("x") is None and terminal_key("q") is None


# -- the image in place of the scenario's [taught] -------------------------------------------


def test_with_eeprom_replaces_the_taught_section_and_records_the_image(machine):
    image = dataclasses.replace(machine.eeprom, z_low_m=0.030, pickups=machine.eeprom.pickups[:2])
    scenario = with_eeprom(paper_scenario(**{"scenario.seedlings": 3}), image, "t.eeprom")
    config = assemble(scenario, preflight=False)
    assert config.machine.eeprom == EepromImage.from_bytes(image.to_bytes())
    assert config.machine.eeprom.m_pp == 2 and config.machine.eeprom.z_low_m == 0.030
    assert dict(config.overrides)["scenario.seedlings"] == 3
    record = dict(config.overrides)[EEPROM_OVERRIDE]
    assert record.startswith("t.eeprom (M_pp 2, CRC-32 0x")
    assert scenario.taught.pickup[1].wrist_rad == pytest.approx(math.radians(124.7))


def test_with_eeprom_refuses_taught_overrides_and_bad_z_levels(machine):
    with pytest.raises(ScenarioError, match="taught.z_low_mm and the EEPROM image x both set"):
        with_eeprom(paper_scenario(**{"taught.z_low_mm": 30}), machine.eeprom, "x")
    too_high = dataclasses.replace(machine.eeprom, z_up_m=0.2)
    with pytest.raises(ScenarioError, match="Z_up = 200 mm is outside"):
        with_eeprom(paper_scenario(), too_high, "x")
    equal = dataclasses.replace(machine.eeprom, z_up_m=0.034)
    with pytest.raises(ScenarioError, match="must be above Z_low"):
        with_eeprom(paper_scenario(), equal, "x")


@pytest.mark.slow
def test_the_interactive_keypad_runs_in_a_terminal(tmp_path):
    """`transplanter hmi` without --keys on a terminal: the curses UI draws the LCD, takes
    keys and quits on q (a pty stands in for the terminal)."""
    import fcntl
    import os
    import select
    import struct
    import subprocess
    import sys
    import termios
    import time

    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    out = tmp_path / "taught.eeprom"
    env = {**os.environ, "TERM": "xterm"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "transplanter.cli", "hmi", "paper", "--out", str(out)],
        stdin=slave, stdout=slave, stderr=slave, env=env, close_fds=True,
    )  # fmt: skip
    os.close(slave)
    screen = b""

    def read_for(seconds: float) -> None:
        nonlocal screen
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            ready, _, _ = select.select([master], [], [], 0.05)
            if ready:
                try:
                    screen += os.read(master, 65536)
                except OSError:
                    return

    read_for(3.0)
    assert b"Keypad:" in screen and b"Homed X0 Y79 Z159" in screen
    os.write(master, b"1")  # the pickups menu
    read_for(1.0)
    assert b"PICKUPS" in screen.upper()
    os.write(master, b"q")
    read_for(1.0)
    assert proc.wait(timeout=10) == 0  # quitting is fine; it says nothing was written
    read_for(0.5)
    assert b"no EEPROM image written" in screen
    assert not out.exists()
    os.close(master)
