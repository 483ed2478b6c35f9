"""One self-contained HTML file of a command's results (`trial`, `sweep`, `compare` with
`--report FILE.html`): what the command printed, its results as tables, its pictures
embedded, the scenario files as read and the command line, the version and the seeds.

The file needs nothing beside it (the pictures are `data:` URIs, the style is inline, no
script is fetched) so it can be mailed, attached to a ticket or archived with the results.
It is made from the same data the command writes to its JSON, CSV and PNG files, never
from a second computation: every table names what it shows (`data-source`: a path in the
--json file, `per_seedling`, `motors.drives`, `trials[0].per_seedling`; or the study's file,
`settings.csv`, `compare.json#rows?workcell=JOB`), and a test opens the file in headless
Chromium and checks each table's rows against it (docs/results.md, "The HTML report").

Generic: it names no robot, effector or job; a job's results become tables by their
shape (`tables_of`): the scalars of a result in one table, each list of records (the
per-unit records, the drives, the runs) in its own, each mapping of counts in its own.
"""

from __future__ import annotations

import base64
import html
import json
import math
import platform
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = [
    "Picture",
    "Report",
    "ScenarioText",
    "Table",
    "cell_text",
    "records_table",
    "render",
    "tables_of",
    "units_picture",
]

MAX_ROWS = 5000
"""A table shows at most this many rows (the rest are in the JSON; the table says so)."""


@dataclass(frozen=True)
class Table:
    """A table: its title, the JSON path of what it shows ('' for none), the columns and
    the rows (each a sequence of cell values, shown by `cell_text`)."""

    title: str
    source: str
    columns: tuple[str, ...]
    rows: tuple[tuple[Any, ...], ...]
    note: str = ""


@dataclass(frozen=True)
class Picture:
    """A PNG picture and its caption."""

    caption: str
    png: bytes

    @classmethod
    def of_file(cls, path: Path, caption: str | None = None) -> Picture:
        return cls(caption or Path(path).name, Path(path).read_bytes())


@dataclass(frozen=True)
class ScenarioText:
    """A scenario file as read (its base chain gives several) and its name."""

    name: str
    text: str


@dataclass
class Report:
    """What a report holds, filled by the command that makes it."""

    title: str
    command: str
    version: str
    seeds: str = ""
    summary: str = ""
    tables: list[Table] = field(default_factory=list)
    pictures: list[Picture] = field(default_factory=list)
    scenarios: list[ScenarioText] = field(default_factory=list)
    overrides: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    ready: bool = False
    """Filled by a command that finished its work: a command refused before it is not
    reported."""


def _is_scalar(v: Any) -> bool:
    return v is None or isinstance(v, str | int | float | bool)


def cell_text(v: Any) -> str:
    """A value as a table shows it: numbers to 6 significant digits (integers whole), None
    as '-', booleans as 'true'/'false' (as in the JSON), lists and mappings as compact
    JSON."""
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        return f"{v:.6g}"
    if isinstance(v, str):
        return v
    return json.dumps(v, sort_keys=True, separators=(", ", ": "), default=str)


def records_table(title: str, source: str, records: Sequence[Mapping[str, Any]]) -> Table:
    columns: list[str] = []
    for r in records:
        for k in r:
            if k not in columns:
                columns.append(k)
    shown = records[:MAX_ROWS]
    note = (
        f"the first {MAX_ROWS} of {len(records)} rows; every row is in the JSON"
        if len(records) > MAX_ROWS
        else ""
    )
    rows = tuple(tuple(r.get(c) for c in columns) for r in shown)
    return Table(title, source, tuple(columns), rows, note)


def _is_records(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, Mapping) for x in v)


def _records_tables(title: str, source: str, records: Sequence[Mapping[str, Any]]) -> list[Table]:
    """A list of records as its table and, for each record, a table of each of its own lists
    of records (a pooled run's trials: each trial's per-unit records), those columns left out
    of the first table."""
    nested = list(dict.fromkeys(k for r in records for k, v in r.items() if _is_records(v)))
    first = records_table(title, source, [{k: v for k, v in r.items() if k not in nested}
                                          for r in records])  # fmt: skip
    out = [first]
    for i, r in enumerate(records[:MAX_ROWS]):
        for k in nested:
            if _is_records(r.get(k)):
                out.append(records_table(f"{title}[{i}].{k}", f"{source}[{i}].{k}", r[k]))
    return out


def _flat(prefix: str, mapping: Mapping[str, Any], out: list[tuple[str, Any]], lists: list):
    for k, v in mapping.items():
        name = f"{prefix}{k}"
        if isinstance(v, Mapping):
            _flat(f"{name}.", v, out, lists)
        elif isinstance(v, list) and v and all(isinstance(x, Mapping) for x in v):
            lists.append((name, v))
        else:
            out.append((name, v))


def tables_of(payload: Mapping[str, Any], title: str = "results", source: str = "") -> list[Table]:
    """A JSON result as tables, by its shape: the scalars (and short lists of scalars) of the
    top level in one table of key and value; each mapping in its own table of its flattened
    keys; each list of mappings (records) in its own table, a column per key; each longer
    list of scalars as a one-column table. `source` is the JSON path of `payload` ('' for
    the file's top level): each table's `source` is the path of what it shows."""

    def path(key: str) -> str:
        return f"{source}.{key}" if source else key

    scalars: list[tuple[str, Any]] = []
    out: list[Table] = []
    later: list[Table] = []
    for k, v in payload.items():
        if isinstance(v, Mapping) and v:
            flat: list[tuple[str, Any]] = []
            lists: list[tuple[str, list]] = []
            _flat("", v, flat, lists)
            if flat:
                later.append(Table(k, path(k), ("key", "value"), tuple(flat)))
            for name, records in lists:
                later.append(records_table(f"{k}.{name}", path(f"{k}.{name}"), records))
        elif isinstance(v, list) and v and all(isinstance(x, Mapping) for x in v):
            later += _records_tables(k, path(k), v)
        elif isinstance(v, list) and len(v) > 4 and all(_is_scalar(x) for x in v):
            later.append(Table(k, path(k), (k,), tuple((x,) for x in v)))
        else:
            scalars.append((k, v))
    if scalars:
        out.append(Table(title, source, ("key", "value"), tuple(scalars)))
    return out + later


_UNIT_TIME_KEYS = ("t_start_s", "start_s", "t_s")
_UNIT_VALUE_KEYS = ("cycle_time_s", "time_s", "duration_s")


def units_picture(table: Table, caption: str | None = None) -> Picture | None:
    """The units of a records table as a picture, where its records carry an `outcome`
    (the layout every job's per-unit records share, docs/results.md): each unit at its start
    time (or its place in the run) against its cycle time (or 1), coloured by outcome; None
    for a table without outcomes or rows."""
    if "outcome" not in table.columns or not table.rows:
        return None
    col = {c: i for i, c in enumerate(table.columns)}
    tkey = next((k for k in _UNIT_TIME_KEYS if k in col), None)
    vkey = next((k for k in _UNIT_VALUE_KEYS if k in col), None)

    def number(row, key, default):
        v = row[col[key]] if key is not None else None
        return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else default

    from io import BytesIO

    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    outcomes = list(dict.fromkeys(str(r[col["outcome"]]) for r in table.rows))
    outcomes.sort(key=lambda o: (o != "success", o))
    colours = plt.get_cmap("tab10")
    fig, ax = plt.subplots(figsize=(8, 3.2))
    try:
        points = [
            (str(r[col["outcome"]]), number(r, tkey, float(n)), number(r, vkey, 1.0))
            for n, r in enumerate(table.rows)
        ]
        for i, outcome in enumerate(outcomes):
            xs = [x for o, x, _ in points if o == outcome]
            ys = [y for o, _, y in points if o == outcome]
            colour = "tab:green" if outcome == "success" else colours((i + 1) % 10)
            ax.scatter(xs, ys, s=18, color=colour, label=f"{outcome} ({len(xs)})")
        ax.set_xlabel(f"{tkey} (simulated)" if tkey else "unit in the run")
        ax.set_ylabel(vkey or "")
        if vkey is None:
            ax.set_yticks([])
        ax.legend(loc="best", fontsize=8, frameon=False)
        ax.set_title(caption or f"{table.title}: each unit's outcome", fontsize=10)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        buf = BytesIO()
        fig.savefig(buf, format="png", dpi=100)
    finally:
        plt.close(fig)
    return Picture(caption or f"{table.title}: each unit's outcome", buf.getvalue())


_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;
max-width:1200px;padding:0 1em;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}
h3{font-size:1em}pre{background:#f6f6f6;padding:.8em;overflow-x:auto;font-size:.85em;white-space:pre-wrap}
table{border-collapse:collapse;font-size:.8em;margin:.4em 0 1em}
th,td{border:1px solid #ddd;padding:.2em .5em;text-align:left;vertical-align:top}
th{background:#eee;position:sticky;top:0}td.n{text-align:right;font-variant-numeric:tabular-nums}
.wrap{max-height:32em;overflow:auto;display:inline-block;max-width:100%}
figure{margin:1em 0}img{max-width:100%;border:1px solid #ddd}
dl{display:grid;grid-template-columns:max-content auto;gap:.2em 1em}dt{font-weight:bold}
.note{color:#666;font-size:.85em}
"""

# Counts the pictures that drew once the page has loaded: `data-pictures-drawn` on <body>
# (a browser test reads it); inline, nothing is fetched.
_SCRIPT = """
window.addEventListener('load',function(){var n=0;
document.querySelectorAll('img').forEach(function(i){if(i.complete&&i.naturalWidth>0)n++;});
document.body.setAttribute('data-pictures-drawn',String(n));});
"""


def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _table_html(t: Table, n: int) -> str:
    head = "".join(f"<th>{_e(c)}</th>" for c in t.columns)
    body = []
    for row in t.rows:
        cells = []
        for v in row:
            numeric = isinstance(v, int | float) and not isinstance(v, bool)
            cls = ' class="n"' if numeric else ""
            cells.append(f"<td{cls}>{_e(cell_text(v))}</td>")
        body.append(f"<tr>{''.join(cells)}</tr>")
    note = f'<p class="note">{_e(t.note)}</p>' if t.note else ""
    return (
        f'<h3 id="table-{n}">{_e(t.title)}</h3>{note}<div class="wrap">'
        f'<table data-source="{_e(t.source)}" data-rows="{len(t.rows)}">'
        f"<thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table></div>"
    )


def render(report: Report) -> str:
    """The report as one HTML document."""
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f'<meta name="generator" content="transplanter {_e(report.version)}">',
        f"<title>{_e(report.title)}</title><style>{_STYLE}</style>",
        f"<script>{_SCRIPT}</script></head><body>",
        f"<h1>{_e(report.title)}</h1>",
        "<dl>",
        f"<dt>command</dt><dd><code>{_e(report.command)}</code></dd>",
        f"<dt>version</dt><dd>transplanter {_e(report.version)}, Python "
        f"{_e(platform.python_version())}{_e(_mujoco_version())}</dd>",
    ]
    if report.seeds:
        parts.append(f"<dt>seeds</dt><dd>{_e(report.seeds)}</dd>")
    if report.overrides:
        parts.append(f"<dt>--set</dt><dd><code>{_e(' '.join(report.overrides))}</code></dd>")
    parts.append("</dl>")
    for note in report.notes:
        parts.append(f'<p class="note">{_e(note)}</p>')
    if report.summary:
        parts.append(f"<h2>Summary</h2><pre>{_e(report.summary.rstrip())}</pre>")
    if report.pictures:
        parts.append("<h2>Pictures</h2>")
        for p in report.pictures:
            data = base64.b64encode(p.png).decode("ascii")
            parts.append(
                f'<figure><img alt="{_e(p.caption)}" src="data:image/png;base64,{data}">'
                f"<figcaption>{_e(p.caption)}</figcaption></figure>"
            )
    if report.tables:
        parts.append("<h2>Tables</h2>")
        parts += [_table_html(t, n) for n, t in enumerate(report.tables)]
    if report.scenarios:
        parts.append("<h2>Scenario files as read</h2>")
        parts.append(
            '<p class="note">The scenario and its base chain, each file as it was read; '
            "the run's --set overrides are above.</p>"
        )
        for s in report.scenarios:
            parts.append(f"<h3>{_e(s.name)}</h3><pre>{_e(s.text)}</pre>")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def _mujoco_version() -> str:
    try:
        import mujoco
    except ImportError:  # pragma: no cover - a dependency
        return ""
    return f", MuJoCo {mujoco.__version__}"


def scenario_texts(paths: Iterable[Path]) -> list[ScenarioText]:
    """The scenario files as read (a file that cannot be read says so)."""
    out = []
    for p in paths:
        try:
            text = Path(p).read_text(encoding="utf-8")
        except OSError as exc:
            text = f"(could not be read: {exc})"
        out.append(ScenarioText(str(p), text))
    return out
