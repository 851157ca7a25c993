"""The package's floor plan stays readable: no import cycles, no oversized modules or functions.

Imports are read from the source (``ast``), not by importing, so the test sees every import a
module can execute: module level, inside functions (a lazy import that dodges a cycle is still a
cycle) and inside ``try``; only ``if TYPE_CHECKING:`` blocks are skipped (they never run).
``from pkg import name`` is an edge to ``pkg.name`` when that is a module, else to ``pkg``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE_DIR = Path(__file__).resolve().parents[1] / "harness"
MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 80


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def package_modules() -> dict[str, Path]:
    return {module_name(path): path for path in sorted(PACKAGE_DIR.rglob("*.py"))}


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _absolute(module: str, node: ast.ImportFrom) -> str:
    """The absolute module an ``ImportFrom`` names (relative imports resolved)."""
    if node.level == 0:
        return node.module or ""
    is_package = PACKAGE_DIR.parent.joinpath(*module.split("."), "__init__.py").exists()
    base = module.split(".")
    base = base if is_package else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, node.module] if node.module else base)


def imported_modules(module: str, path: Path, known: set[str]) -> set[str]:
    """The harness modules ``module`` imports anywhere except under ``if TYPE_CHECKING``."""
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names if alias.name in known)
        elif isinstance(node, ast.ImportFrom):
            source = _absolute(module, node)
            for alias in node.names:
                submodule = f"{source}.{alias.name}"
                if submodule in known:
                    found.add(submodule)
                elif source in known:
                    found.add(source)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(ast.parse(path.read_text(), str(path)))
    found.discard(module)
    return found


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def connect(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for neighbour in sorted(graph.get(node, ())):
            if neighbour not in index:
                connect(neighbour)
                low[node] = min(low[node], low[neighbour])
            elif neighbour in on_stack:
                low[node] = min(low[node], index[neighbour])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            connect(node)
    return cycles


def import_graph() -> dict[str, set[str]]:
    modules = package_modules()
    known = set(modules)
    return {name: imported_modules(name, path, known) for name, path in modules.items()}


def test_cycle_finder_sees_a_lazy_import_cycle(tmp_path: Path) -> None:
    """The checker itself: a cycle closed by a function-level import is found."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert import_cycles(graph) == [["a", "b", "c"]]
    source = tmp_path / "m.py"
    source.write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    import harness.x\n"
        "def f():\n    import harness.y\n"
    )
    assert imported_modules("harness.m", source, {"harness.x", "harness.y"}) == {"harness.y"}


def test_no_import_cycles() -> None:
    cycles = import_cycles(import_graph())
    assert not cycles, "import cycles between harness modules: " + "; ".join(
        " <-> ".join(cycle) for cycle in cycles
    )


@pytest.mark.parametrize("name", sorted(package_modules()))
def test_module_and_function_sizes(name: str) -> None:
    path = package_modules()[name]
    text = path.read_text()
    lines = len(text.splitlines())
    assert lines <= MAX_MODULE_LINES, f"{path}: {lines} lines (limit {MAX_MODULE_LINES})"
    long_functions = [
        f"{node.name} (line {node.lineno}, {node.end_lineno - node.lineno + 1} lines)"
        for node in ast.walk(ast.parse(text))
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.end_lineno is not None
        and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES
    ]
    assert not long_functions, (
        f"{path}: functions over {MAX_FUNCTION_LINES} lines: {long_functions}"
    )


def test_layout_docs_name_every_package() -> None:
    """README "Layout" and docs/architecture.md describe the tree as it is."""
    root = PACKAGE_DIR.parent
    readme = (root / "README.md").read_text()
    layout = readme[readme.index("## Layout") :]
    architecture = (root / "docs" / "architecture.md").read_text()
    packages = sorted(p.name for p in PACKAGE_DIR.iterdir() if (p / "__init__.py").is_file())
    for name in packages:
        assert f"{name}/" in layout, f"README Layout does not mention harness/{name}/"
        assert f"`{name}/`" in architecture, f"docs/architecture.md does not list {name}/"
    for path in PACKAGE_DIR.glob("*.py"):
        if path.stem not in ("__init__",):
            assert path.stem in architecture, f"docs/architecture.md does not mention {path.name}"


def misplaced_modules(package_dir: Path) -> list[str]:
    """Top-level modules of ``package_dir`` that belong to one of its packages: a module whose
    name is a package's name or starts with it followed by ``_`` (``episode_ids.py`` beside
    ``episode/``). Such a module is one concept split across two places; it moves in."""
    packages = {p.name for p in package_dir.iterdir() if (p / "__init__.py").is_file()}
    found = []
    for path in sorted(package_dir.glob("*.py")):
        stem = path.stem
        owner = next((p for p in packages if stem == p or stem.startswith(f"{p}_")), None)
        if owner is not None:
            found.append(f"{path.name} (belongs in {owner}/)")
    return found


def test_misplaced_module_finder(tmp_path: Path) -> None:
    """The checker itself: a flat ``episode_ids.py`` beside ``episode/`` is found, unrelated
    modules and the package's own ``__init__`` are not."""
    (tmp_path / "episode").mkdir()
    (tmp_path / "episode" / "__init__.py").write_text("")
    for name in ("__init__.py", "episode_ids.py", "episodes.py", "row.py"):
        (tmp_path / name).write_text("")
    assert misplaced_modules(tmp_path) == ["episode_ids.py (belongs in episode/)"]


def test_no_top_level_module_belongs_to_a_package() -> None:
    misplaced = misplaced_modules(PACKAGE_DIR)
    assert not misplaced, "top-level harness modules that belong to a package: " + ", ".join(
        misplaced
    )
