"""`transplanter plan-move` and `transplanter ik` at the edges of their input: options held to
their scenario key's range, numbers in ASCII, points far outside every arm refused as given
without a numpy warning, and a --json that cannot be written (docs/reliability.md)."""

from __future__ import annotations

import errno
import json
import pathlib
import warnings

import pytest

from conftest import PAPER_PATH
from transplanter import cli
from transplanter.scenario.schema import key_spec

MOVE = ["plan-move", str(PAPER_PATH), "--set", "robot.kind=delta", "--no-toppra"]
PICK_PLACE = ["--from", "200,200,-800", "--to", "250,-175,-800"]


@pytest.mark.parametrize("given", ["1e-300", "1e-100", "0.0999999", "1000.000001", "1e300"])
def test_plan_move_refuses_an_ee_accel_outside_the_keys_range_in_one_line(given, capsys):
    """--ee-accel 1e-300 was a LinAlgError traceback after seven RuntimeWarnings, 1e-100 a
    3e50 s move and exit 0: the option now has motion.ee_accel_limit_mm_s2's range, read
    from the schema, and says so in one line before anything ran (exit 2)."""
    spec = key_spec("motion.ee_accel_limit_mm_s2")
    assert (spec.lo, spec.hi, spec.scale) == (100, 1e6, 1e-3)  # [0.1, 1000] m/s^2
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        status = cli.main([*MOVE, *PICK_PLACE, "--ee-accel", given])
    out, err = capsys.readouterr()
    assert status == 2 and out == "" and caught == []
    assert err.count("\n") == 1
    assert f"--ee-accel {float(given)!r} m/s^2 is outside [0.1, 1000] m/s^2" in err
    assert "motion.ee_accel_limit_mm_s2 ([100, 1e+06] mm/s^2)" in err


def test_plan_move_takes_the_ends_of_the_ee_accel_range(capsys):
    for given, total_s in (("0.1", 7.7192), ("1000", 0.6556)):
        assert cli.main([*MOVE, *PICK_PLACE, "--ee-accel", given]) == 0
        assert f"total_s {total_s:.4f}" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv",
    [
        ["--from", "٢٠٠,٢٠٠,-٨٠٠", "--to", "250,-175,-800"],  # Arabic-Indic digits
        ["--from", "200,200,-800", "--to", "２５０,-175,-800"],  # full-width digits
        [*PICK_PLACE, "--ee-accel", "٨"],
        [*PICK_PLACE, "--exit-mm", "١٠"],
    ],
)
def test_plan_move_numbers_are_ascii_as_every_other_commands(argv, capsys):
    """float() reads '٢٠٠' as 200: plan-move planned a move the other commands refuse."""
    with pytest.raises(SystemExit) as stop:
        cli.main([*MOVE, *argv])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "ASCII digits 0-9" in err and "Traceback" not in err


@pytest.mark.parametrize(
    "kind, base",
    [
        ("fivebar", ["0", "200", "5"]),
        ("delta", ["0", "0", "-800"]),
        ("serial4", ["100", "40", "50"]),
    ],
)
@pytest.mark.parametrize("given", ["1e308", "-1e308", "1e200"])
def test_ik_refuses_a_point_far_outside_the_arm_as_given_without_a_warning(
    kind, base, given, capsys
):
    """1e308 mm overflowed on its way to the refusal: numpy's RuntimeWarnings came first."""
    for axis in range(3):
        xyz = list(base)
        xyz[axis] = given
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            status = cli.main(["ik", "--set", f"robot.kind={kind}", "--", *xyz])
        out, err = capsys.readouterr()
        assert [str(w.message) for w in caught] == [] and err == ""
        shown = ", ".join(f"{float(v):g}" for v in xyz)
        assert status == 1 and out.startswith(f"({shown}) mm cannot be reached: ")
        assert "outside" in out and out.count("\n") == 1  # the workspace, or Z's range
        assert "inf" not in out


def test_ik_refuses_a_number_beyond_the_largest_float_as_written(capsys):
    """'1e309' is read as inf: it used to be refused as '(inf, 0, -800) mm cannot be reached'."""
    for xyz in (["1e309", "0", "-800"], ["0", "0", "nan"]):
        with pytest.raises(SystemExit) as stop:
            cli.main(["ik", *xyz, "--set", "robot.kind=delta"])
        assert stop.value.code == 2
        err = capsys.readouterr().err
        given = xyz[0] if xyz[0] != "0" else xyz[2]
        assert f"{given!r} is not a finite number" in err


@pytest.mark.parametrize(
    "ends, option, shown",
    [
        (["--from", "1e308,0,-800", "--to", "250,-175,-800"], "--from", "(1e+308, 0, -800)"),
        (["--from", "200,200,-800", "--to", "250,-175,1e308"], "--to", "(250, -175, 1e+308)"),
        (["--from=-1e200,0,-800", "--to", "250,-175,-800"], "--from", "(-1e+200, 0, -800)"),
    ],
)
def test_plan_move_refuses_an_end_far_outside_the_arm_as_given_without_a_warning(
    ends, option, shown, capsys
):
    """It printed numpy's overflow warnings, then refused 'key point Q0 [inf, 0.0, -800.0]'
    (or Q1, the lift above a far --to)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        status = cli.main([*MOVE, *ends])
    out, err = capsys.readouterr()
    assert [str(w.message) for w in caught] == [] and err == ""
    assert status == 1
    assert out.startswith(f"move refused (reach): {option} {shown} mm: outside workspace")
    assert "inf" not in out and out.count("\n") == 1


def test_plan_move_on_a_full_disk_says_so_in_one_line_and_leaves_nothing(
    tmp_path, monkeypatch, capsys
):
    """A full disk was an OSError traceback; now one line, exit 5, as trial and the studies,
    and the earlier file is left whole with no temporary file beside it."""
    out = tmp_path / "move.json"
    out.write_text('{"earlier": true}\n')

    def full_disk(self, text, *args, **kwargs):
        with open(self, "w") as f:
            f.write(text[: len(text) // 2])  # cut short
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(pathlib.Path, "write_text", full_disk)
    assert cli.main([*MOVE, *PICK_PLACE, "--json", str(out)]) == 5
    printed, err = capsys.readouterr()
    assert "total_s" in printed and "wrote" not in printed
    err = err.strip().splitlines()
    assert len(err) == 1 and "--json" in err[0] and "No space left on device" in err[0]
    assert [p.name for p in tmp_path.iterdir()] == ["move.json"]
    assert json.loads(out.read_text()) == {"earlier": True}
