"""The package's import structure: no cycles, bpy sealed in blender/, a light CLI."""

from __future__ import annotations

import ast
import subprocess
import sys

from tests.util import ROOT

SRC = ROOT / "src"
PKG = SRC / "deformsim"
DRIVER = ("deformsim.generate", "deformsim.cli", "deformsim.pipeline", "deformsim.api", "deformsim.learn",
          "deformsim.composite", "deformsim.evaluate", "deformsim.report")


def _modules() -> dict[str, ast.Module]:
    out = {}
    for path in PKG.rglob("*.py"):
        parts = path.relative_to(SRC).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = ast.parse(path.read_text())
    return out


def import_graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports anywhere in its body (function-level imports included)."""
    mods = _modules()
    graph = {m: set() for m in mods}
    for name, tree in mods.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in mods else node.module
                           for a in node.names]
            else:
                continue
            graph[name] |= {t for t in targets if t in mods and t != name}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_cycle_finder_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycles():
    assert cycles(import_graph()) == []


def test_blender_side_imports_no_driver_module():
    bad = {m: sorted(d for d in deps if d.startswith(DRIVER))
           for m, deps in import_graph().items() if m.startswith("deformsim.blender")}
    assert {m: d for m, d in bad.items() if d} == {}


def test_only_blender_imports_bpy():
    users = {m for m, tree in _modules().items() for node in ast.walk(tree)
             if isinstance(node, ast.Import) and any(a.name == "bpy" for a in node.names)}
    assert users and all(m.startswith("deformsim.blender") for m in users)


def test_cli_and_pipeline_import_neither_torch_nor_bpy():
    code = "import sys, deformsim, deformsim.cli, deformsim.pipeline; print(sorted({'torch', 'bpy'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
