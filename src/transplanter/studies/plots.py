"""Plots of sweeps and tuning studies (matplotlib, Agg backend: no display needed).

Every figure is written atomically (a temporary file beside it, then moved into place).

Sweep plots, beside the sweep's tables:

- `success_<key>.png`: the pooled success rate and its 95 % interval band against each varied
  key; with two varied keys one line per value of the other key (up to `MAX_LINES`), else the
  rate pooled over the other keys (marginal);
- `cycle_<key>.png`: the mean cycle time against each varied key, lines as above;
- `success_heatmap.png`: the success rate over the first two varied keys (pooled over any
  others), with two or more varied keys.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from transplanter import fileio
from transplanter.studies.stats import aggregate

__all__ = ["MAX_LINES", "pareto_plot", "sweep_plots"]

MAX_LINES = 6  # lines per plot before falling back to the marginal over the other keys


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
        fig_s, ax_s = plt.subplots(figsize=(6.4, 4.0))
        fig_c, ax_c = plt.subplots(figsize=(6.4, 4.0))
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
                label=label or None,
            )
        for ax, ylabel in ((ax_s, "success rate (%), 95 % interval"), (ax_c, "cycle time (s)")):
            ax.set_xlabel(key)
            ax.set_ylabel(ylabel)
            ax.grid(True, alpha=0.3)
            if not numeric:
                ax.set_xticks(range(len(xs)), [_label(v) for v in xs])
            if any(label for label, _ in lines):
                ax.legend(fontsize="small")
        ax_s.set_ylim(-2, 102)
        ax_s.set_title(f"success rate vs {key}")
        ax_c.set_title(f"mean cycle time vs {key}")
        written.append(_save(fig_s, out / f"success_{key}.png"))
        written.append(_save(fig_c, out / f"cycle_{key}.png"))
    if len(keys) >= 2:
        written.append(_heatmap(out / "success_heatmap.png", keys[0], keys[1], rows))
    return written


def _heatmap(path: Path, kx: str, ky: str, rows: Sequence[Mapping[str, Any]]) -> Path:
    import numpy as np

    plt = _pyplot()
    xs, ys = _unique(r[kx] for r in rows), _unique(r[ky] for r in rows)
    grid = np.full((len(ys), len(xs)), np.nan)
    index_x = {json.dumps(v): i for i, v in enumerate(xs)}
    index_y = {json.dumps(v): i for i, v in enumerate(ys)}
    for a in aggregate(rows, [kx, ky]):
        if a["success_rate"] is not None:
            grid[index_y[json.dumps(a[ky])], index_x[json.dumps(a[kx])]] = 100 * a["success_rate"]
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    image = ax.imshow(grid, origin="lower", aspect="auto", vmin=0, vmax=100, cmap="viridis")
    ax.set_xticks(range(len(xs)), [_label(v) for v in xs])
    ax.set_yticks(range(len(ys)), [_label(v) for v in ys])
    for (j, i), value in np.ndenumerate(grid):
        text = "error" if np.isnan(value) else f"{value:.0f}"
        ax.text(i, j, text, ha="center", va="center", color="w" if value < 60 else "k")
    ax.set_xlabel(kx)
    ax.set_ylabel(ky)
    ax.set_title("success rate (%)")
    fig.colorbar(image, ax=ax, label="success rate (%)")
    return _save(fig, path)


def pareto_plot(
    path: Path,
    points: Sequence[tuple[float, float]],
    front: Sequence[tuple[float, float]],
    chosen: tuple[float, float] | None,
) -> Path:
    """Every finished trial as (mean cycle time s, lower 95 % bound of success), the Pareto
    front joined and the chosen point starred."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    if points:
        ax.scatter(*zip(*points, strict=True), s=18, color="0.6", label="trials")
    if front:
        f = sorted(front)
        ax.plot(*zip(*f, strict=True), "o-", color="C3", label="Pareto front")
    if chosen is not None:
        ax.scatter([chosen[0]], [chosen[1]], marker="*", s=220, color="C2", zorder=5,
                   label="chosen (tuned.toml)")  # fmt: skip
    ax.set_xlabel("mean cycle time (s)")
    ax.set_ylabel("lower 95 % bound of pooled success")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title("speed vs success")
    return _save(fig, path)
