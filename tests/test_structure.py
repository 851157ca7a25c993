"""The package's floor plan stays readable: no import cycles, no oversized modules or functions.

Imports are read from the source (``ast``), not by importing, so the test sees every import a
module can execute: module level, inside functions (a lazy import that dodges a cycle is still a
cycle) and inside ``try``; only ``if TYPE_CHECKING:`` blocks are skipped (they never run).
``from pkg import name`` is an edge to ``pkg.name`` when that is a module, else to ``pkg``.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE_DIR = Path(__file__).resolve().parents[1] / "harness"
ROOT = PACKAGE_DIR.parent
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


def top_level_unit(module: str) -> str:
    """``harness.runs.rundir`` -> ``harness.runs``: the package (or top-level module) it is in."""
    return ".".join(module.split(".")[:2])


def package_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """The module graph collapsed onto top-level packages (and top-level modules) of harness:
    an edge A -> B when any module of A imports any module of B (A != B)."""
    packages: dict[str, set[str]] = {}
    for module, imports in graph.items():
        source = top_level_unit(module)
        targets = packages.setdefault(source, set())
        targets.update(top_level_unit(d) for d in imports if top_level_unit(d) != source)
    return packages


def test_package_cycle_finder_sees_a_cycle_through_submodules() -> None:
    """The checker itself: modules without a cycle whose packages form one are caught."""
    graph = {
        "harness.a.x": {"harness.b.y"},
        "harness.b.y": set(),
        "harness.b.z": {"harness.c"},
        "harness.c": {"harness.a.w"},
        "harness.a.w": set(),
        "harness.d": {"harness.a.x"},
    }
    assert import_cycles(graph) == []
    assert package_graph(graph)["harness.a"] == {"harness.b"}
    assert import_cycles(package_graph(graph)) == [["harness.a", "harness.b", "harness.c"]]


def test_no_package_cycles() -> None:
    """Packages depend in one direction: config <- robots <- ..., runs <- report."""
    graph = import_graph()
    cycles = import_cycles(package_graph(graph))
    detail = []
    for cycle in cycles:
        members = set(cycle)
        edges = sorted(
            f"{m} -> {d}"
            for m, imports in graph.items()
            for d in imports
            if top_level_unit(m) in members
            and top_level_unit(d) in members
            and top_level_unit(m) != top_level_unit(d)
        )
        detail.append(" <-> ".join(cycle) + " (" + ", ".join(edges) + ")")
    assert not cycles, "import cycles between harness packages: " + "; ".join(detail)


def test_no_import_cycles() -> None:
    cycles = import_cycles(import_graph())
    assert not cycles, "import cycles between harness modules: " + "; ".join(
        " <-> ".join(cycle) for cycle in cycles
    )


def test_no_test_module_imports_another_test_module() -> None:
    tests = ROOT / "tests"
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


def robot_generators() -> list[Path]:
    """The robots' own URDF generators (``robots/<name>/build.py``, the template's too) and the
    driver: code outside the package, under the same size rules."""
    robots = ROOT / "robots"
    return [*sorted(robots.glob("*/build.py")), robots / "build_urdfs.py"]


@pytest.mark.parametrize(
    "path", robot_generators(), ids=lambda p: p.relative_to(ROOT / "robots").as_posix()
)
def test_robot_generator_sizes(path: Path) -> None:
    assert len(robot_generators()) >= 4
    check_sizes(path)


@pytest.mark.parametrize("name", sorted(package_modules()))
def test_module_and_function_sizes(name: str) -> None:
    check_sizes(package_modules()[name])


def check_sizes(path: Path) -> None:
    """No module over MAX_MODULE_LINES, no function over MAX_FUNCTION_LINES."""
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
    """docs/layout.md (the README's former "Layout") and docs/architecture.md describe the tree
    as it is."""
    root = PACKAGE_DIR.parent
    layout = (root / "docs" / "layout.md").read_text()
    architecture = (root / "docs" / "architecture.md").read_text()
    packages = sorted(p.name for p in PACKAGE_DIR.iterdir() if (p / "__init__.py").is_file())
    for name in packages:
        assert f"{name}/" in layout, f"docs/layout.md does not mention harness/{name}/"
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


DOC_PATH = re.compile(r"(?<![\w/.-])((?:harness|robots|tasks|tests|docs)/[\w./<>-]*)")


def named_paths(text: str) -> list[str]:
    """Repository paths a page names (``harness/...``, ``robots/...``, ...), placeholders
    (``<name>``) left out, trailing punctuation dropped."""
    paths = {match.rstrip(".,;:)") for match in DOC_PATH.findall(text)}
    return sorted(p for p in paths if "<" not in p and ">" not in p)


def test_named_paths_finder() -> None:
    text = (
        "see `harness/pick/verdict.py`, robots/_template/ and tasks/pick/<name>.yaml; x/harness/y"
    )
    assert named_paths(text) == ["harness/pick/verdict.py", "robots/_template/"]


def test_every_path_docs_extending_names_exists() -> None:
    paths = named_paths((ROOT / "docs" / "extending.md").read_text())
    assert len(paths) >= 20, paths
    missing = [p for p in paths if not (ROOT / p).exists()]
    assert not missing, f"docs/extending.md names paths that do not exist: {missing}"


# --------------------------------------------------------------------------------------------
# A fourth robot touches its own folder, its task file(s) and docs/robots.md, nothing else.
#
# The bundled robots are the registry's (``available_robots()``). Code and tests that must grow
# with a new robot are those that spell the robot set out by hand: a collection (list, tuple,
# set, dict keys) naming every bundled robot, a string listing them all (an expected error
# message), a dict literal of robots subscripted by a name (a KeyError for a new robot), an
# if/elif chain over robot names with an else (a new robot takes another robot's branch). None
# of these may appear in harness/ or tests/ outside tests/reference_robots.py (the pinned facts
# of the reference's robots, looked up with ``pinned()``, which skips a robot without any) and
# the few named exemptions below.

FOURTH_ROBOT_EXEMPT: dict[tuple[str, str], str] = {
    ("tests/test_failure_groups.py", "REAL"): "recorded failure rows (data), not a robot list",
}
FOURTH_ROBOT_FREE_MODULES = {"tests/reference_robots.py"}


def _robot_named(node: ast.AST, robots: set[str]) -> str | None:
    """The robot a literal names: ``"fr3"``, ``"lift2_left"`` (a task stem), ``"fr3.yaml"``, or a
    tuple whose first element does (``("fr3", "left")``)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        for robot in robots:
            if node.value in (robot, f"{robot}_left", f"{robot}_right", f"{robot}.yaml"):
                return robot
    if isinstance(node, ast.Tuple) and node.elts:
        return _robot_named(node.elts[0], robots)
    return None


def _docstrings(tree: ast.AST) -> set[int]:
    ids = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        first = body[0] if isinstance(body, list) and body else None
        if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
            ids.add(id(first.value))
    return ids


def _owners(tree: ast.AST) -> dict[int, str]:
    """id(node) -> the name an assignment binds it to (for the named exemptions)."""
    owners: dict[int, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign | ast.AnnAssign) and node.value is not None:
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names = [t.id for t in targets if isinstance(t, ast.Name)]
            for child in ast.walk(node.value):
                owners.setdefault(id(child), names[0] if names else "")
    return owners


def _robot_branches(node: ast.If, robots: set[str]) -> tuple[int, bool]:
    """(branches of an if/elif chain that compare with a robot name, whether it ends in else)."""
    count, current = 0, node
    while True:
        if any(_robot_named(c, robots) for c in ast.walk(current.test)):
            count += 1
        if len(current.orelse) == 1 and isinstance(current.orelse[0], ast.If):
            current = current.orelse[0]
            continue
        return count, bool(current.orelse)


def hand_kept_robot_sets(source: str, robots: set[str]) -> list[tuple[int, str, str]]:
    """(line, owner, what) of every place in ``source`` that spells the robot set out by hand."""
    tree = ast.parse(source)
    docstrings, owners, found = _docstrings(tree), _owners(tree), []
    for node in ast.walk(tree):
        what = ""
        if isinstance(node, ast.List | ast.Tuple | ast.Set | ast.Dict):
            elements = node.keys if isinstance(node, ast.Dict) else node.elts
            named = {_robot_named(e, robots) for e in elements if e is not None}
            if named >= robots:
                what = "a collection naming every bundled robot"
        elif (
            isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and id(node) not in docstrings
            and all(re.search(rf"\b{re.escape(r)}\b", node.value) for r in robots)
        ):
            what = "a string listing every bundled robot"
        elif isinstance(node, ast.Subscript) and isinstance(node.value, ast.Dict):
            if any(_robot_named(k, robots) for k in node.value.keys if k is not None):
                what = "a dict of robots subscripted in place"
        elif isinstance(node, ast.If):
            branches, has_else = _robot_branches(node, robots)
            if branches >= 2 and has_else:
                what = "an if/elif chain over robot names ending in else"
        if what:
            found.append((getattr(node, "lineno", 0), owners.get(id(node), ""), what))
    return sorted(set(found))


def test_hand_kept_robot_set_finder() -> None:
    """The checker itself, on a synthetic module (robots a, b)."""
    source = (
        'ROBOTS = ["a", "b"]\n'
        'ARMS = [("a", "left"), ("b_right", "x")]\n'
        'ONE = ["a"]\n'
        'MESSAGE = "available robots: a, b"\n'
        'x = {"a": 1, "b": 2}[name]\n'
        'if name == "a":\n    y = 1\nelif name == "b":\n    y = 2\nelse:\n    y = 3\n'
        'if name == "a":\n    z = 1\n'
        'def f():\n    "Robots a and b."\n'
    )
    found = hand_kept_robot_sets(source, {"a", "b"})
    assert sorted({(line, owner) for line, owner, _ in found}) == [
        (1, "ROBOTS"),
        (2, "ARMS"),
        (4, "MESSAGE"),
        (5, "x"),
        (6, ""),
    ]


def test_a_fourth_robot_needs_no_edit_in_harness_or_tests() -> None:
    from harness.config.robot_registry import available_robots

    robots = set(available_robots())
    assert len(robots) >= 2
    modules = [*sorted(PACKAGE_DIR.rglob("*.py")), *sorted((ROOT / "tests").glob("*.py"))]
    problems = []
    for path in modules:
        relative = path.relative_to(ROOT).as_posix()
        if relative in FOURTH_ROBOT_FREE_MODULES:
            continue
        for line, owner, what in hand_kept_robot_sets(path.read_text(), robots):
            if (relative, owner) not in FOURTH_ROBOT_EXEMPT:
                problems.append(f"{relative}:{line}: {what}")
    assert not problems, (
        "robot sets spelled out by hand (take them from harness.config.robot_registry / "
        "tests/helpers.py, or pin facts in tests/reference_robots.py): " + "; ".join(problems)
    )
