"""The package's layout holds: imports point one way down the pipeline, no module imports itself
back through a cycle, and no module grows past the size a reader can hold.

The pipeline (docs/architecture.md): errors -> scene -> kinematics -> model -> dynamics -> design
-> report -> study -> cli.  A module may import its own subpackage and the layers before its
own; never one after it.  Every import is read from the source (module level and inside
functions alike), so a lazy import against the direction fails here too."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "optdesign"
LAYERS = ("errors", "scene", "kinematics", "model", "dynamics", "design", "report", "study", "cli")
MAX_LINES = 500


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        yield ".".join(parts), path


def _imports(name, path):
    """The optdesign modules that module ``name`` imports (absolute dotted names)."""
    tree = ast.parse(path.read_text(), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == "optdesign"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "optdesign":
                continue
            if node.module is None or node.level and not node.module:
                # from . import x: x may be a module
                out |= {f"{target}.{a.name}" for a in node.names}
            else:
                out.add(target)
    return out


def _layer(module):
    parts = module.split(".")
    if len(parts) < 2:
        return None  # the front doors (optdesign/__init__, __main__) sit above the pipeline
    return parts[1] if parts[1] in LAYERS else None


def _existing(module, known):
    """The module itself, or the nearest package that exists (``from .x import name``)."""
    while module not in known and "." in module:
        module = module.rpartition(".")[0]
    return module


MODULES = dict(_modules())


def test_every_subpackage_is_a_layer_of_the_pipeline():
    subpackages = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert subpackages <= set(LAYERS), f"subpackages not in the pipeline: {subpackages - set(LAYERS)}"
    assert len(subpackages) >= 4
    loose = {p.stem for p in PACKAGE.glob("*.py")} - {"__init__", "__main__", "errors"}
    assert not loose, f"modules outside the subpackages: {sorted(loose)}"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_point_down_the_pipeline(module):
    mine = _layer(module)
    if mine is None:
        return
    for target in sorted(_imports(module, MODULES[module])):
        theirs = _layer(_existing(target, MODULES))
        if theirs is None or theirs == mine:
            continue
        assert LAYERS.index(theirs) < LAYERS.index(mine), (
            f"{module} imports {target}: {mine} must not import {theirs} (it comes later in the pipeline)")


def find_cycle(graph) -> list | None:
    """An import cycle of ``graph`` (module -> the modules it imports) as a path, or None."""
    state = {}

    def visit(m, stack):
        state[m] = "open"
        for t in sorted(graph.get(m, ())):
            if state.get(t) == "open":
                return stack[stack.index(t):] + [t]
            if t not in state:
                found = visit(t, stack + [t])
                if found:
                    return found
        state[m] = "done"
        return None

    for m in sorted(graph):
        if m not in state:
            found = visit(m, [m])
            if found:
                return found
    return None


def test_no_import_cycle():
    # the detector itself finds a cycle three modules long, and none in a chain
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    graph = {m: {_existing(t, MODULES) for t in _imports(m, p)} - {m} for m, p in MODULES.items()}
    graph = {m: {t for t in ts if t in MODULES and not m.startswith(t + ".")} for m, ts in graph.items()}
    cycle = find_cycle(graph)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_modules_stay_readable(module):
    lines = MODULES[module].read_text().count("\n")
    assert lines <= MAX_LINES, f"{module} has {lines} lines (at most {MAX_LINES}): split it by job"


def test_the_checks_can_fail(tmp_path):
    """The parser sees relative, absolute and function-level imports (a test that cannot fail
    would prove nothing)."""
    src = tmp_path / "m.py"
    src.write_text("from ..cli.main import main\nimport optdesign.study\n"
                   "def f():\n    from ..design import problem\n    from . import elements\n")
    found = _imports("optdesign.scene.m", src)
    assert found == {"optdesign.cli.main", "optdesign.study", "optdesign.design", "optdesign.scene.elements"}
