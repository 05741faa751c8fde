"""No import cycle among weavecap's modules: every ``import`` and ``from … import`` of every
module (read with ``ast``, wherever it stands: at the top, in a function, under
``TYPE_CHECKING``) is an edge, and the graph must have no cycle."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: package name → its folder (cli/ and fixtures/ install inside weavecap, setup.py's MAPPED)
FOLDERS = {"weavecap": ROOT / "weavecap", "weavecap.cli": ROOT / "cli", "weavecap.fixtures": ROOT / "fixtures"}


def modules() -> dict[str, Path]:
    """Dotted module name → file, for every module of the three folders."""
    found = {}
    for package, folder in FOLDERS.items():
        for path in sorted(folder.rglob("*.py")):
            parts = list(path.relative_to(folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join([package, *parts])] = path
    return found


def imported(name: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The modules of ``known`` that module ``name`` (at ``path``) imports, with the packages
    above them that Python runs first (but not the importing module's own packages)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    targets = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                base = ".".join(parts + ([base] if base else []))
            targets += [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names]
    edges = set()
    for target in targets:
        parts = target.split(".")
        for k in range(1, len(parts) + 1):
            above = ".".join(parts[:k])
            if above in known and above != name and not name.startswith(above + "."):
                edges.add(above)
    return edges


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

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


def test_the_package_has_no_import_cycle():
    known = modules()
    assert {"weavecap.pipeline", "weavecap.fit.rounds", "weavecap.cli.main"} <= set(known)
    graph = {name: imported(name, path, known) for name, path in known.items()}
    assert "weavecap.fit.rounds" in graph["weavecap.stages"]  # the walk sees imports inside functions
    assert cycles(graph) == []


def test_the_walk_finds_a_cycle_through_a_type_checking_import(tmp_path):
    """The cycle the capture had: fit/rounds.py imported the runner's options for its types,
    and the runner imports fit/rounds.py."""
    (tmp_path / "fit").mkdir()
    (tmp_path / "pipeline.py").write_text("def capture():\n    from .fit.rounds import fit_registered\n")
    (tmp_path / "fit" / "__init__.py").write_text("")
    (tmp_path / "fit" / "rounds.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..pipeline import CaptureOptions\n")
    known = {"pkg": tmp_path / "__init__.py", "pkg.pipeline": tmp_path / "pipeline.py",
             "pkg.fit": tmp_path / "fit" / "__init__.py", "pkg.fit.rounds": tmp_path / "fit" / "rounds.py"}
    (tmp_path / "__init__.py").write_text("")
    graph = {name: imported(name, path, known) for name, path in known.items()}
    assert cycles(graph) == [["pkg.fit.rounds", "pkg.pipeline"]]
