"""The package's import graph: no cycle among module-level imports, ``io`` below ``render``,
every module importable on its own in a fresh interpreter, no source file over 600 lines."""
import ast
import os
import subprocess
import sys
from pathlib import Path

import jellysim

PKG = Path(jellysim.__file__).resolve().parent
SRC = PKG.parent
MAX_LINES = 600
OVERSIZE_OWNED_ELSEWHERE: set[str] = set()
"""Files over the limit that another change is splitting (issue 11: the kernel layer)."""


def _modules() -> dict[str, Path]:
    out = {}
    for f in sorted(PKG.rglob("*.py")):
        rel = f.relative_to(SRC).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = f
    return out


def _imports(name: str, path: Path, modules, *, top_level_only: bool) -> set[str]:
    """jellysim modules that ``name`` imports (at module level, or anywhere)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    nodes = tree.body if top_level_only else list(ast.walk(tree))
    if top_level_only:   # module level includes if/try blocks, not function bodies
        stack, nodes = list(tree.body), []
        while stack:
            n = stack.pop()
            nodes.append(n)
            if isinstance(n, (ast.If, ast.Try)):
                stack += n.body + n.orelse + getattr(n, "handlers", []) + getattr(
                    n, "finalbody", [])
            elif isinstance(n, ast.ExceptHandler):
                stack += n.body
    found = set()
    for n in nodes:
        if isinstance(n, ast.Import):
            targets = [a.name for a in n.names]
        elif isinstance(n, ast.ImportFrom):
            if n.level:
                base = package.split(".")
                base = base[:len(base) - (n.level - 1)]
                mod = ".".join(base + ([n.module] if n.module else []))
            else:
                mod = n.module or ""
            targets = [mod] + [f"{mod}.{a.name}" for a in n.names]
        else:
            continue
        for t in targets:
            if t in modules and t != name:
                found.add(t)
    return found


def test_no_import_cycle_among_module_level_imports():
    modules = _modules()
    graph = {m: _imports(m, p, modules, top_level_only=True) for m, p in modules.items()}
    # a package imports its parent packages' __init__ implicitly: those edges are not cycles
    state, cycle = {}, []

    def visit(m, path):
        state[m] = 1
        for d in sorted(graph[m]):
            if m.startswith(d + "."):
                continue   # importing one's own parent package
            if state.get(d) == 1:
                cycle.append(path + [d])
            elif d not in state:
                visit(d, path + [d])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert not cycle, f"import cycles: {cycle}"


def test_io_never_imports_render_or_the_cli():
    modules = _modules()
    for m, p in modules.items():
        if m == "jellysim.io" or m.startswith("jellysim.io."):
            deps = _imports(m, p, modules, top_level_only=False)
            bad = sorted(d for d in deps if d.startswith(("jellysim.render", "jellysim.cli",
                                                          "jellysim.viewer")))
            assert not bad, f"{m} imports {bad}"


FORK_EACH = """
import importlib, os, sys
for lib in ("numpy", "scipy.sparse", "scipy.spatial", "numba", "click", "rich", "meshio"):
    importlib.import_module(lib)          # third-party only: no jellysim module is loaded yet
assert not any(m == "jellysim" or m.startswith("jellysim.") for m in sys.modules)
bad = []
for m in sys.argv[1:]:
    pid = os.fork()
    if pid == 0:                          # a child with no jellysim module imported
        try:
            importlib.import_module(m)
        except BaseException as exc:
            print(f"{m}: {type(exc).__name__}: {exc}", flush=True)
            os._exit(1)
        os._exit(0)
    if os.waitpid(pid, 0)[1]:
        bad.append(m)
print("FAILED", bad)
"""


def test_every_module_imports_alone_in_a_fresh_interpreter():
    """Each module imported first, in a process where no other jellysim module is loaded
    (a fork of one interpreter that holds only the third-party libraries)."""
    modules = [m for m in _modules() if m != "jellysim.__main__"]
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    res = subprocess.run([sys.executable, "-c", FORK_EACH, *modules], capture_output=True,
                         text=True, env=env, timeout=300)
    assert res.returncode == 0, res.stderr
    assert "FAILED []" in res.stdout, res.stdout


def test_no_source_file_over_600_lines():
    long = {}
    for f in PKG.rglob("*.py"):
        rel = f.relative_to(PKG).as_posix()
        n = len(f.read_text(encoding="utf-8").splitlines())
        if n > MAX_LINES and rel not in OVERSIZE_OWNED_ELSEWHERE:
            long[rel] = n
    assert not long, f"files over {MAX_LINES} lines: {long}"


LEAF_MODULES = {"jellysim.params", "jellysim.errors"}
"""Modules that import nothing of ours (params only errors): every module imports them at its top, where the
dependency graph shows, never inside a function."""


def test_leaf_modules_are_imported_at_module_level():
    modules = _modules()
    hidden = []
    for name, path in modules.items():
        if name in LEAF_MODULES:
            continue
        anywhere = _imports(name, path, modules, top_level_only=False)
        top = _imports(name, path, modules, top_level_only=True)
        hidden += [f"{name} -> {m}" for m in sorted((anywhere - top) & LEAF_MODULES)]
    assert not hidden, "import these at the module's top: " + ", ".join(hidden)
    for leaf in LEAF_MODULES:  # (params raises errors' ParameterError: the one edge)
        allowed = {"jellysim.errors"} if leaf == "jellysim.params" else set()
        assert not _imports(leaf, modules[leaf], modules, top_level_only=False) - allowed
