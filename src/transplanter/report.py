"""Presenting trial results: the summary table, a progress bar and result files."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

from transplanter.results import TrialResult

__all__ = ["format_summary", "output_problem", "progress_bar", "write_json_atomic"]


def format_summary(result: TrialResult) -> str:
    """The trial's numbers as an aligned two-column table."""
    d = result.to_dict()
    lo, hi = d["success_rate_ci95"]
    rows = [
        ("scenario", f"{d['scenario']} (seed {d['seed']})"),
        ("valid", "yes" if d["valid"] else f"NO: {d['invalid_reason']}"),
        ("seedlings", f"{d['seedlings']}"),
        (
            "success rate",
            f"{100 * d['success_rate']:.1f} % ({d['successes']}/{d['seedlings']}), "
            f"95 % CI {100 * lo:.1f}-{100 * hi:.1f} %",
        ),
        (
            "cycle time",
            "n/a"
            if d["cycle_time_s"] is None
            else f"{d['cycle_time_s']:.3f} s mean, sd {d['cycle_time_sd_s'] or 0:.3f} s",
        ),
        ("seedlings per minute", f"{d['seedlings_per_min']:.1f}"),
        ("simulated time", f"{d['sim_time_s']:.1f} s"),
        ("wall time", f"{d['wall_time_s']:.1f} s"),
        ("real-time factor", f"{d['real_time_factor']:.1f}x" if d["real_time_factor"] else "n/a"),
    ]
    rows += [(f"failures: {k}", str(v)) for k, v in d["failures"].items()]
    if d["fault"]:
        rows.append(("firmware fault", d["fault"]))
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def progress_bar(total: int, enabled: bool):
    """A tqdm bar over the trial's seedlings, and the callback run_trial updates it with;
    (None, None) when disabled."""
    if not enabled:
        return None, None
    from tqdm import tqdm

    bar = tqdm(total=total, unit="seedling", dynamic_ncols=True)

    def update(done: int, sim_t: float) -> None:
        bar.set_postfix_str(f"sim {sim_t:.1f} s", refresh=False)
        bar.update(done - bar.n)

    return bar, update


def output_problem(path: Path | None, suffix: str | None) -> str | None:
    """Why an output file cannot be written there (checked before simulating), or None."""
    if path is None:
        return None
    path = Path(path)
    if path.is_dir():
        return f"{path} is a directory; give a file name"
    if not path.parent.is_dir():
        return f"{path.parent} does not exist; create it first"
    if not os.access(path.parent, os.W_OK):
        return f"{path.parent} is not writable"
    if suffix is not None and path.suffix != suffix:
        return f"{path} must end in {suffix}"
    return None


def write_json_atomic(path: Path, payload: dict[str, Any]) -> None:
    """Write JSON so that the file is either the old one or the complete new one."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(payload, f, indent=2, sort_keys=True)
            f.write("\n")
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; results are for sharing
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
