"""The package's shape: no import circle (module- and function-level imports, type-checking ones included), imports
only down the layers of the data flow, few modules at the top level, no module reaching into another's private
names. Read from the installed package's source, so it holds for what `pip install .` ships."""
from __future__ import annotations

import ast
import collections
from pathlib import Path

import ancf_sym

ROOT = Path(ancf_sym.__file__).parent

# Layers, top down (docs/code_map.md): a module imports only from its own package or from layers below its own.
LAYERS = [("cli",), ("study",), ("control", "modal", "sensitivity", "water"), ("io",), ("dynamics",), ("statics",),
          ("system",), ("model",), ("scene",), ("contact",), ("bodies",), ("kernels", "codegen"),
          ("registry", "elements", "util")]
LEVEL = {name: k for k, names in enumerate(LAYERS) for name in names}


def _modules() -> dict[str, tuple[Path, bool]]:
    out = {}
    for p in ROOT.rglob("*.py"):
        if "_kernels" in p.parts:
            continue
        parts = ["ancf_sym", *p.relative_to(ROOT).with_suffix("").parts]
        is_pkg = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_pkg else parts)] = (p, is_pkg)
    return out


def _imports() -> tuple[dict[str, set[str]], list[str]]:
    """module -> the package modules it imports (wherever in the file), and the private names imported across."""
    mods = _modules()
    graph, private = collections.defaultdict(set), []
    for name, (path, is_pkg) in mods.items():
        package = name if is_pkg else name.rsplit(".", 1)[0]
        nodes = list(ast.walk(ast.parse(path.read_text())))
        for node in nodes:
            if isinstance(node, ast.ImportFrom):
                target = node.module or ""
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - node.level + 1]
                    target = ".".join(base + ([node.module] if node.module else []))
                for a in node.names:
                    sub = f"{target}.{a.name}"
                    if sub in mods:
                        graph[name].add(sub)
                    elif target in mods:
                        graph[name].add(target)
                        if a.name.startswith("_") and not a.name.startswith("__") and target != name:
                            private.append(f"{name}: from {target} import {a.name}")
            elif isinstance(node, ast.Import):
                graph[name].update(a.name for a in node.names if a.name in mods)
        imported = {a.asname or a.name: f"{n.module}.{a.name}" for n in nodes
                    if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("ancf_sym") for a in n.names
                    if f"{n.module}.{a.name}" in mods}
        for node in nodes:  # module._private
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in imported
                    and node.attr.startswith("_") and not node.attr.startswith("__")):
                private.append(f"{name}: {imported[node.value.id]}.{node.attr}")
        graph[name].discard(name)
    return graph, private


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
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

    for v in list(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_circle():
    graph, _ = _imports()
    assert _cycles(graph) == []


def test_few_modules_at_the_top_level():
    top = sorted(p.name for p in ROOT.glob("*.py"))
    assert len(top) <= 8, top


def test_imports_go_down_the_layers():
    graph, _ = _imports()
    wrong = []
    for a, targets in graph.items():
        pa = a.split(".")[1] if "." in a else ""
        for b in targets:
            pb = b.split(".")[1] if "." in b else ""
            if pa and pb and pa != pb and LEVEL[pb] < LEVEL[pa]:
                wrong.append(f"{a} -> {b}")
    assert wrong == []


def test_every_package_has_a_layer():
    packages = {p.parent.name for p in ROOT.glob("*/__init__.py")} | {p.stem for p in ROOT.glob("*.py")}
    assert packages - {"__init__"} <= set(LEVEL), sorted(packages - {"__init__"} - set(LEVEL))


def test_no_module_writes_another_objects_private_fields():
    """Helpers take what they need and return what they build: an assignment to `obj._name` is only for obj = self
    (or cls)."""
    writes = []
    for path in ROOT.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and node.attr.startswith("_")
                    and not node.attr.startswith("__")
                    and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"))):
                writes.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    assert writes == []


def test_no_module_imports_another_modules_private_names():
    _, private = _imports()
    assert private == []
