"""The layer contract, read from the code's own imports (every import, function-local too).

    core < data < sim < method < study < analysis < report < (cli, the package's face)

* a module imports only modules of its own layer or of a lower one;
* ``uavwind.core`` imports nothing else of uavwind;
* a private name (``_x``) is imported only from a private module (``_kernels``) of the
  importing module's own package: no private name crosses a module otherwise, and no
  private module is reached from outside its package;
* no two modules import each other, directly or through others (no cycles).
"""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "uavwind"
LAYERS = ["core", "data", "sim", "method", "study", "analysis", "report"]
#: modules outside the layers: the version (importable from anywhere), the old paths, the top
TOP = {"uavwind", "uavwind.cli", "uavwind.__main__"}
ANYWHERE = {"uavwind._version"}
SHIMS = {"uavwind._compat"}  # re-exports old paths lazily; imports layers only when asked


def _modules():
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _package(mod, path):
    return mod if path.name == "__init__.py" else mod.rpartition(".")[0]


def _imports(mod, path):
    """``(target module, [names], line)`` for every import of a uavwind module in ``mod``."""
    tree = ast.parse(path.read_text())
    pkg = _package(mod, path)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "uavwind":
                    out.append((a.name, [], node.lineno))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "uavwind":
                continue
            names = [a.name for a in node.names]
            # "from . import x" / "from .pkg import mod": the names may be modules
            subs = [f"{target}.{n}" for n in names if f"{target}.{n}" in MODULES]
            if subs:
                out += [(s, [], node.lineno) for s in subs]
                names = [n for n in names if f"{target}.{n}" not in MODULES]
                if not names:
                    continue
            out.append((target, names, node.lineno))
    return out


def _layer(mod):
    parts = mod.split(".")
    if len(parts) > 1 and parts[1] in LAYERS:
        return LAYERS.index(parts[1])
    if mod in ANYWHERE:
        return -1
    return len(LAYERS)  # the top: the package face, the CLI, the shims


EDGES = {mod: _imports(mod, path) for mod, path in MODULES.items()}


def test_the_walk_sees_the_package():
    assert "uavwind.sim.dynamics" in MODULES and "uavwind.method.softdtw._kernels" in MODULES
    assert any(t == "uavwind.core.checks" for t, _, _ in EDGES["uavwind.sim.wind"])


def test_no_layer_imports_a_higher_one():
    bad = []
    for mod, edges in EDGES.items():
        if mod in SHIMS:
            continue
        for target, _, line in edges:
            if _layer(target) > _layer(mod):
                bad.append(f"{mod}:{line} imports {target}")
    assert not bad, "\n".join(bad)


def test_core_knows_nothing_of_the_domain():
    for mod, edges in EDGES.items():
        if mod.startswith("uavwind.core"):
            assert all(t.startswith("uavwind.core") for t, _, _ in edges), mod


def _private_module(name):
    return any(p.startswith("_") and not p.startswith("__") for p in name.split(".")[1:])


def test_no_private_name_crosses_a_module():
    bad = []
    for mod, edges in EDGES.items():
        if mod in SHIMS:
            continue
        pkg = _package(mod, MODULES[mod])
        for target, names, line in edges:
            tpkg = target.rpartition(".")[0]
            if target in ANYWHERE:
                continue
            if _private_module(target) and not (tpkg == pkg or target.startswith(pkg + ".")):
                bad.append(f"{mod}:{line} reaches the private module {target}")
            private = [n for n in names if n.startswith("_") and n != "__version__"]
            if private and not (_private_module(target) and tpkg == pkg):
                bad.append(f"{mod}:{line} takes {private} from {target}")
    assert not bad, "\n".join(bad)


def test_no_import_cycles():
    graph = {m: {t for t, _, _ in e if t in MODULES and t != m} for m, e in EDGES.items()
             if m not in TOP | SHIMS}
    # a package imports its own modules to show its face: that is not a cycle
    for m in graph:
        graph[m] = {t for t in graph[m] if not m.startswith(t + ".")}
    state = {}

    def visit(m, path):
        state[m] = 1
        for t in sorted(graph.get(m, ())):
            if state.get(t) == 1:
                pytest.fail("import cycle: " + " -> ".join(path[path.index(t):] + [t]))
            if t not in state:
                visit(t, path + [t])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
