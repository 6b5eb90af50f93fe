"""Data flows one way: the import graph of pbr_xval has no cycle and no edge to a higher layer.

Every module of the installed package is parsed with :mod:`ast` — ``pbr_xval/``, plus
``engines/`` and ``reference/``, installed as ``pbr_xval.engines`` and ``pbr_xval.reference``.
Module-level and function-level imports both count (a lazy import is still a dependency);
imports under ``if TYPE_CHECKING:`` do not (they never run). ``from pkg import name`` is an edge
to ``pkg.name`` when that is a module, else to ``pkg``. The implicit import of a parent package
(``import a.b`` runs ``a/__init__``) is not an edge: ``pbr_xval/__init__`` is the façade at the
top and must stay importable without any engine.

The layers (low → high; a module may import from its own layer or any lower one). The same
table, with what each layer holds, is in ``docs/architecture.md``.
"""

from __future__ import annotations

import ast
from fnmatch import fnmatchcase
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TREES = {
    "pbr_xval": ROOT / "pbr_xval",
    "pbr_xval.engines": ROOT / "engines",
    "pbr_xval.reference": ROOT / "reference",
}

#: (layer name, module patterns), lowest first; an exact name wins, then the first matching pattern
LAYERS: list[tuple[str, tuple[str, ...]]] = [
    # small shared pieces: units, hashing, JSON, atomic writes, errors, version, settings table, consoles
    (
        "foundation",
        (
            "pbr_xval.units",
            "pbr_xval.hashing",
            "pbr_xval.jsonio",
            "pbr_xval.atomic",
            "pbr_xval.errors",
            "pbr_xval.version",
            "pbr_xval.registry",
            "pbr_xval.status",
            "pbr_xval.settings_spec",
            "pbr_xval.tomlio",
            "pbr_xval.lifeline",
            "pbr_xval.quaternions",
            "pbr_xval.linalg3",
            "pbr_xval.machine",
            "pbr_xval.console",
        ),
    ),
    # scan → rock model; ground motions
    ("model", ("pbr_xval.geometry", "pbr_xval.geometry.*", "pbr_xval.motion", "pbr_xval.motion.*")),
    # what the user writes
    ("scenario", ("pbr_xval.scenario", "pbr_xval.plausibility", "pbr_xval.uncertainty")),
    # what is simulated
    ("scene", ("pbr_xval.scene",)),
    # what every engine returns: the trajectory and its engine-neutral diagnostics
    ("trajectory", ("pbr_xval.trajectory", "pbr_xval.diagnostics")),
    # the engine interface and registry lookup, the shared stepping core
    ("engine", ("pbr_xval.engine", "pbr_xval.stepping", "pbr_xval.stepping.*")),
    # the solvers behind that interface, and running a scene through one
    (
        "engines",
        (
            "pbr_xval.analytical",
            "pbr_xval.analytical.*",
            "pbr_xval.reference",
            "pbr_xval.reference.*",
            "pbr_xval.engines",
            "pbr_xval.engines.*",
            "pbr_xval.runner",
        ),
    ),
    # the engine test suite (conformance checks and their public runner)
    ("conformance", ("pbr_xval.conformance", "pbr_xval.testing")),
    # studies over trajectories; figure primitives they draw with (report.style, report.figures
    # import nothing above this layer)
    (
        "study",
        (
            "pbr_xval.study",
            "pbr_xval.study.*",
            "pbr_xval.catalog",
            "pbr_xval.catalog.*",
            "pbr_xval.validation",
            "pbr_xval.validation.*",
            "pbr_xval.hazard",
            "pbr_xval.hazard.*",
            "pbr_xval.report.style",
            "pbr_xval.report.figures",
        ),
    ),
    # the HTML/Markdown report of a study
    ("report", ("pbr_xval.report", "pbr_xval.report.*")),
    # the package façade (pbr_xval/__init__: simulate, load_scenario, …)
    ("api", ("pbr_xval",)),
    # command line on top
    ("cli", ("pbr_xval.cli", "pbr_xval.cli.*", "pbr_xval.catalog.__main__")),
]


def _modules() -> dict[str, Path]:
    out: dict[str, Path] = {}
    for pkg, folder in TREES.items():
        for path in sorted(folder.rglob("*.py")):
            if "__pycache__" in path.parts:
                continue
            parts = list(path.relative_to(folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            if pkg == "pbr_xval" and parts and parts[0] in ("engines", "reference"):
                continue  # not installed from pbr_xval/ (package-dir mapping)
            out[".".join([pkg, *parts])] = path
    return out


MODULES = _modules()


def _resolve(name: str) -> str | None:
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def imports_of(module: str) -> dict[str, int]:
    """pbr_xval modules imported by ``module`` -> first line number of the import."""
    path = MODULES[module]
    is_pkg = path.name == "__init__.py"
    out: dict[str, int] = {}

    def add(target: str | None, line: int) -> None:
        if target and target != module:
            out.setdefault(target, line)

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child.test):
                for sub in child.orelse:
                    visit_node(sub)
                continue
            visit_node(child)

    def visit_node(node: ast.AST) -> None:
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "pbr_xval":
                    add(_resolve(alias.name), node.lineno)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".") if is_pkg else module.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                full = ".".join(base + ([node.module] if node.module else []))
            else:
                full = node.module or ""
            if full.split(".")[0] != "pbr_xval":
                return
            for alias in node.names:
                sub = f"{full}.{alias.name}"
                add(sub if sub in MODULES else _resolve(full), node.lineno)
        else:
            visit(node)

    visit(ast.parse(path.read_text(encoding="utf-8"), str(path)))
    return out


GRAPH = {m: imports_of(m) for m in MODULES}


def layer_of(module: str) -> int:
    """Index in LAYERS of ``module``: an exact name wins over a wildcard (``catalog.__main__``)."""
    for i, (_, patterns) in enumerate(LAYERS):
        if module in patterns:
            return i
    for i, (_, patterns) in enumerate(LAYERS):
        if any(fnmatchcase(module, p) for p in patterns):
            return i
    raise LookupError(module)


def _where(a: str, b: str) -> str:
    return f"{MODULES[a].relative_to(ROOT)}:{GRAPH[a][b]}"


def test_every_module_has_a_layer() -> None:
    missing = []
    for m in MODULES:
        try:
            layer_of(m)
        except LookupError:
            missing.append(m)
    assert not missing, f"modules not in the layer table of tests/test_import_graph.py: {missing}"


def test_no_import_from_a_higher_layer() -> None:
    bad = []
    for a, targets in GRAPH.items():
        for b in targets:
            la, lb = layer_of(a), layer_of(b)
            if lb > la:
                bad.append(f"{_where(a, b)}: {a} ({LAYERS[la][0]}) imports {b} ({LAYERS[lb][0]})")
    assert not bad, "imports from a higher layer:\n" + "\n".join(sorted(bad))


def _cycles() -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = iter(range(len(GRAPH) * 2))

    def strong(v: str) -> None:
        index[v] = low[v] = next(counter)
        stack.append(v)
        on.add(v)
        for w in GRAPH[v]:
            if w not in index:
                strong(w)
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

    for v in sorted(GRAPH):
        if v not in index:
            strong(v)
    return out


def test_no_cycles() -> None:
    cycles = _cycles()
    lines = []
    for comp in cycles:
        edges = [f"{_where(a, b)}: {a} -> {b}" for a in comp for b in GRAPH[a] if b in comp]
        lines.append("cycle among " + ", ".join(comp) + ":\n  " + "\n  ".join(edges))
    assert not cycles, "\n".join(lines)


def test_graph_sees_known_edges() -> None:
    """The parser finds module-level, function-level and relative imports, and skips TYPE_CHECKING."""
    assert "pbr_xval.scenario" in GRAPH["pbr_xval.scene"]  # module level, ``from pbr_xval import scenario``
    assert "pbr_xval.plausibility" in GRAPH["pbr_xval.scene"]  # inside a function
    assert "pbr_xval.engines._common" in GRAPH["pbr_xval.engines.mujoco_"]  # engines/ mapped
    assert "pbr_xval.scene" not in GRAPH["pbr_xval.engine"]  # only under TYPE_CHECKING


@pytest.mark.parametrize(
    ("module", "layer"),
    [("pbr_xval.units", "foundation"), ("pbr_xval.geometry.io", "model"), ("pbr_xval.cli.simulate", "cli")],
)
def test_layer_table(module: str, layer: str) -> None:
    assert LAYERS[layer_of(module)][0] == layer


def test_docs_table_matches_layers() -> None:
    """docs/architecture.md shows the same layers, in the same order, with the same modules."""
    import re

    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| (\d+) \| (\w+) \| ([^|]+) \|", doc, re.MULTILINE)
    assert [name for _, name, _ in rows] == [name for name, _ in LAYERS]
    for (_, name, mods), (_, patterns) in zip(rows, LAYERS, strict=True):
        shown = set(re.findall(r"`([^`]+)`", mods))
        for pat in patterns:
            base = (pat.removeprefix("pbr_xval.") if pat != "pbr_xval" else pat).removesuffix(".*")
            assert shown & {base, f"{base}.*", f"{base}*"}, (
                f"layer {name}: {pat} is in tests/test_import_graph.py but not in docs/architecture.md"
            )
