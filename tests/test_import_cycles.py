"""No import cycles among the harness modules, and no test module importing another.

Static: every ``import`` and ``from ... import`` of each module under ``harness/`` (at its top
level and inside functions: a lazy import that closes a cycle is still one) is parsed with
``ast``; imports under ``if TYPE_CHECKING:`` are type-only and left out. The graph's strongly
connected components must all be single modules.
"""

from __future__ import annotations

import ast
from pathlib import Path

from helpers import PROJECT_ROOT


def _module_names(root: Path) -> dict[str, Path]:
    """Dotted module name -> file, for every module of the package at ``root``."""
    names = {}
    for path in root.rglob("*.py"):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names[".".join(parts)] = path
    return names


def _type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def imported_modules(source: str, name: str, package: bool, known: set[str]) -> set[str]:
    """The modules of ``known`` that module ``name`` imports outside ``if TYPE_CHECKING:``
    (``from a import b`` counts ``a.b`` when that is a module, else ``a``)."""
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _type_checking(child):
                for other in child.orelse:
                    visit_one(other)
                continue
            visit_one(child)

    def visit_one(child: ast.AST) -> None:
        if isinstance(child, ast.Import):
            found.update(alias.name for alias in child.names)
        elif isinstance(child, ast.ImportFrom):
            base = child.module or ""
            if child.level:
                parts = name.split(".") if package else name.split(".")[:-1]
                parts = parts[: len(parts) - (child.level - 1)]
                base = ".".join(parts + ([base] if base else []))
            for alias in child.names:
                sub = f"{base}.{alias.name}"
                found.add(sub if sub in known else base)
        else:
            visit(child)

    visit(ast.parse(source))
    return {module for module in found if module in known and module != name}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, edges = work[-1]
            step = next(edges, None)
            if step is not None:
                if step not in index:
                    index[step] = low[step] = counter
                    counter += 1
                    stack.append(step)
                    on_stack.add(step)
                    work.append((step, iter(sorted(graph[step]))))
                elif step in on_stack:
                    low[node] = min(low[node], index[step])
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


def import_graph(root: Path) -> dict[str, set[str]]:
    modules = _module_names(root)
    known = set(modules)
    return {
        name: imported_modules(path.read_text(), name, path.name == "__init__.py", known)
        for name, path in modules.items()
    }


def test_no_import_cycles_among_harness_modules() -> None:
    graph = import_graph(PROJECT_ROOT / "harness")
    assert len(graph) > 100  # the whole package was read
    assert graph["harness.engines.mjwarp.batch"] >= {"harness.engines.mjwarp.motion"}
    assert cycles(graph) == []


def test_the_check_finds_a_cycle_and_ignores_type_only_imports() -> None:
    known = {"pkg.a", "pkg.b", "pkg.c"}
    a = "from pkg import b\n"
    b = "def f():\n    from . import c\n"
    c = "from pkg.a import thing\n"
    graph = {
        "pkg.a": imported_modules(a, "pkg.a", False, known),
        "pkg.b": imported_modules(b, "pkg.b", False, known),
        "pkg.c": imported_modules(c, "pkg.c", False, known),
    }
    assert graph == {"pkg.a": {"pkg.b"}, "pkg.b": {"pkg.c"}, "pkg.c": {"pkg.a"}}
    assert cycles(graph) == [["pkg.a", "pkg.b", "pkg.c"]]
    typed = "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.a import thing\n"
    graph["pkg.c"] = imported_modules(typed, "pkg.c", False, known)
    assert graph["pkg.c"] == set()
    assert cycles(graph) == []


def test_no_test_module_imports_another_test_module() -> None:
    tests = PROJECT_ROOT / "tests"
    own = {path.stem for path in tests.glob("test_*.py")}
    offenders = []
    for path in sorted(tests.glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            offenders += [
                f"{path.name}: {n}"
                for n in names
                if n.split(".")[-1] in own or n.startswith("tests.test_")
            ]
    assert offenders == []
