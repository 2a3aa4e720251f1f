"""The layers of ``docs/architecture.md``, kept: no module imports a layer above its own, and no
import cycle between modules. Every import counts — at module level, inside functions (lazy)
and under ``if TYPE_CHECKING:`` — because each is a dependency a reader has to follow.

The check reads the source with :mod:`ast` (nothing is imported), so a test below can plant a
violation in a throw-away package and watch the check fail.
"""

from __future__ import annotations

import ast
from collections.abc import Mapping
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "marknav"

#: Bottom to top. Packages on one line are peers: neither imports the other.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("core",),
    ("planning",),
    ("vision", "robot"),
    ("remote",),
    ("sim",),
    ("missions",),
    ("behaviours",),
    ("testing",),
    ("runs",),
    ("cli",),
    ("__main__",),
)


def module_graph(package: Path) -> dict[str, set[str]]:
    """``{module: modules of the same package it imports}``, dotted names from the package."""
    name = package.name
    modules: dict[str, Path] = {}
    for path in package.rglob("*.py"):
        parts = list(path.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        modules[".".join(parts)] = path

    def resolve(dotted: str) -> str | None:
        while dotted and dotted not in modules:
            dotted = dotted.rpartition(".")[0]
        return dotted or None

    graph: dict[str, set[str]] = {}
    for module, path in modules.items():
        targets: set[str | None] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets.update(resolve(a.name) for a in node.names
                               if a.name.split(".")[0] == name)
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                if node.module.split(".")[0] != name:
                    continue
                for alias in node.names:  # `from pkg import submodule` names the submodule
                    full = f"{node.module}.{alias.name}"
                    targets.add(full if full in modules else resolve(node.module))
        graph[module] = {t for t in targets if t is not None and t not in (module, name)}
    return graph


def layer_of(module: str) -> int | None:
    """The layer index of ``package.sub...`` (``None``: the package's own ``__init__``)."""
    parts = module.split(".")
    if len(parts) < 2:
        return None
    for i, layer in enumerate(LAYERS):
        if parts[1] in layer:
            return i
    raise AssertionError(f"{module}: its package {parts[1]!r} is in no layer of LAYERS")


def upward_imports(graph: Mapping[str, set[str]]) -> list[str]:
    """Every import of a module in a higher layer, or of a peer package of the same layer."""
    found = []
    for module, targets in sorted(graph.items()):
        for target in sorted(targets):
            a, b = layer_of(module), layer_of(target)
            if a is None or b is None:
                continue
            peer = a == b and module.split(".")[1] != target.split(".")[1]
            if b > a or peer:
                found.append(f"{module} -> {target}")
    return found


def cycles(graph: Mapping[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_module_imports_a_layer_above_its_own() -> None:
    assert upward_imports(module_graph(PACKAGE)) == []


#: The packages of ``runs/``, bottom to top (``docs/architecture.md``).
RUNS_LAYERS = ("records", "metrics", "views", "loop", "evaluation", "benchmarks")


def runs_upward_imports(graph: Mapping[str, set[str]]) -> list[str]:
    """Every import, inside ``runs``, of a ``runs`` package above the importer's own."""
    def rank(module: str) -> int | None:
        parts = module.split(".")
        if len(parts) < 4 or parts[1] != "runs":  # marknav.runs.<package>.<module>
            return None
        return RUNS_LAYERS.index(parts[2])
    return [f"{m} -> {t}" for m, targets in sorted(graph.items()) for t in sorted(targets)
            if (a := rank(m)) is not None and (b := rank(t)) is not None and b > a]


def test_the_packages_of_runs_import_one_way() -> None:
    graph = module_graph(PACKAGE)
    assert {m.split(".")[2] for m in graph if m.startswith("marknav.runs.")} == set(RUNS_LAYERS)
    assert runs_upward_imports(graph) == []


def test_a_planted_upward_import_inside_runs_is_found() -> None:
    graph = {"marknav.runs.records.report": {"marknav.runs.loop.run"}}
    assert runs_upward_imports(graph) == ["marknav.runs.records.report -> marknav.runs.loop.run"]


def test_no_import_cycles() -> None:
    assert cycles(module_graph(PACKAGE)) == []


def test_every_package_has_a_layer() -> None:
    packages = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    modules = {p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"}
    placed = {name for layer in LAYERS for name in layer}
    assert packages | modules <= placed


def _plant(tmp_path: Path, files: Mapping[str, str]) -> Path:
    root = tmp_path / "marknav"
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    for folder in [root, *[p for p in root.rglob("*") if p.is_dir()]]:
        (folder / "__init__.py").touch()
    return root


@pytest.mark.parametrize("source", [
    "from marknav.runs import run\n",                       # a plain upward import
    "def f():\n    import marknav.runs.run\n",              # a lazy one
    "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from marknav.runs.run import X\n",
])
def test_a_planted_upward_import_is_found(tmp_path: Path, source: str) -> None:
    root = _plant(tmp_path, {"vision/detect.py": source, "runs/run.py": "X = 1\n"})
    assert upward_imports(module_graph(root)) == ["marknav.vision.detect -> marknav.runs.run"]


def test_a_planted_peer_import_is_found(tmp_path: Path) -> None:
    root = _plant(tmp_path, {"vision/a.py": "from marknav.robot import oi\n", "robot/oi.py": ""})
    assert upward_imports(module_graph(root)) == ["marknav.vision.a -> marknav.robot.oi"]


def test_a_planted_cycle_is_found(tmp_path: Path) -> None:
    root = _plant(tmp_path, {
        "sim/a.py": "from marknav.sim import b\n",
        "sim/b.py": "def f():\n    from marknav.sim.c import g\n",
        "sim/c.py": "from marknav.sim.a import h\n",
    })
    graph = module_graph(root)
    assert upward_imports(graph) == []
    assert cycles(graph) == [["marknav.sim.a", "marknav.sim.b", "marknav.sim.c"]]
