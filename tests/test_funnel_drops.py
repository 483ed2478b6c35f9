"""scripts/funnel_drops.py's bench: the drop tube's funnel alone. An upright pot falls through
the throat; one tilted past the throat's critical angle, off towards its low rim, wedges in
the cone; a wider throat (`drop_tube.funnel_throat_diameter_mm`) lets the same pot through."""

from __future__ import annotations

import importlib.util
import math
import sys

import pytest

from conftest import ROOT

SCRIPT = ROOT / "scripts" / "funnel_drops.py"


@pytest.fixture(scope="module")
def drops():
    spec = importlib.util.spec_from_file_location("funnel_drops", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_a_pot_tilted_past_the_throats_angle_wedges_and_a_wider_throat_frees_it(drops):
    bench = drops.Bench("paper", {})
    cfg = bench.cfg
    assert drops._critical_tilt_deg(cfg) == pytest.approx(8.1, abs=0.05)  # 35 x 52 mm, 42 mm
    z = cfg.pot_height_m / 2 + drops.ENTRY_MARGIN_M  # its bottom just over the funnel's top

    def drop(b, tilt_deg, offset_mm):
        return b.drop("pot_0_0", [offset_mm * 1e-3, 0.0, z], drops._tilted(tilt_deg, math.pi / 2),
                      [0.0] * 6)  # fmt: skip

    upright = drop(bench, 0.0, 0.0)
    assert upright["place"] == "tube" and upright["below_top_mm"] > 100
    stuck = drop(bench, 30.0, -6.0)  # leaning, off towards its low rim
    assert stuck["place"] == "jam" and stuck["below_top_mm"] < 1e3 * cfg.funnel_height_m
    assert stuck["off_axis_mm"] < 1e3 * cfg.funnel_top_diameter_m / 2  # in the cone
    assert stuck["speed_m_s"] < drops.REST_M_S and stuck["rest_tilt_deg"] > 20
    assert drop(bench, 30.0, 6.0)["place"] == "tube"  # off towards its top's lean: righted
    wide = drops.Bench("paper", {"drop_tube.funnel_throat_diameter_mm": 50.0})
    assert drops._critical_tilt_deg(wide.cfg) == pytest.approx(19.0, abs=0.05)
    assert drop(wide, 15.0, -6.0)["place"] == "tube"
    assert drop(bench, 15.0, -6.0)["place"] == "jam"
