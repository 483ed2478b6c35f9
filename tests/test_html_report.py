"""The HTML report (transplanter.viewing.html_report, `--report` of trial, sweep and compare): one
self-contained file whose tables hold what the JSON and CSV files hold, row for row, whose
pictures draw, opened in headless Chromium (Debian's package, installed by `.ci/run`)."""

from __future__ import annotations

import csv
import html.parser
import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from transplanter.cli import main
from transplanter.viewing import html_report

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None and not os.environ.get("CI"),
    reason="headless Chromium is not installed (apt-get install chromium; .ci/run does)",
)


class _Page(html.parser.HTMLParser):
    """The title, the tables (source, declared rows, header, cells) and the images."""

    def __init__(self) -> None:
        super().__init__()
        self.title, self.tables, self.images, self.body = "", [], [], {}
        self._in_title, self._in_head = False, False
        self._cell: list[str] | None = None
        self._row: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "title":
            self._in_title = True
        elif tag == "body":
            self.body = a
        elif tag == "table":
            self.tables.append({"source": a.get("data-source"), "rows": int(a["data-rows"]),
                                "head": [], "cells": []})  # fmt: skip
        elif tag == "thead":
            self._in_head = True
        elif tag == "tr":
            self._row = []
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "img":
            self.images.append(a)

    def handle_endtag(self, tag):
        if tag == "title":
            self._in_title = False
        elif tag == "thead":
            self._in_head = False
        elif tag in ("td", "th") and self._cell is not None:
            self._row.append("".join(self._cell))
            self._cell = None
        elif tag == "tr" and self._row is not None:
            t = self.tables[-1]
            if self._in_head:
                t["head"] = self._row
            else:
                t["cells"].append(self._row)
            self._row = None

    def handle_data(self, data):
        if self._in_title:
            self.title += data
        if self._cell is not None:
            self._cell.append(data)


def _page(text: str) -> _Page:
    p = _Page()
    p.feed(text)
    return p


def _resolve(payload, path: str):
    """A JSON path of a table's data-source ('per_seedling', 'motors.drives',
    'trials[1].per_seedling', '' for the top level); a key holding a dot
    ('scenario.seedlings' of the overrides) is taken whole."""
    if isinstance(payload, dict) and path in payload:
        return payload[path]
    node = payload
    for part in filter(None, path.split(".")):
        m = re.fullmatch(r"(\w+)((?:\[\d+\])*)", part)
        node = node[m.group(1)]
        for i in re.findall(r"\[(\d+)\]", m.group(2)):
            node = node[int(i)]
    return node


def _check_tables_against_json(page: _Page, payload) -> int:
    """Every table's rows are the JSON's at its source, cell for cell; every key of the
    JSON's top level is in a table."""
    for t in page.tables:
        assert t["rows"] == len(t["cells"]), t["source"]
        node = _resolve(payload, t["source"])
        if isinstance(node, list) and node and isinstance(node[0], dict):  # records
            want = [[html_report.cell_text(r.get(c)) for c in t["head"]] for r in node]
        elif isinstance(node, list):
            want = [[html_report.cell_text(v)] for v in node]
        else:  # key and value: each row's value is the JSON's at its key
            assert t["head"] == ["key", "value"]
            want = [[k, html_report.cell_text(_resolve(node, k))] for k, _ in t["cells"]]
        assert t["cells"] == want, t["source"]
    top = next((t for t in page.tables if t["source"] == ""), {"cells": []})
    shown = {k for k, _ in top["cells"]} | {
        re.split(r"[.\[]", t["source"])[0] for t in page.tables if t["source"]
    }
    assert set(payload) <= shown
    return len(page.tables)


# -- the module ------------------------------------------------------------------------------


def test_a_result_becomes_tables_by_its_shape():
    payload = {
        "scenario": "x", "success_rate": 0.975, "ci": [0.9, 1.0], "fault": None,
        "failures": {"slipped": 1, "damaged": 0},
        "motors": {"energy_j": 7.25, "drives": [{"name": "a", "peak": 1.5}, {"name": "b"}]},
        "per_seedling": [{"index": 0, "outcome": "success"}, {"index": 1, "outcome": "slipped",
                                                               "pot": 3}],
        "warnings": ["w1", "w2", "w3", "w4", "w5"],
    }  # fmt: skip
    tables = {t.source: t for t in html_report.tables_of(payload)}
    assert tables[""].rows == (("scenario", "x"), ("success_rate", 0.975),
                               ("ci", [0.9, 1.0]), ("fault", None))  # fmt: skip
    assert tables["failures"].rows == (("slipped", 1), ("damaged", 0))
    assert tables["motors"].rows == (("energy_j", 7.25),)
    assert tables["motors.drives"].columns == ("name", "peak")
    assert tables["motors.drives"].rows == (("a", 1.5), ("b", None))
    assert tables["per_seedling"].columns == ("index", "outcome", "pot")
    assert tables["warnings"].rows == (("w1",), ("w2",), ("w3",), ("w4",), ("w5",))
    assert [html_report.cell_text(v) for v in (None, True, 3, 0.1 + 0.2, [1, 2], "a")] == [
        "-", "true", "3", "0.3", "[1, 2]", "a"]  # fmt: skip


def test_a_pooled_runs_trials_each_get_their_records_table():
    payload = {"trials": [{"seed": s, "per_seedling": [{"outcome": "success"}] * s}
                          for s in (1, 2)], "pooled": {"successes": 3}}  # fmt: skip
    tables = {t.source: t for t in html_report.tables_of(payload)}
    assert tables["trials"].columns == ("seed",)  # the nested records have their own tables
    assert len(tables["trials[0].per_seedling"].rows) == 1
    assert len(tables["trials[1].per_seedling"].rows) == 2
    assert tables["pooled"].rows == (("successes", 3),)


def test_text_is_escaped_and_pictures_are_embedded():
    report = html_report.Report(
        title="t <b>", command="transplanter trial '<x>'", version="0",
        summary="a < b & c", tables=html_report.tables_of({"k": "<script>alert(1)</script>"}),
        pictures=[html_report.Picture("p", b"\x89PNG fake")],
    )  # fmt: skip
    text = html_report.render(report)
    assert "<script>alert(1)" not in text and "&lt;script&gt;alert(1)" in text
    assert "<title>t &lt;b&gt;</title>" in text and "a &lt; b &amp; c" in text
    assert 'src="data:image/png;base64,iVBORyBmYWtl"' in text
    assert "http://" not in text and "https://" not in text  # nothing is fetched


def test_a_long_table_says_where_the_rest_is(monkeypatch):
    monkeypatch.setattr(html_report, "MAX_ROWS", 3)
    t = html_report.records_table("runs", "runs.csv", [{"i": i} for i in range(5)])
    assert len(t.rows) == 3 and "the first 3 of 5 rows" in t.note


def test_the_units_picture_draws_each_outcome():
    t = html_report.records_table("per_seedling", "per_seedling", [
        {"outcome": "success", "t_start_s": 1.0, "cycle_time_s": 3.5},
        {"outcome": "slipped", "t_start_s": 4.5, "cycle_time_s": 3.4},
    ])  # fmt: skip
    picture = html_report.units_picture(t)
    import cv2

    image = cv2.imdecode(np.frombuffer(picture.png, np.uint8), cv2.IMREAD_COLOR)
    assert image.shape[0] > 100 and image.std() > 10
    assert html_report.units_picture(html_report.records_table("x", "x", [{"a": 1}])) is None


# -- the commands ----------------------------------------------------------------------------


def test_a_trials_report_holds_its_json_row_for_row(tmp_path, capsys):
    out, report = tmp_path / "r.json", tmp_path / "r.html"
    args = ["trial", "paper", "--seedlings", "2", "--json", str(out), "--report", str(report)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert f"report written to {report}" in printed
    page = _page(report.read_text())
    payload = json.loads(out.read_text())
    assert page.title == "transplanter trial paper"
    assert _check_tables_against_json(page, payload) >= 5
    per_seedling = next(t for t in page.tables if t["source"] == "per_seedling")
    assert len(per_seedling["cells"]) == 2
    assert len(page.images) == 1 and page.images[0]["src"].startswith("data:image/png;base64,")
    text = report.read_text()
    assert "plants per hour" in text  # the summary as printed
    assert "[conveyor]" in text  # the base chain's files as read
    assert "--seedlings 2" in text  # the command


def test_a_pooled_trials_report_has_each_seeds_units(tmp_path):
    out, report = tmp_path / "r.json", tmp_path / "r.html"
    assert main(["trial", "paper", "--seedlings", "1", "--seeds", "2-3", "--json", str(out),
                 "--report", str(report)]) == 0  # fmt: skip
    page = _page(report.read_text())
    payload = json.loads(out.read_text())
    _check_tables_against_json(page, payload)
    sources = {t["source"] for t in page.tables}
    assert {"trials[0].per_seedling", "trials[1].per_seedling", "pooled"} <= sources
    assert "2, 3" in report.read_text()  # the seeds


def test_a_sweeps_report_holds_its_csv_files(tmp_path):
    out, report = tmp_path / "sw", tmp_path / "sw.html"
    assert main(["sweep", "paper", "--vary", "taught.z_low_mm=28,32", "--seedlings", "1",
                 "--out", str(out), "--report", str(report), "--quiet"]) == 0  # fmt: skip
    page = _page(report.read_text())
    for t in page.tables:
        with open(out / t["source"], newline="") as f:
            rows = list(csv.DictReader(f))
        assert t["rows"] == len(rows) == len(t["cells"])
        keys = [c for c in t["head"] if c in rows[0]]
        assert "taught.z_low_mm" in keys
        i = t["head"].index("taught.z_low_mm")
        assert [r[i] for r in t["cells"]] == [str(int(float(r["taught.z_low_mm"]))) for r in rows]
    assert len(page.images) == len(list(out.glob("*.png"))) == 1


def test_a_comparisons_report_holds_its_rows_per_job(tmp_path):
    out, report = tmp_path / "cmp", tmp_path / "cmp.html"
    assert main(["compare", "paper", "paper_tuned", "--seeds", "1", "--seedlings", "1",
                 "--out", str(out), "--report", str(report), "--quiet"]) == 0  # fmt: skip
    page = _page(report.read_text())
    rows = json.loads((out / "compare.json").read_text())["rows"]
    (table,) = page.tables
    assert table["source"] == "compare.json#rows?workcell=conveyor_tube"
    i = table["head"].index("scenario")
    assert [r[i] for r in table["cells"]] == [r["scenario"] for r in rows]  # ranked order
    assert len(page.images) == 1  # compare.png


def test_a_report_is_refused_before_any_work(tmp_path, capsys):
    report = tmp_path / "r.html"
    json_path = tmp_path / "r.json"
    assert main(["trial", "paper", "--report", str(tmp_path / "no" / "r.html")]) == 2
    assert "--report" in capsys.readouterr().err
    assert main(["trial", "paper", "--json", str(report), "--report", str(report)]) == 2
    assert "name the same file" in capsys.readouterr().err
    scenario = tmp_path / "s.toml"
    scenario.write_text('[scenario]\nbase = "paper"\n')
    os.link(scenario, tmp_path / "s.html")  # the scenario under another name
    assert main(["trial", str(scenario), "--report", str(tmp_path / "s.html")]) == 2
    assert "never replaces an input" in capsys.readouterr().err
    assert main(["compare", "paper", str(scenario), "--out", str(tmp_path / "c"),
                 "--report", str(tmp_path / "s.html")]) == 2  # fmt: skip
    assert "never replaces an input" in capsys.readouterr().err
    assert main(["trial", "no_such", "--report", str(report)]) == 2  # refused: no report
    assert not report.exists() and not json_path.exists()
    assert scenario.read_text() == '[scenario]\nbase = "paper"\n'


# -- in a browser ----------------------------------------------------------------------------


def _chromium(*args: str, user_dir: Path) -> subprocess.CompletedProcess:
    assert CHROMIUM is not None, "CI installs Debian's chromium (.ci/run)"
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={user_dir}"]  # fmt: skip
    return subprocess.run([CHROMIUM, *flags, *args], capture_output=True, text=True, timeout=120)


@needs_chromium
def test_a_report_opens_in_headless_chromium_with_every_table_and_picture(tmp_path):
    import cv2

    out, report = tmp_path / "r.json", tmp_path / "r.html"
    assert main(["trial", "delta_pots", "--seedlings", "2", "--json", str(out), "--report",
                 str(report), "--quiet"]) == 0  # fmt: skip
    shot = tmp_path / "shot.png"
    done = _chromium("--window-size=1280,2000", f"--screenshot={shot}", report.as_uri(),
                     user_dir=tmp_path / "u1")  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    image = cv2.imread(str(shot))
    assert image.shape[:2] == (2000, 1280) and image.std() > 10  # a page drew, not a blank
    dom = _chromium("--virtual-time-budget=5000", "--dump-dom", report.as_uri(),
                    user_dir=tmp_path / "u2")  # fmt: skip
    assert dom.returncode == 0, dom.stderr[-2000:]
    page = _page(dom.stdout)  # the page as the browser built it
    assert page.title == "transplanter trial delta_pots"
    assert _check_tables_against_json(page, json.loads(out.read_text())) >= 5
    assert page.images and page.body.get("data-pictures-drawn") == str(len(page.images))


def test_a_report_that_cannot_be_written_exits_5_with_the_json_written(tmp_path, monkeypatch,
                                                                        capsys):  # fmt: skip
    from transplanter import fileio

    write = fileio.write_text_atomic

    def refuse_html(path, text, **kw):
        if str(path).endswith(".html"):
            raise OSError(28, "No space left on device")
        return write(path, text, **kw)

    monkeypatch.setattr(fileio, "write_text_atomic", refuse_html)
    out, report = tmp_path / "r.json", tmp_path / "r.html"
    args = ["trial", "paper", "--seedlings", "1", "--json", str(out), "--report", str(report)]
    assert main(args) == 5
    assert "the report could not be written" in capsys.readouterr().err
    assert json.loads(out.read_text())["seedlings"] == 1 and not report.exists()
