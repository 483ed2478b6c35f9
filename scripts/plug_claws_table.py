"""Print the plug claws' hold and substrate retention over the paper's three factors at three
levels each (Zhao et al. 2022, Table 1: substrate moisture 60-70 / 70-80 / 80-90 %, seedling age
20 / 25 / 30 d, transplanting acceleration, read here as 20 / 30 / 40 m/s^2), measured on the
standalone bench (transplanter.scene.plug_bench): one pick per cell of the 3 x 3 x 3 grid, then
the range analysis of retention over the paper's L9 orthogonal runs.

Run: .venv/bin/python scripts/plug_claws_table.py   (about 5 s; docs/plug_claws.md shows it)
"""

from __future__ import annotations

import argparse

from transplanter.scene.plug_bench import BenchConfig, measure_hold, run_pick
from transplanter.scene.plug_substrate import PlugsConfig, Substrate

MOISTURE_PCT = (65.0, 75.0, 85.0)  # the middles of the paper's three bands
AGE_D = (20.0, 25.0, 30.0)
ACCEL_M_S2 = (20.0, 30.0, 40.0)
L9 = (
    (1, 1, 1),
    (1, 2, 2),
    (1, 3, 3),
    (2, 1, 2),
    (2, 2, 3),
    (2, 3, 1),
    (3, 1, 3),
    (3, 2, 1),
    (3, 3, 2),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timestep-ms", type=float, default=1.0)
    args = parser.parse_args()
    bench = {"timestep_ms": args.timestep_ms}
    print(
        "| moisture % | age d | plug g | friction hold N | pin capacity N | "
        + " | ".join(f"{a:g} m/s^2: retention % (peak carried load N)" for a in ACCEL_M_S2)
        + " |"
    )
    print("| " + " | ".join(["---"] * (5 + len(ACCEL_M_S2))) + " |")
    retention = {}
    for i, w in enumerate(MOISTURE_PCT):
        for j, age in enumerate(AGE_D):
            plugs = PlugsConfig(moisture_pct=w, age_d=age)
            sub = Substrate(plugs)
            hold = measure_hold(plugs, timestep_ms=args.timestep_ms)
            cells = []
            for k, a in enumerate(ACCEL_M_S2):
                r = run_pick(plugs, bench=BenchConfig(extraction_accel_m_s2=a, **bench))
                retention[i, j, k] = r.retention
                text = f"{100 * r.retention:.1f} ({r.peak_load_n:.2f})"
                cells.append(text if r.held and r.in_target else f"dropped ({r.peak_load_n:.2f})")
            print(
                f"| {w:g} | {age:g} | {sub.mass_kg * 1e3:.1f} | {hold:.2f} | "
                f"{sub.pin_capacity_n:.2f} | " + " | ".join(cells) + " |"
            )
    print()
    print(
        "L9 runs (A moisture, B age, C acceleration; levels 1-3): substrate delivered into the"
        " target cell, % of the plug (retention; 0 for a dropped plug)"
    )
    runs = []
    for n, (a, b, c) in enumerate(L9, 1):
        value = 100 * retention[a - 1, b - 1, c - 1]
        runs.append(((a, b, c), value))
        print(f"  run {n}: A{a} B{b} C{c}  {value:.1f}")
    for f, name in enumerate(("A moisture", "B age", "C acceleration")):
        k = [sum(v for lv, v in runs if lv[f] == level) / 3 for level in (1, 2, 3)]
        print(f"  {name}: k1 {k[0]:.1f}  k2 {k[1]:.1f}  k3 {k[2]:.1f}  R {max(k) - min(k):.1f}")


if __name__ == "__main__":
    main()
