"""Draw where the conveyor's index pushes leave the pots, from runs of benchmarks/push_drift.py.

Run: .venv/bin/python benchmarks/push_drift.py --rows 40 --seeds 1-6 --indexes 30 --drive stepper
         --feet 0 --json cylinder.json   (and --feet 8 --json feet.json)
     .venv/bin/python scripts/push_drift_figure.py "on its cylinder=cylinder.json" \\
         "on 8 feet=feet.json" [--out docs/img/push_drift.png]

Two panels against the pushes a pot has had: the spread (sd) of its offset across the belt,
which the window of live rows must let settle (docs/performance.md, "Pots on feet and the
stepper index"), and the mean offset across the belt of the pots on the near and on the far
half of the belt, which MuJoCo's native cylinder-on-box collider pulls apart ("Why the far
rows drift"). Points with fewer than 30 pots are left out. The PNG is written atomically.
"""

from __future__ import annotations

import argparse
import io
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from push_drift import tally  # noqa: E402

from transplanter import fileio  # noqa: E402

MIN_POTS = 30  # a point of fewer pots is noise


def curves(path: str) -> dict[str, np.ndarray]:
    """Per push count: the sd across (mm), and the mean across of the near and far halves."""
    with open(path) as fh:
        saved = json.load(fh)
    by_push, _, _, _ = tally(saved["seeds"], saved["args"]["rows"])
    out: dict[str, list] = {"pushes": [], "sd": [], "near": [], "far": []}
    for k in sorted(by_push):
        v = np.array(by_push[k])
        far = v[:, 2] > 0
        if len(v) < MIN_POTS:
            continue
        out["pushes"].append(k)
        out["sd"].append(v[:, 0].std())
        for name, half in (("near", ~far), ("far", far)):
            out[name].append(v[half, 0].mean() if half.sum() >= MIN_POTS else np.nan)
    return {k: np.array(v, dtype=float) for k, v in out.items()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", metavar="LABEL=JSON", help="push_drift.py --json files")
    parser.add_argument("--out", default=str(ROOT / "docs" / "img" / "push_drift.png"))
    args = parser.parse_args()
    runs = []
    for item in args.runs:
        label, sep, path = item.partition("=")
        if not sep:
            parser.error(f"{item!r}: write LABEL=FILE")
        runs.append((label, curves(path)))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8), dpi=110)
    for k, (label, c) in enumerate(runs):
        colour = f"C{k}"
        ax1.plot(c["pushes"], c["sd"], "o-", ms=3, color=colour, label=label)
        ax2.plot(c["pushes"], c["near"], "o-", ms=3, color=colour, label=f"{label}, near half")
        ax2.plot(c["pushes"], c["far"], "s--", ms=3, color=colour, label=f"{label}, far half")
    ax1.set_xlabel("index pushes the pot has had")
    ax1.set_ylabel("sd of the offset across the belt (mm)")
    ax1.set_ylim(bottom=0)
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=8)
    ax1.set_title("spread across the belt", fontsize=10)
    ax2.axhline(0.0, color="0.5", lw=0.8)
    ax2.set_xlabel("index pushes the pot has had")
    ax2.set_ylabel("mean offset across the belt (mm, +x)")
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=7)
    ax2.set_title("mean across the belt, near and far halves", fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    out = Path(args.out)
    tmp = fileio.temp_beside(out)
    try:
        tmp.write_bytes(buf.getvalue())
    except BaseException:
        fileio.discard(tmp)
        raise
    fileio.commit(tmp, out)
    print(f"{out} ({len(buf.getvalue()) >> 10} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
