"""The `transplanter` command line: ik and plan (trial and replay are tested with their modules)."""

from pathlib import Path

from transplanter.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_ik_prints_angles(capsys):
    assert main(["ik", "0", "200"]) == 0
    out = capsys.readouterr().out
    assert "theta1 = 145.9911 deg" in out
    assert "theta2 = 34.0089 deg" in out
    assert "passive-link (transmission) angle = 96.7263 deg" in out


def test_ik_unreachable_says_why(capsys):
    assert main(["ik", "0", "400"]) == 1
    assert "cannot be reached: outside workspace" in capsys.readouterr().out
    assert main(["ik", "-100", "90"]) == 1  # inside the reach, outside the limits
    assert "cannot be reached" in capsys.readouterr().out


def test_plan_prints_every_line_and_total(capsys):
    assert main(["plan", str(ROOT / "scenarios" / "example.gcode")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:2] == ["line", "duration_s"]
    assert out[-1].startswith("total")
    assert len(out) == 1 + 18 + 1  # header, 18 G-code lines, total


def test_plan_error_has_line_number(tmp_path, capsys):
    bad = tmp_path / "bad.gcode"
    bad.write_text("G28\nG90\nG1 X0 Y500 Z50 S100\n")
    assert main(["plan", str(bad)]) == 1
    err = capsys.readouterr().err
    assert f"{bad}:3: error:33" in err
    assert main(["plan", str(tmp_path / "missing.gcode")]) == 1


def test_ik_and_plan_refuse_a_missing_scenario(tmp_path, capsys):
    assert main(["ik", "0", "200", "--scenario", str(tmp_path / "none.toml")]) == 2
    assert "scenario refused" in capsys.readouterr().err
    binary = tmp_path / "bin.gcode"
    binary.write_bytes(bytes(range(256)))
    assert main(["plan", str(binary)]) == 1
    assert "not a text file" in capsys.readouterr().err
