"""The code base keeps the shape a newcomer can read: no import cycle among the companion's
packages, small modules, no untyped service dictionary."""

from __future__ import annotations

import ast
from pathlib import Path

from .conftest import REPO_ROOT

COMPANION = REPO_ROOT / "companion"
MAX_LINES = 400
LONGER_ALLOWED = {"companion/models/identify.py"}
"""The identification maths stays in one file (it reads like the chapter's section 3)."""


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO_ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _unit(module: str) -> str:
    """The package (``companion.modes``) or top-level module (``companion.vehicle``) of ``module``."""
    return ".".join(module.split(".")[:2])


def _imports(path: Path) -> list[str]:
    """Every companion module ``path`` imports (module level, in functions, under TYPE_CHECKING)."""
    module = _module_name(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: list[str] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                found.append(".".join([*base, node.module] if node.module else base))
            elif node.module:
                found.append(node.module)
    return [name for name in found if name == "companion" or name.startswith("companion.")]


def import_graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for path in COMPANION.rglob("*.py"):
        src = _unit(_module_name(path))
        for target in _imports(path):
            dst = _unit(target)
            if dst != src and dst != "companion":
                graph.setdefault(src, set()).add(dst)
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` as a path (first node repeated at the end), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt):], nxt]
            if nxt not in state and (cycle := visit(nxt)) is not None:
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state and (cycle := visit(start)) is not None:
            return cycle
    return None


def test_no_import_cycle_among_companion_packages() -> None:
    graph = import_graph()
    assert "companion.modes" in graph and "companion.payloads" in graph  # the graph was read
    assert find_cycle(graph) is None, " -> ".join(find_cycle(graph) or [])


def test_the_cycle_finder_finds_cycles() -> None:
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}}) is None


def test_the_layers_point_one_way() -> None:
    """What the redesign separated: modes never import the vehicle, MAVLink or payloads; the
    payloads and the vehicle depend on modes (mission actions, the mode host), not back."""
    graph = import_graph()
    assert not graph["companion.modes"] & {"companion.vehicle", "companion.mavlink", "companion.payloads",
                                            "companion.runtime"}
    assert not graph.get("companion.pipeline", set()) & {"companion.modes", "companion.payloads",
                                                          "companion.vehicle"}
    wiring_users = {src for src, dsts in graph.items() if "companion.runtime" in dsts}
    assert wiring_users == {"companion.commands"}  # only the subcommands build a companion


def test_modules_stay_small() -> None:
    too_long = {}
    for path in COMPANION.rglob("*.py"):
        rel = path.relative_to(REPO_ROOT).as_posix()
        lines = len(path.read_text(encoding="utf-8").splitlines())
        if lines > MAX_LINES and rel not in LONGER_ALLOWED:
            too_long[rel] = lines
    assert not too_long, f"modules over {MAX_LINES} lines: {too_long}"


def test_no_untyped_service_dictionary() -> None:
    """Parts get their collaborators through constructors: no ``extras`` on the context."""
    from dataclasses import fields

    from companion.app import Context

    assert [f.name for f in fields(Context)] == ["config", "clock", "bus", "params"]
    offenders = [p.relative_to(REPO_ROOT).as_posix() for p in COMPANION.rglob("*.py")
                 if ".extras" in p.read_text(encoding="utf-8")]
    assert not offenders
