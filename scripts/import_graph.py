#!/usr/bin/env python3
"""Count the imports between the project's packages, from the source alone (``ast``, nothing is imported).

Every ``import``/``from ... import`` of the four packages (``auvlink``, ``logs_format``, ``recon``,
``classify``) is found, wherever it sits: at module top, inside a function (a lazy import), or under
``if TYPE_CHECKING:`` (types only, not run). Reported:

- cross-package imports: source and target in different *units* (the layer units of
  ``docs/ARCHITECTURE.md``: core, sim, logs_format, recon, classify, app), and how many sit inside a function;
- in-function imports of project modules in total, and lazy imports of heavy optional libraries;
- import cycles between modules (strongly connected components of the graph of every import: top-level,
  in-function and under TYPE_CHECKING, as import-linter counts them; ``--runtime`` leaves TYPE_CHECKING out);
- upward imports: a unit importing a unit of a higher layer, or a same-layer import the architecture forbids
  (recon -> logs_format or sim; logs_format or sim -> recon).

Usage: ``python scripts/import_graph.py [--root DIR] [--list] [--json]``; ``--list`` prints each cycle and
upward import.
"""

from __future__ import annotations

import argparse
import ast
import json
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

PACKAGES = ("auvlink", "logs_format", "recon", "classify")
APP = ("auvlink.pipeline", "auvlink.cli", "auvlink.evaluation", "auvlink.__main__")
#: the root package is no part of the core: its public facade (PEP 562 ``__getattr__``) reaches the application
ROOT = "auvlink"
LAYER = {"core": 1, "sim": 2, "logs_format": 2, "recon": 2, "classify": 3, "app": 4}
FORBIDDEN_SAME_LAYER = {("recon", "logs_format"), ("recon", "sim"), ("logs_format", "recon"), ("sim", "recon")}
HEAVY = ("torch", "open3d", "matplotlib", "trimesh", "sklearn", "dask", "distributed")


@dataclass(frozen=True)
class Import:
    src: str  # importing module
    dst: str  # imported project module (the most specific module that exists)
    line: int
    in_function: bool
    type_checking: bool


def unit(module: str) -> str:
    """The layer unit of a module name."""
    if module == ROOT:
        return "app"
    for app in APP:
        if module == app or module.startswith(app + "."):
            return "app"
    if module == "auvlink.sim" or module.startswith("auvlink.sim."):
        return "sim"
    return module.split(".")[0] if module.split(".")[0] != "auvlink" else "core"


def module_files(root: Path) -> dict[str, Path]:
    mods: dict[str, Path] = {}
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            mods[".".join(parts)] = path
    return mods


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _walk(node: ast.AST, in_function: bool, type_checking: bool):  # type: ignore[no-untyped-def]
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.Import | ast.ImportFrom):
            yield child, in_function, type_checking
        fn = in_function or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
        if isinstance(child, ast.If) and _is_type_checking(child.test):
            for stmt in child.body:
                yield from _walk_stmt(stmt, fn, True)
            for stmt in child.orelse:
                yield from _walk_stmt(stmt, fn, type_checking)
            continue
        yield from _walk(child, fn, type_checking)


def _walk_stmt(stmt: ast.stmt, in_function: bool, type_checking: bool):  # type: ignore[no-untyped-def]
    if isinstance(stmt, ast.Import | ast.ImportFrom):
        yield stmt, in_function, type_checking
    yield from _walk(stmt, in_function, type_checking)


def _resolve(name: str, mods: dict[str, Path]) -> str | None:
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def imports_of(module: str, path: Path, mods: dict[str, Path]) -> tuple[list[Import], list[tuple[str, int, str]]]:
    """Project imports of one module, and its in-function imports of heavy libraries."""
    tree = ast.parse(path.read_text(), str(path))
    is_pkg = path.name == "__init__.py"
    out: list[Import] = []
    heavy: list[tuple[str, int, str]] = []
    for node, in_fn, tc in _walk(tree, False, False):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        else:
            base = node.module or ""
            if node.level:
                pkg = module if is_pkg else module.rpartition(".")[0]
                for _ in range(node.level - 1):
                    pkg = pkg.rpartition(".")[0]
                base = f"{pkg}.{base}" if base else pkg
            # "from pkg import mod" names a submodule when one exists
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
        for target in dict.fromkeys(targets):
            top = target.split(".")[0]
            if top in PACKAGES:
                dst = _resolve(target, mods)
                if dst is not None and dst != module:
                    out.append(Import(module, dst, node.lineno, in_fn, tc))
            elif in_fn and top in HEAVY:
                heavy.append((module, node.lineno, target))
    return out, heavy


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm (iterative); components of more than one module, each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    comps: list[list[str]] = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, it = work[-1]
            advanced = False
            for nxt in it:
                if nxt not in index:
                    index[nxt] = low[nxt] = counter
                    counter += 1
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(sorted(graph.get(nxt, ())))))
                    advanced = True
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    comp.append(top)
                    if top == node:
                        break
                if len(comp) > 1:
                    comps.append(sorted(comp))
    return sorted(comps)


def is_upward(imp: Import) -> bool:
    s, d = unit(imp.src), unit(imp.dst)
    return LAYER[d] > LAYER[s] or (s, d) in FORBIDDEN_SAME_LAYER


def analyse(root: Path, runtime: bool = False) -> dict[str, object]:
    mods = module_files(root)
    imports: list[Import] = []
    heavy: list[tuple[str, int, str]] = []
    for mod, path in mods.items():
        found, lazy = imports_of(mod, path, mods)
        imports += found
        heavy += lazy
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for imp in imports:
        if not (runtime and imp.type_checking):
            graph[imp.src].add(imp.dst)
    cycles = strongly_connected(graph)
    cross = [i for i in imports if unit(i.src) != unit(i.dst)]
    upward = [i for i in imports if is_upward(i)]
    return {
        "modules": len(mods),
        "project_imports": len(imports),
        "in_function_imports": sum(i.in_function for i in imports),
        "type_checking_imports": sum(i.type_checking for i in imports),
        "cross_package_imports": len(cross),
        "cross_package_in_function": sum(i.in_function for i in cross),
        "cross_package_by_units": dict(Counter(f"{unit(i.src)}->{unit(i.dst)}" for i in cross).most_common()),
        "cycles": cycles,
        "upward_imports": [f"{i.src}:{i.line} -> {i.dst}" + (" (TYPE_CHECKING)" if i.type_checking else "")
                           for i in upward],
        "lazy_heavy_imports": [f"{m}:{n} {t}" for m, n, t in heavy],
        "in_function_project_imports": [f"{i.src}:{i.line} -> {i.dst}" for i in imports if i.in_function],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent)
    ap.add_argument("--list", action="store_true", help="print every cycle, upward and in-function import")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--runtime", action="store_true", help="cycles of run-time imports only (no TYPE_CHECKING)")
    args = ap.parse_args(argv)
    res = analyse(args.root, args.runtime)
    if args.json:
        print(json.dumps(res, indent=1))
        return 0
    cycles = res["cycles"]
    upward = res["upward_imports"]
    assert isinstance(cycles, list) and isinstance(upward, list)
    print(f"modules                      {res['modules']}")
    print(f"project imports              {res['project_imports']}")
    print(f"  inside functions           {res['in_function_imports']}")
    print(f"  under TYPE_CHECKING        {res['type_checking_imports']}")
    print(f"cross-package imports        {res['cross_package_imports']}")
    print(f"  inside functions           {res['cross_package_in_function']}")
    print(f"import cycles (modules)      {len(cycles)} ({sum(len(c) for c in cycles)})")
    print(f"upward imports               {len(upward)}")
    print(f"lazy heavy-library imports   {len(res['lazy_heavy_imports'])}")  # type: ignore[arg-type]
    if args.list:
        for c in cycles:
            print("cycle:", " <-> ".join(c))
        for u in upward:
            print("upward:", u)
        for line in res["in_function_project_imports"]:  # type: ignore[attr-defined]
            print("in-function:", line)
        for line in res["lazy_heavy_imports"]:  # type: ignore[attr-defined]
            print("lazy heavy:", line)
    return 1 if cycles or upward else 0


if __name__ == "__main__":
    sys.exit(main())
