"""The package tree follows the data: packages, a handful of top-level modules, no import
circles (any import anywhere in a module counts, TYPE_CHECKING or inside a function too)."""

from __future__ import annotations

import ast
from pathlib import Path

import transplanter

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGES = {"cli", "kinds", "scenario", "machine", "scene", "twin", "viewing", "runs", "studies"}


def _modules() -> dict[str, Path]:
    out = {}
    for path in (SRC / "transplanter").rglob("*.py"):
        name = ".".join(path.relative_to(SRC).with_suffix("").parts)
        out[name.removesuffix(".__init__")] = path
    return out


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    graph = {}
    for name, path in modules.items():
        deps = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                for alias in node.names:
                    full = f"{node.module}.{alias.name}"
                    deps.add(full if full in modules else node.module)
            elif isinstance(node, ast.Import):
                deps.update(alias.name for alias in node.names)
        graph[name] = {d for d in deps if d in modules and d != name}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_another_that_imports_it_back():
    assert _cycles(_graph()) == []


def test_the_cycle_finder_sees_a_circle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_the_top_level_holds_packages_and_a_handful_of_modules():
    top = SRC / "transplanter"
    packages = {p.name for p in top.iterdir() if (p / "__init__.py").is_file()}
    modules = {p.stem for p in top.glob("*.py")} - {"__init__"}
    assert PACKAGES <= packages
    assert modules <= {"errors", "units", "fileio", "interrupts"}


def test_the_public_api_is_declared():
    assert set(transplanter.__all__) >= {"load_scenario", "assemble", "run_trial", "Kinematics"}
    for name in transplanter.__all__:
        assert getattr(transplanter, name) is not None
