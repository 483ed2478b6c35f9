"""Why a pot wedges in the drop tube's funnel: each pot's state as it enters the funnel in real
trials, then the funnel alone, re-dropping those states and varying one thing at a time
(docs/fidelity.md, "Why a pot wedges in the funnel").

    python scripts/funnel_drops.py capture --seeds 1-5 --seedlings 40 --out results/funnel
    python scripts/funnel_drops.py capture --seeds 2 --seedlings 20 --rows 100 --out results/funnel
    python scripts/funnel_drops.py bench --out results/funnel [--set KEY=VALUE ...]
    python scripts/funnel_drops.py map --out results/funnel      # the tilt x offset map + figure

`capture` runs the scenario's trial (`paper` by default) with an observer that keeps, for every
released pot, its state at the first step after its release at which its centre lies within
half its height (+ 3 mm) of the funnel's top plane or below it, over the funnel: the step of
the release itself for a pot the jaws lowered into the funnel, as they lower the paper's. It
keeps the pose and velocity relative to the tube's axis, and the judge's outcome for the pot.
`bench` builds the workcell alone (the conveyor, its pots asleep on the belt, the drop tube: no
robot, no jaws), sets one belt pot into each captured state over the funnel and lets it fall
for 1 s (the loop's `run_steps`), then says where it came to rest: through the throat into the
tube, stuck above the throat (a jam), or outside. The scene's settings may be changed as
`--set` changes a trial's (`pots.friction=0.3`, `physics.timestep_ms=0.25`,
`drop_tube.funnel_throat_diameter_mm=46`). `map` drops a pot from rest at each tilt and offset
from the axis of a grid, at the height a trial's pots enter, and draws the jams over the
captured entry states. Writes JSON (atomically) and a PNG into --out.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import mujoco
import numpy as np

from transplanter import fileio
from transplanter.studies.stats import parse_seeds

ENTRY_MARGIN_M = 0.003
"""A pot enters the funnel when its centre comes within half its height plus this of the
funnel's top plane."""
FALL_S = 1.0
"""How long a bench drop runs (a pot falls through the funnel and the tube in about 0.3 s)."""
REST_M_S = 0.02
"""A pot slower than this at the end of a drop has come to rest."""


def _tilt_deg(quat) -> float:
    """The angle of a pot's axis from upright (deg) for its free joint's quaternion."""
    w, x, y, z = quat
    return math.degrees(math.acos(max(-1.0, min(1.0, 1 - 2 * (x * x + y * y)))))


class EntryCapture:
    """A trial observer: each released pot's state as it enters the funnel (module doc)."""

    def attach(self, twin, records) -> None:
        self.twin, self.records = twin, records
        cfg = twin.scene.config
        self.tube = np.array([*cfg.drop_tube_xy_m, cfg.funnel_top_z_m])
        self.entry_z = cfg.funnel_top_z_m + cfg.pot_height_m / 2 + ENTRY_MARGIN_M
        self.reach = cfg.funnel_top_diameter_m / 2 + 0.01
        self.entries: dict[int, dict] = {}

    def step(self, twin) -> None:
        scene, d = twin.scene, twin.data
        for rec in self.records:
            if rec.t_release_s is None or rec.index in self.entries or rec.pot is None:
                continue
            a, v = int(scene.pot_qpos_adr[rec.pot]), int(scene.pot_dof_adr[rec.pot])
            if a < 0:
                continue
            pos = d.qpos[a : a + 3] - self.tube
            if pos[2] + self.tube[2] < self.entry_z and math.hypot(pos[0], pos[1]) < self.reach:
                self.entries[rec.index] = {
                    "seedling": rec.index, "pot": rec.pot, "t_s": twin.time,
                    "after_release_s": twin.time - rec.t_release_s,
                    "pos_m": pos.tolist(), "quat": d.qpos[a + 3 : a + 7].tolist(),
                    "vel": d.qvel[v : v + 6].tolist(),
                    "tilt_deg": _tilt_deg(d.qpos[a + 3 : a + 7]),
                }  # fmt: skip

    def finish(self, twin, interrupted: bool) -> None:
        for rec in self.records:
            if rec.index in self.entries:
                self.entries[rec.index]["outcome"] = str(rec.outcome)

    def abort(self) -> None:
        pass


def capture(args) -> None:
    from transplanter.scenario.assemble import assemble
    from transplanter.scenario.schema import load_scenario
    from transplanter.twin.trial import run_trial

    out = Path(args.out)
    for seed in parse_seeds(args.seeds):
        over = {"scenario.seed": seed, "scenario.seedlings": args.seedlings, **_sets(args)}
        if args.rows:
            over["conveyor.rows"] = args.rows
        observer = EntryCapture()
        result = run_trial(assemble(load_scenario(args.scenario, over)), observers=[observer])
        jams = result.to_dict()["funnel_jams"]
        name = f"entries_{args.scenario}_seed{seed}_{args.seedlings}x{args.rows or 'rows'}.json"
        fileio.write_json_atomic(out / name, {
            "scenario": args.scenario, "seed": seed, "overrides": over,
            "entries": sorted(observer.entries.values(), key=lambda e: e["seedling"]),
            "funnel_jams": jams,
        })  # fmt: skip
        print(f"seed {seed}: {len(observer.entries)} entries, {len(jams)} jams -> {out / name}")


def _sets(args) -> dict:
    import tomllib

    out = {}
    for item in args.set or ():
        key, _, value = item.partition("=")
        out[key] = tomllib.loads(f"v = {value}")["v"]
    return out


class Bench:
    """The workcell alone, with its pots asleep on the belt; `drop` sets pot `pot` into a
    state over the funnel and lets it fall (module docstring)."""

    def __init__(self, scenario: str, overrides: dict) -> None:
        from transplanter.scenario.assemble import assemble
        from transplanter.scenario.schema import load_scenario
        from transplanter.scene import kinds
        from transplanter.scene.build import apply_options, merge_models, workcell_xml
        from transplanter.twin.loop import StepLoop

        cfg = self.cfg = assemble(load_scenario(scenario, overrides)).scene
        spec = merge_models([workcell_xml(cfg.workcell_kind)], "funnel_bench")
        apply_options(spec, cfg)
        cell = kinds.workcell(cfg.workcell_kind)
        cell.apply(spec, cfg)
        cell.populate(spec, cfg, int(overrides.get("scenario.seed", 1)), decor=False)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, self.data)
        self.loop = StepLoop(self.model, self.data)
        self.q0, self.v0 = self.data.qpos.copy(), self.data.qvel.copy()
        self.tube = np.array([*cfg.drop_tube_xy_m, cfg.funnel_top_z_m])

    def drop(self, pot_name: str, pos_m, quat, vel) -> dict:
        """One drop from a fresh copy of the resting belt; where the pot came to rest."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = self.q0, self.v0
        joint = m.body(pot_name).jntadr[0]
        a, v = m.jnt_qposadr[joint], m.jnt_dofadr[joint]
        d.qpos[a : a + 3] = self.tube + np.asarray(pos_m)
        d.qpos[a + 3 : a + 7] = np.asarray(quat) / np.linalg.norm(quat)
        d.qvel[v : v + 6] = vel
        mujoco.mj_forward(m, d)
        self.loop.k = 0
        self.loop.run_steps(round(FALL_S / m.opt.timestep))
        return self.where(d.qpos[a : a + 7], d.qvel[v : v + 6])

    def where(self, q, v) -> dict:
        cfg = self.cfg
        rel = q[:3] - self.tube
        off = math.hypot(rel[0], rel[1])
        throat_z = -cfg.funnel_height_m
        if rel[2] < throat_z and off < cfg.funnel_throat_diameter_m / 2:
            place = "tube"
        elif (
            rel[2] >= throat_z
            and off < cfg.funnel_top_diameter_m / 2 + 0.01
            and (rel[2] < cfg.pot_height_m)
        ):
            place = "jam"
        else:
            place = "outside"
        return {
            "place": place, "below_top_mm": -1e3 * rel[2], "off_axis_mm": 1e3 * off,
            "rest_tilt_deg": _tilt_deg(q[3:]), "speed_m_s": float(np.linalg.norm(v[:3])),
        }  # fmt: skip


def _entries(out: Path) -> list[dict]:
    rows = []
    for path in sorted(out.glob("entries_*.json")):
        d = json.loads(path.read_text())
        rows += [{**e, "file": path.name, "seed": d["seed"]} for e in d["entries"]]
    return rows


def bench(args) -> None:
    out = Path(args.out)
    entries = _entries(out)
    if not entries:
        sys.exit(f"no entries_*.json in {out}: run `capture` first")
    benches: dict[str, Bench] = {}
    rows = []
    for e in entries:
        if e["file"] not in benches:  # the trial's own belt and seed: its pots, their sizes
            over = json.loads((out / e["file"]).read_text())["overrides"]
            over = {k: v for k, v in over.items() if k != "scenario.seedlings"}
            benches[e["file"]] = Bench(args.scenario, {**over, **_sets(args)})
        b = benches[e["file"]]
        pot = f"pot_{e['pot'] // b.cfg.cols}_{e['pot'] % b.cfg.cols}"
        got = b.drop(pot, e["pos_m"], e["quat"], e["vel"])
        trial = "jam" if e.get("outcome") == "funnel_jam" else (
            "tube" if e.get("outcome") in ("success", "damaged") else e.get("outcome"))  # fmt: skip
        rows.append({**{k: e[k] for k in ("file", "seed", "seedling", "tilt_deg")},
                     "trial": trial, **got})  # fmt: skip
    tally: dict[str, int] = {}
    for r in rows:
        tally[f"{r['trial']} -> {r['place']}"] = tally.get(f"{r['trial']} -> {r['place']}", 0) + 1
    label = ",".join(args.set or [])
    name = "bench_" + (label.replace("=", "_").replace(",", "__").replace(" ", "") or "as_run")
    fileio.write_json_atomic(out / f"{name}.json", {"settings": label or "as run",
                                                    "tally": tally, "drops": rows})  # fmt: skip
    print(f"{label or 'as run'}: " + ", ".join(f"{k} {v}" for k, v in sorted(tally.items())))
    for r in rows:
        if r["trial"] == "jam" or r["place"] == "jam":
            print(
                f"  seed {r['seed']} seedling {r['seedling']}: entered tilted "
                f"{r['tilt_deg']:.1f} deg; trial {r['trial']}, bench {r['place']} "
                f"({r['below_top_mm']:.1f} mm below the top, {r['off_axis_mm']:.1f} off "
                f"axis, tilted {r['rest_tilt_deg']:.1f} deg)"
            )


def _tilted(tilt_deg: float, azimuth_rad: float) -> list[float]:
    """The quaternion of a pot tilted about the horizontal axis at `azimuth_rad`."""
    half = math.radians(tilt_deg) / 2
    return [math.cos(half), math.sin(half) * math.cos(azimuth_rad),
            math.sin(half) * math.sin(azimuth_rad), 0.0]  # fmt: skip


def map_(args) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(args.out)
    b = Bench(args.scenario, _sets(args))
    cfg = b.cfg
    z = cfg.pot_height_m / 2 + ENTRY_MARGIN_M  # the height at which trial pots enter
    tilts = np.arange(0.0, 46.0, 3.0)
    offsets = np.arange(0.0, 13.0, 2.0)  # mm, towards the tilt's lower side and away
    grid = []
    for tilt in tilts:
        for off in offsets:
            for side in (1.0, -1.0) if off else (1.0,):  # off towards its top's lean, or away
                az = 0.0
                pos = [side * off * 1e-3, 0.0, z]
                got = b.drop("pot_0_0", pos, _tilted(tilt, az + math.pi / 2), [0.0] * 6)
                grid.append({"tilt_deg": float(tilt), "offset_mm": float(side * off), **got})
    entries = _entries(out)
    suffix = "".join(
        "_" + x.split(".", 1)[-1].replace("=", "_").replace(".", "p") for x in args.set or []
    )
    fileio.write_json_atomic(out / f"map{suffix}.json", {"settings": args.set or [], "grid": grid})
    fig, ax = plt.subplots(figsize=(7, 5.0))
    colours = {"tube": "tab:green", "jam": "tab:red", "outside": "tab:gray"}
    for place, colour in colours.items():
        pts = [(g["offset_mm"], g["tilt_deg"]) for g in grid if g["place"] == place]
        if pts:
            ax.scatter(*zip(*pts, strict=True), marker="s", s=60, c=colour, alpha=0.35,
                       label=f"bench drop from rest: {place}")  # fmt: skip
    shown = [e for e in entries if abs(_signed_offset_mm(e["pos_m"], e["quat"])) <= 14.0]
    for e in shown:  # (a pot that landed on a stuck one, far off the axis, is left out)
        off = _signed_offset_mm(e["pos_m"], e["quat"])
        style = dict(c="k", marker="x") if e.get("outcome") == "funnel_jam" else dict(
            c="tab:blue", marker=".", alpha=0.5)  # fmt: skip
        ax.scatter(off, e["tilt_deg"], **style)
    ax.scatter([], [], c="tab:blue", marker=".", label="a trial pot at its release")
    ax.scatter([], [], c="k", marker="x", label="a trial pot that jammed")
    crit = _critical_tilt_deg(cfg)
    ax.axhline(crit, color="k", lw=0.8, ls="--",
               label=f"{crit:.1f} deg: tilted more, the pot is wider than the throat")  # fmt: skip
    ax.set_xlabel(
        "centre off the tube's axis at entry (mm; +: towards its top's lean, -: its low rim)"
    )
    ax.set_ylabel("tilt from upright at entry (deg)")
    ax.set_xlim(-14, 14)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2)
    ax.set_title(f"Funnel {1e3 * cfg.funnel_top_diameter_m:.0f} mm to a "
                 f"{1e3 * cfg.funnel_throat_diameter_m:.0f} mm throat, pot "
                 f"{1e3 * cfg.pot_diameter_m:.0f} x {1e3 * cfg.pot_height_m:.0f} mm",
                 fontsize=9)  # fmt: skip
    fig.tight_layout()
    png = out / f"funnel_map{suffix}.png"
    tmp = png.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=130)
    tmp.replace(png)
    jams = sum(g["place"] == "jam" for g in grid)
    print(f"map: {jams} of {len(grid)} drops jam; critical tilt {crit:.1f} deg -> {png}")


def _signed_offset_mm(pos_m, quat) -> float:
    """The centre's offset from the tube's axis (mm), signed along the way the pot's top
    leans: + the centre is off towards its top's lean, - towards its low rim (the map's
    x axis)."""
    w, x, y, z = quat
    lean = np.array([2 * (x * z + w * y), 2 * (y * z - w * x)])  # the axis's horizontal part
    off = np.asarray(pos_m[:2], dtype=float)
    norm = float(np.linalg.norm(lean))
    if norm < 1e-9:
        return 1e3 * float(np.linalg.norm(off))
    return 1e3 * float(off @ lean) / norm


def _critical_tilt_deg(cfg) -> float:
    """The tilt beyond which a rigid pot (diameter d, height h) is wider than the throat:
    d cos(t) + h sin(t) = throat."""
    d, h, w = cfg.pot_diameter_m, cfg.pot_height_m, cfg.funnel_throat_diameter_m
    r = math.hypot(d, h)
    phi = math.atan2(h, d)  # d cos t + h sin t = r cos(t - phi): its smaller root
    return math.degrees(phi - math.acos(w / r)) if d < w < r else (0.0 if w <= d else 90.0)


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("what", choices=("capture", "bench", "map"))
    p.add_argument("--scenario", default="paper")
    p.add_argument("--seeds", default="1")
    p.add_argument("--seedlings", type=int, default=40)
    p.add_argument("--rows", type=int, default=0, help="conveyor.rows (0: the scenario's)")
    p.add_argument("--set", action="append", help="KEY=VALUE, as trial --set")
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    Path(args.out).mkdir(parents=True, exist_ok=True)
    {"capture": capture, "bench": bench, "map": map_}[args.what](args)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
