"""The layer rules of the package, by folder, checked on the source (AST): see ``docs/architecture.md``.

* the core (the modules at the top of ``src/lgvi/``, ``systems/`` and ``_kernels/``) never imports
  ``lgvi.io``, ``lgvi.cli``, ``lgvi.plot`` or ``lgvi.verification``;
* kernels (``_kernels/``) import only ``lgvi._jit`` and other kernels;
* ``io/`` never imports ``cli/`` or ``plot/``; ``verification/`` never imports ``io/``, ``cli/`` or
  ``plot/``; ``plot/`` never imports ``cli/``;
* inside the core, nothing below imports anything above (the top-level modules are ranked below);
* the import graph of the top-level modules and folders has no cycle.

An import inside a function counts too (it runs when the function does), and an old name of a moved
module (``from . import exact``, ``from .streaming import ...``: :data:`lgvi._aliases.MOVED`) counts
as the module it names.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

import lgvi
from lgvi._aliases import MOVED

SRC = Path(lgvi.__file__).parent

#: The folders of the package (subpackages) above the core, and the kernels; the top-level modules
#: and every other folder (``systems/``, a folder of models) are the core.
AREAS = {"_kernels": "kernels", "io": "io", "verification": "verification", "plot": "plot", "cli": "cli",
         "view": "plot"}  # lgvi.view (the interactive page) is a plot module at the top level for now
#: The package's front door: re-exports, ``python -m lgvi``, the old names of moved modules.
FRONT = {"__init__", "__main__", "_aliases"}
#: Areas that an area never imports.
FORBIDDEN: dict[str, set[str]] = {
    "kernels": {"core", "io", "verification", "plot", "cli", "front"},   # only _jit and kernels
    "core": {"io", "verification", "plot", "cli", "front"},
    "io": {"plot", "cli", "front"},
    "verification": {"io", "plot", "cli", "front"},
    "plot": {"cli", "front"},
}

#: Rank of each top-level module of the core, lowest first: inside the core a module imports its
#: own rank or lower ones (``systems/`` is rank 3, the kernels and ``_jit`` rank 0).
CORE_RANKS: dict[str, int] = {
    "_jit": 0,
    # 1: foundations (``_files`` and ``_untrusted`` stay here: ``trajectory`` and ``ensemble`` save,
    # load and check result files with them)
    "_version": 1, "errors": 1, "_validation": 1, "_untrusted": 1, "_files": 1, "so3": 1, "body": 1,
    # 2: models, registries, invariants, implicit solver, results
    "registry": 2, "torques": 2, "invariants": 2, "implicit": 2, "accuracy": 2, "trajectory": 2,
    "discrete": 2, "control": 2,
    "environment": 2, "components": 2, "spacecraft": 2, "fsw": 2,
    # 3: systems and the driver
    "driver": 3, "systems": 3, "modified": 3, "optimal": 3, "splitting": 3,
    "system_ensembles": 3, "gpu": 3,
}

# Imports inside the core that run back up, each with its reason; the test fails when one
# disappears (so that the list stays true) or when a new one appears. None today: the accuracy
# estimate's shadow run calls lgvi.simulate as lgvi.integrator provides it (accuracy.provide_simulate).
ALLOWED_UPWARD: set[tuple[str, str]] = set()


def _modules(src: Path = SRC) -> dict[str, Path]:
    """Dotted name below ``lgvi`` (``io.streaming``; ``cli`` for ``cli/__init__.py``) -> file."""
    out = {}
    for path in src.rglob("*.py"):
        parts = path.relative_to(src).with_suffix("").parts
        if len(parts) > 1 and parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _real(name: str) -> str:
    """An old name of a moved module (``exact``, ``streaming.x``) -> its real one."""
    top, _, rest = name.partition(".")
    new = MOVED.get(f"lgvi.{top}")
    return (new[5:] + ("." + rest if rest else "")) if new else name


def _imports(mod: str, path: Path) -> set[str]:
    """Dotted names (below ``lgvi``, old names made real) that module ``mod`` imports, anywhere."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = mod.split(".") if path.name == "__init__.py" else mod.split(".")[:-1]
    if mod == "__init__":
        package = []
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name == "lgvi" or a.name.startswith("lgvi."):
                    found.add(a.name[5:] or "__init__")
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                if node.module and (node.module == "lgvi" or node.module.startswith("lgvi.")):
                    parts = node.module.split(".")[1:]
                else:
                    continue
            else:
                parts = package[:len(package) - (node.level - 1)] + (node.module.split(".") if node.module else [])
            # ``from lgvi.io import streaming`` imports lgvi.io.streaming (or a name of lgvi.io)
            found.update(".".join(parts + [a.name]) if parts else a.name for a in node.names)
            if parts:
                found.add(".".join(parts))
    return {_real(f) for f in found}


def _area(mod: str) -> str:
    if mod in FRONT:
        return "front"
    if mod == "_jit":
        return "kernels"
    return AREAS.get(mod.split(".")[0], "core")


def _rank(mod: str) -> int:
    top = mod.split(".")[0]
    return 0 if top == "_kernels" else CORE_RANKS[top]


def _edges(src: Path = SRC) -> list[tuple[str, str]]:
    """(importer, imported) for every import of one lgvi module by another (by module, not by name:
    ``io.streaming.read_stream`` is cut to the longest prefix that is a module)."""
    mods = _modules(src)
    edges = set()
    for mod, path in mods.items():
        for target in _imports(mod, path):
            parts = target.split(".")
            while len(parts) > 1 and ".".join(parts) not in mods:
                parts.pop()
            target = ".".join(parts)
            if target != mod and target in mods:
                edges.add((mod, target))
    return sorted(edges)


def _violations(src: Path = SRC) -> list[str]:
    """Every import that breaks a folder rule, as ``'importer (area) -> imported (area)'``."""
    return [f"{m} ({_area(m)}) -> {t} ({_area(t)})" for m, t in _edges(src)
            if _area(t) in FORBIDDEN.get(_area(m), set())]


def _upward(src: Path = SRC) -> set[tuple[str, str]]:
    """Imports inside the core (top-level modules and ``systems``) of a higher-ranked module."""
    return {(m.split(".")[0], t.split(".")[0]) for m, t in _edges(src)
            if _area(m) == "core" and _area(t) in ("core", "kernels") and _rank(t) > _rank(m)}


def _cycles(src: Path = SRC) -> list[list[str]]:
    """The import cycles between top-level modules and folders (``systems.gyrostat`` counts as
    ``systems``; an import inside a function counts too): each strongly connected group of two or
    more, sorted (Tarjan's algorithm)."""
    graph: dict[str, set[str]] = {}
    for m, t in _edges(src):
        a, b = m.split(".")[0], t.split(".")[0]
        graph.setdefault(a, set())
        graph.setdefault(b, set())
        if a != b:
            graph[a].add(b)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    groups: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(groups)


def test_no_import_cycle_between_top_level_modules():
    """A module that needs one above it is handed it through a registration (``lgvi.systems.provide_run``,
    ``lgvi.accuracy.provide_simulate``, ``lgvi.invariants.declares_invariants``), never imports it back."""
    cycles = _cycles()
    assert not cycles, "import cycles between top-level modules (an import inside a function counts):\n" + \
        "\n".join(" <-> ".join(c) for c in cycles)


def test_the_cycle_check_sees_one(tmp_path):
    src = tmp_path / "lgvi"
    (src / "systems").mkdir(parents=True)
    (src / "torques.py").write_text("def f():\n    from .invariants import combine\n")
    (src / "invariants.py").write_text("from .registry import kind\n")
    (src / "registry.py").write_text("def g():\n    from . import torques\n")
    (src / "so3.py").write_text("from .torques import f\n")                        # into a cycle, not on one
    (src / "modified.py").write_text("from .systems.gyrostat import x\n")
    (src / "systems" / "__init__.py").write_text("from . import gyrostat\n")      # inside a folder: not a cycle
    (src / "systems" / "gyrostat.py").write_text("from . import System\ndef h():\n    from ..modified import y\n")
    assert _cycles(src) == [["invariants", "registry", "torques"], ["modified", "systems"]]


def test_every_core_module_and_folder_has_a_rank():
    mods = _modules()
    missing = sorted({m.split(".")[0] for m in mods if _area(m) in ("core", "kernels")} - set(CORE_RANKS) - {"_kernels"})
    assert not missing, f"core modules without a rank in tests/test_layers.py: {missing}"


def test_the_folders_of_the_layout_exist():
    assert {m for m in _modules() if "." not in m} >= {"io", "cli", "plot", "verification", "systems", "_kernels"}
    assert {"io.streaming", "io.outputs", "io.scenario", "verification.reference", "verification.exact",
            "verification.baselines"} <= set(_modules())


def test_kernels_import_only_jit_and_kernels():
    bad = [(m, t) for m, t in _edges() if _area(m) == "kernels" and _area(t) != "kernels"]
    assert not bad, f"kernels may import only lgvi._jit and other kernels: {bad}"


def test_no_folder_imports_a_folder_it_must_not():
    """The core never imports io, cli, plot or verification; io never cli or plot; and so on."""
    bad = _violations()
    assert not bad, "imports breaking the layer rules (see tests/test_layers.py):\n" + "\n".join(bad)


def test_nothing_in_the_core_imports_anything_above():
    up = _upward()
    assert up - ALLOWED_UPWARD == set(), f"imports running back up the layers: {sorted(up - ALLOWED_UPWARD)}"
    assert ALLOWED_UPWARD - up == set(), f"listed as allowed but gone (remove from the list): {ALLOWED_UPWARD - up}"


VIOLATIONS = {
    # file (relative to a fake src/lgvi) -> its source, each breaking one rule
    "modified.py": "from .io.streaming import StreamSink\n",
    "driver.py": "def f():\n    from . import exact\n",            # an old name, inside a function
    "registry.py": "import lgvi.plot\n",
    "systems/rigid_body.py": "from ..verification.baselines import rk4\n",
    "_kernels/solvers.py": "from ..torques import TORQUE_MODELS\n",
    "io/outputs.py": "def g():\n    from ..cli import main\n",
    "verification/exact.py": "from lgvi.io import scenario\n",
    "so3.py": "from .modified import simulate\n",                  # upward inside the core
}


def test_the_checker_sees_a_violation(tmp_path):
    """A fake package with one violation per rule: every one is reported, nothing else is."""
    src = tmp_path / "lgvi"
    for name in ["__init__.py", "_jit.py", "torques.py", "cli/__init__.py", "plot/__init__.py",
                 "io/__init__.py", "io/streaming.py", "io/scenario.py", "verification/__init__.py",
                 "verification/baselines.py", "systems/__init__.py", "_kernels/__init__.py",
                 "_kernels/codes.py", *VIOLATIONS]:
        (src / name).parent.mkdir(parents=True, exist_ok=True)
        (src / name).write_text(VIOLATIONS.get(name, ""))
    (src / "_kernels" / "codes.py").write_text("from .._jit import njit\n")           # allowed
    (src / "io" / "scenario.py").write_text("from ..modified import simulate\nfrom .streaming import x\n")  # allowed
    bad = _violations(src)
    assert {b.split(" ")[0] for b in bad} == {"modified", "driver", "registry", "systems.rigid_body",
                                              "_kernels.solvers", "io.outputs", "verification.exact"}, bad
    assert _upward(src) == {("so3", "modified")}


def test_the_old_names_are_the_moved_modules():
    """``lgvi.streaming`` is ``lgvi.io.streaming`` (one module object), and so on for every old name."""
    import importlib

    for old, new in MOVED.items():
        assert importlib.import_module(old) is importlib.import_module(new) is sys.modules[old], old
        module = sys.modules[new]
        assert module.__name__ == new and module.__spec__.name == new, (old, module.__spec__)
    import lgvi.baselines
    import lgvi.verification.baselines
    from lgvi import exact

    assert exact is lgvi.verification.exact and lgvi.baselines is lgvi.verification.baselines
    assert lgvi.streaming is lgvi.io.streaming
    # the rigid body's run and ensemble moved behind the system seam (issue 25): the old names, the
    # attributes of the package and the public names of DESIGN.md are the same objects
    import lgvi.ensemble
    import lgvi.integrator
    import lgvi.systems.rigid_body_ensemble
    import lgvi.systems.rigid_body_run
    from lgvi.ensemble import simulate_ensemble
    from lgvi.integrator import Run, simulate

    assert lgvi.integrator is lgvi.systems.rigid_body_run and lgvi.ensemble is lgvi.systems.rigid_body_ensemble
    assert simulate is lgvi.simulate and simulate_ensemble is lgvi.simulate_ensemble
    assert Run is lgvi.systems.SYSTEMS["rigid_body"].runner(None)


def test_a_patch_through_an_old_name_is_seen_by_the_real_module(monkeypatch):
    import lgvi.exact
    import lgvi.streaming
    import lgvi.verification.exact

    monkeypatch.setattr(lgvi.streaming, "read_stream", "patched")
    monkeypatch.setattr("lgvi.exact.free_body", "patched too")
    monkeypatch.setattr("lgvi.integrator.CHUNK_STEPS", 7)
    assert lgvi.io.streaming.read_stream == "patched"
    assert lgvi.verification.exact.free_body == "patched too"
    assert lgvi.systems.rigid_body_run.CHUNK_STEPS == 7


def _missing_modules(src: Path = SRC) -> list[str]:
    """``from .x import y`` (or ``import lgvi.x``) whose module ``x`` does not exist; e.g. an edit of
    the old ``cli.py`` merged into ``cli/__init__.py`` with ``from .registry import ...``, which now
    means ``lgvi.cli.registry`` and fails only when the function runs."""
    mods = _modules(src)
    bad = []
    for mod, path in mods.items():
        package = mod.split(".") if path.name == "__init__.py" and mod != "__init__" else mod.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.ImportFrom) and node.module and node.level:
                names = [".".join(package[:len(package) - (node.level - 1)] + node.module.split("."))]
            elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("lgvi."):
                names = [node.module[5:]]
            elif isinstance(node, ast.Import):
                names = [a.name[5:] for a in node.names if a.name.startswith("lgvi.")]
            bad += [f"{mod}: {name}" for name in names if name not in mods and f"lgvi.{name}" not in MOVED]
    return bad


def test_every_imported_module_exists():
    bad = _missing_modules()
    assert not bad, f"imports of modules that do not exist (a relative import after a move?): {bad}"


def test_the_missing_module_check_sees_one(tmp_path):
    src = tmp_path / "lgvi"
    (src / "cli").mkdir(parents=True)
    (src / "registry.py").write_text("")
    (src / "cli" / "__init__.py").write_text("def f():\n    from .registry import X\n    from ..registry import Y\n"
                                             "    from ..exact import free_body\n    import lgvi.nowhere\n")
    assert _missing_modules(src) == ["cli: cli.registry", "cli: nowhere"]


def test_no_module_imports_another_modules_private_names():
    """``from .x import _name`` across modules is refused: shared helpers have public names."""
    bad = []
    for mod, path in _modules().items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module is not None:
                bad += [(mod, node.module, a.name) for a in node.names
                        if a.name.startswith("_") and not a.name.startswith("__")]
    assert not bad, f"private names imported from another module: {bad}"
