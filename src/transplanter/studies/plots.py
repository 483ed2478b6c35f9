"""Plots of sweeps and tuning studies (matplotlib, Agg backend: no display needed).

Every figure is written atomically (a temporary file beside it, then moved into place).

Sweep plots, beside the sweep's tables:

- `sweep_<key>.png`, one per varied key: the pooled success rate and its 95 % interval band
  against the key (left) and the mean cycle time (right), the key's axis in its file unit
  (`taught.z_low_mm`: mm); with two varied keys one line per value of the other key (up to
  `MAX_LINES`), else the rate pooled over the other keys (marginal). The title names the
  seedlings per trial and the seeds each point pools;
- `success_heatmap.png`: the success rate over the first two varied keys (pooled over any
  others), with two or more varied keys.

The tuning study's `pareto.png` is Optuna's own Pareto-front plot
(`optuna.visualization.matplotlib.plot_pareto_front`) with named, unit-carrying axes and the
chosen point starred.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from transplanter import fileio
from transplanter.studies.stats import aggregate

__all__ = ["MAX_LINES", "key_label", "pareto_plot", "sample_text", "seed_ranges", "sweep_plots"]

MAX_LINES = 6  # lines per plot before falling back to the marginal over the other keys

# A file key's unit suffix as an axis shows it (longest first: `_mm_s` before `_mm`).
UNITS = (
    ("_mm_s2", "mm/s²"), ("_mm_s", "mm/s"), ("_m_s2", "m/s²"), ("_m_s", "m/s"),
    ("_rev_s", "rev/s"), ("_kgm2", "kg m²"), ("_bps", "bit/s"), ("_deg", "deg"),
    ("_rad", "rad"), ("_mm", "mm"), ("_ms", "ms"), ("_us", "µs"), ("_hz", "Hz"),
    ("_nm", "N m"), ("_kg", "kg"), ("_g", "g"), ("_m", "m"), ("_s", "s"), ("_n", "N"),
)  # fmt: skip


def key_label(key: str) -> str:
    """An axis label for a scenario key in its file unit: 'taught.z_low_mm (mm)'; a key
    without a unit suffix (a count, a name) as it is."""
    name = key.split("[")[0]
    for suffix, unit in UNITS:
        if name.endswith(suffix):
            return f"{key} ({unit})"
    return key


def seed_ranges(seeds: Sequence[int]) -> str:
    """Sorted seeds as '1-3, 7'."""
    parts: list[str] = []
    ordered = sorted(set(seeds))
    start = prev = ordered[0] if ordered else None
    for s in [*ordered[1:], None]:
        if s is not None and s == prev + 1:
            prev = s
            continue
        parts.append(str(start) if start == prev else f"{start}-{prev}")
        start = prev = s
    return ", ".join(parts)


def sample_text(rows: Sequence[Mapping[str, Any]]) -> str:
    """What each plotted point pools: 'n = 40 seedlings x 3 seeds (1-3)'."""
    seeds = sorted({r["seed"] for r in rows if r.get("seed") is not None})
    sizes = sorted({r["seedlings"] for r in rows if r.get("seedlings") is not None})
    per = "/".join(map(str, sizes)) if sizes else "?"
    plural = "seed" if len(seeds) == 1 else "seeds"
    return f"n = {per} seedlings x {len(seeds)} {plural} ({seed_ranges(seeds) if seeds else '-'})"


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    tmp = fileio.temp_beside(path)
    try:
        fig.savefig(tmp, format="png", dpi=100)
    except BaseException:
        fileio.discard(tmp)
        raise
    finally:
        _pyplot().close(fig)
    fileio.commit(tmp, path, follow=False)  # plots are named by the program: never via a link
    return path


def _numeric(values: Sequence[Any]) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def _label(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _unique(values) -> list[Any]:
    seen: dict[str, Any] = {}
    for v in values:
        seen.setdefault(json.dumps(v), v)
    return list(seen.values())


def sweep_plots(out: Path, keys: Sequence[str], rows: Sequence[Mapping[str, Any]]) -> list[Path]:
    """The sweep's PNGs in `out`; the paths written."""

    plt = _pyplot()
    sample = sample_text(rows)
    written = []
    for key in keys:
        others = [k for k in keys if k != key]
        xs = _unique(r[key] for r in rows)
        numeric = _numeric(xs)
        pos = {json.dumps(v): (v if numeric else i) for i, v in enumerate(xs)}
        lines: list[tuple[str, list[dict[str, Any]]]]
        if len(others) == 1 and len(_unique(r[others[0]] for r in rows)) <= MAX_LINES:
            other = others[0]
            lines = []
            for value in _unique(r[other] for r in rows):
                subset = [r for r in rows if json.dumps(r[other]) == json.dumps(value)]
                lines.append((f"{other} = {_label(value)}", aggregate(subset, [key])))
        else:
            label = "pooled over " + ", ".join(others) if others else ""
            lines = [(label, aggregate(rows, [key]))]
        fig, (ax_s, ax_c) = plt.subplots(1, 2, figsize=(11.0, 4.2), layout="constrained")
        for label, agg in lines:
            pts = [a for a in agg if a["success_rate"] is not None]
            x = [pos[json.dumps(a[key])] for a in pts]
            rate = [100 * a["success_rate"] for a in pts]
            lo = [100 * a["ci95_low"] for a in pts]
            hi = [100 * a["ci95_high"] for a in pts]
            (line,) = ax_s.plot(x, rate, "o-", label=label or None)
            ax_s.fill_between(x, lo, hi, color=line.get_color(), alpha=0.2)
            timed = [a for a in pts if a["cycle_time_s"] is not None]
            ax_c.plot(
                [pos[json.dumps(a[key])] for a in timed],
                [a["cycle_time_s"] for a in timed],
                "o-",
                color=line.get_color(),
                label=label or None,
            )
        for ax, ylabel in (
            (ax_s, "pooled success rate (%), 95 % interval band"),
            (ax_c, "mean cycle time (s)"),
        ):
            ax.set_xlabel(key_label(key))
            ax.set_ylabel(ylabel)
            ax.grid(True, alpha=0.3)
            if not numeric:
                ax.set_xticks(range(len(xs)), [_label(v) for v in xs])
        if any(label for label, _ in lines):
            ax_s.legend(fontsize="small")
        ax_s.set_ylim(-2, 102)
        ax_s.set_title("success")
        ax_c.set_title("cycle time")
        fig.suptitle(f"{key}: {sample} per setting")
        written.append(_save(fig, out / f"sweep_{key}.png"))
    if len(keys) >= 2:
        written.append(_heatmap(out / "success_heatmap.png", keys[0], keys[1], rows, sample))
    return written


def _heatmap(path: Path, kx: str, ky: str, rows: Sequence[Mapping[str, Any]], sample: str) -> Path:
    import numpy as np

    plt = _pyplot()
    xs, ys = _unique(r[kx] for r in rows), _unique(r[ky] for r in rows)
    grid = np.full((len(ys), len(xs)), np.nan)
    index_x = {json.dumps(v): i for i, v in enumerate(xs)}
    index_y = {json.dumps(v): i for i, v in enumerate(ys)}
    for a in aggregate(rows, [kx, ky]):
        if a["success_rate"] is not None:
            grid[index_y[json.dumps(a[ky])], index_x[json.dumps(a[kx])]] = 100 * a["success_rate"]
    fig, ax = plt.subplots(figsize=(6.4, 4.8), layout="constrained")
    image = ax.imshow(grid, origin="lower", aspect="auto", vmin=0, vmax=100, cmap="viridis")
    ax.set_xticks(range(len(xs)), [_label(v) for v in xs])
    ax.set_yticks(range(len(ys)), [_label(v) for v in ys])
    for (j, i), value in np.ndenumerate(grid):
        text = "error" if np.isnan(value) else f"{value:.0f}"
        ax.text(i, j, text, ha="center", va="center", color="w" if value < 60 else "k")
    ax.set_xlabel(key_label(kx))
    ax.set_ylabel(key_label(ky))
    ax.set_title(f"pooled success rate (%)\n{sample} per setting", fontsize="medium")
    fig.colorbar(image, ax=ax, label="pooled success rate (%)")
    return _save(fig, path)


def pareto_plot(
    path: Path,
    study,
    chosen: tuple[float, float] | None,
    title: str = "speed vs success",
) -> Path:
    """Optuna's Pareto-front plot of a two-objective study (lower 95 % bound of pooled
    success, mean cycle time), as (mean cycle time s, lower bound %): every complete trial,
    the front highlighted, and `chosen` (cycle s, lower bound as a fraction) starred."""
    import optuna

    _pyplot()  # the Agg backend before Optuna draws
    with warnings.catch_warnings():  # "experimental" since Optuna 3.0, and stable in use
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        ax = optuna.visualization.matplotlib.plot_pareto_front(
            study,
            targets=lambda t: (t.values[1], 100 * t.values[0]),
            target_names=["mean cycle time (s)", "lower 95 % bound of pooled success (%)"],
        )
    fig = ax.figure
    fig.set_size_inches(6.4, 4.6)
    if chosen is not None:
        ax.scatter([chosen[0]], [100 * chosen[1]], marker="*", s=320, facecolors="none",
                   edgecolors="k", zorder=5, label="chosen (tuned.toml)")  # fmt: skip
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title(title, fontsize="medium")
    fig.tight_layout()
    return _save(fig, path)
