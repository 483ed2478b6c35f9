"""The package installs from a wheel and runs without a checkout: models and scenarios inside."""

import os
import shutil
import subprocess
import sys
import zipfile

import pytest

from conftest import ROOT


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    """The wheel built from a clean copy of the sources (a checkout's build/ may be stale)."""
    src = tmp_path_factory.mktemp("src")
    for name in ("src", "models", "scenarios"):
        shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(out), str(src)],
        check=True,
        capture_output=True,
    )  # fmt: skip
    (path,) = out.glob("transplanter-*.whl")
    return path


@pytest.mark.slow
def test_wheel_holds_models_scenarios_and_every_module(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    # every file of every Menagerie folder (robots, workcells): README, CHANGELOG, LICENSE,
    # the XML, the meshes; and nothing else under models/ than those and __init__.py
    models = ROOT / "models"
    shipped = {
        f"transplanter/models/{p.relative_to(models).as_posix()}"
        for p in models.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    }
    for f in (
        "fivebar/fivebar.xml",
        "fivebar/scene.xml",
        "effectors/parallel_jaw/parallel_jaw.xml",
        "effectors/parallel_jaw/assets/jaw.stl",
        "fivebar/LICENSE",
        "workcells/conveyor_tube/conveyor_tube.xml",
        "workcells/conveyor_tube/assets/funnel.stl",
        "workcells/conveyor_tube/README.md",
    ):
        assert f"transplanter/models/{f}" in shipped
    assert {n for n in names if n.startswith("transplanter/models/")} == shipped
    assert "transplanter/scenarios/paper.toml" in names
    assert "transplanter/scenarios/parts/pot_line.toml" in names  # paper.toml's base
    for module in (ROOT / "src" / "transplanter").rglob("*.py"):
        rel = module.relative_to(ROOT / "src").as_posix()
        assert rel in names, rel


@pytest.mark.slow
def test_installed_wheel_runs_a_trial_outside_the_checkout(wheel, tmp_path):
    """The wheel installed on its own (dependencies from this environment), then
    `transplanter trial paper` from another directory: no path into a checkout."""
    target = tmp_path / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index",
         "--target", str(target), str(wheel)],
        check=True,
        capture_output=True,
    )  # fmt: skip
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = dict(os.environ, PYTHONPATH=str(target))
    probe = subprocess.run(
        [sys.executable, "-c", "import transplanter.scene as s; print(s.__file__, s.models_dir())"],
        cwd=work, env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert probe.stdout.count(str(target)) == 2, probe.stdout  # the wheel's code and models
    run = subprocess.run(
        [str(target / "bin" / "transplanter"), "trial", "paper", "--seedlings", "1", "--quiet"],
        cwd=work, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "success rate               100.0 % (1/1)" in run.stdout
