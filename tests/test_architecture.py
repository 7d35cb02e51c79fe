"""The package's shape: no import cycles, the SFA engine free of the simulator, small modules."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "sfa_gym"
# "about 500 lines": a module may run a tenth over before it must say why it is longer
MAX_LINES = 550


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Modules of the package that ``name`` imports anywhere (also inside functions)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            # ``from pkg import sub`` imports the submodule when there is one
            targets = [
                f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names
            ]
        else:
            continue
        for target in targets:
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return path[path.index(nxt) :] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_cycle_finder_finds_a_cycle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_no_module_imports_a_module_that_imports_it_back():
    modules = _modules()
    graph = {name: _imports(name, path, modules) for name, path in modules.items()}
    assert len(graph) > 30 and any(graph.values())
    # the package root registers the envs and every submodule's import runs it first; it only
    # imports registration, which imports nothing of the package
    cycle = _cycle({k: v - {"sfa_gym"} for k, v in graph.items()})
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_rotation_module_is_numpy_only():
    tree = ast.parse((PACKAGE / "rotation.py").read_text())
    imported = {
        (n.module if isinstance(n, ast.ImportFrom) else a.name).split(".")[0]
        for n in ast.walk(tree)
        if isinstance(n, ast.Import | ast.ImportFrom)
        for a in n.names
    }
    assert imported <= {"__future__", "dataclasses", "typing", "numpy"}, imported


@pytest.mark.parametrize("name", sorted(_modules()))
def test_modules_stay_short_or_say_why(name):
    path = _modules()[name]
    lines = path.read_text().count("\n")
    if lines <= MAX_LINES:
        return
    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    assert "longer than" in doc.lower(), (
        f"{path.relative_to(PACKAGE.parent)} has {lines} lines (> {MAX_LINES}) and its docstring "
        "does not say why it is longer than that"
    )


def _package_imports() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def test_the_leaderboard_scores_through_the_protocols_not_the_command_line():
    from sfa_gym.leaderboard.tracks import PROTOCOLS

    graph = _package_imports()
    leaderboard = [
        m for m in graph if m == "sfa_gym.leaderboard" or m.startswith("sfa_gym.leaderboard.")
    ]
    assert "sfa_gym.leaderboard.evaluate" in leaderboard
    assert all(m.startswith("sfa_gym.protocols.") for m in PROTOCOLS.values())
    for module in leaderboard:
        reached = sorted(i for i in graph[module] if i.split(".")[:2] == ["sfa_gym", "cli"])
        assert not reached, f"{module} imports {reached}: the leaderboard scores through protocols"


def test_the_protocols_import_no_leaderboard_or_command_line():
    graph = _package_imports()
    protocols = [m for m in graph if m.split(".")[:2] == ["sfa_gym", "protocols"]]
    assert {"sfa_gym.protocols.grid", "sfa_gym.protocols.trajectory"} <= set(protocols)
    for module in protocols:
        reached = sorted(
            i
            for i in graph[module]
            if i.split(".")[:2] in (["sfa_gym", "leaderboard"], ["sfa_gym", "cli"])
        )
        assert not reached, f"{module} imports {reached}"


def test_the_package_imports_none_of_the_checkouts_folders():
    """eval/, baselines/, envs/ and tests/ are not installed: the package imports none of them,
    except the docs-tables command, which imports the checkout's eval/tables/ from the root it
    was given."""
    outside = {"eval", "benchmarks", "studies", "baselines", "envs", "tests"}
    found = {}
    for name, path in _modules().items():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            if reached := {n.split(".")[0] for n in names} & outside:
                found.setdefault(name, set()).update(reached)
    assert found == {"sfa_gym.cli.docs": {"eval"}}, found
