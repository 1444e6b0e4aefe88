"""The layer rules of the package, checked on the source (AST): see ``docs/architecture.md``.

* kernels (``lgvi._kernels``) import only ``lgvi._jit`` and other kernels;
* the core (systems, driver, registries, models, the integrator) never imports the input/output
  layer (``streaming``, ``outputs``, ``scenario``), the command line or the plots;
* nothing below imports anything above (the layers are ranked below); an import inside a function
  counts too (it runs when the function does).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import lgvi

SRC = Path(lgvi.__file__).parent

#: Layer of each module (dotted name below ``lgvi``; a package covers its submodules), lowest first.
#: A module may import modules of its own layer or of lower layers only.
LAYERS: dict[str, int] = {
    # 0: the compiled layer and its helpers (no lgvi Python objects)
    "_jit": 0, "_kernels": 0,
    # 1: foundations
    "_version": 1, "errors": 1, "_validation": 1, "_untrusted": 1, "_files": 1, "so3": 1, "body": 1,
    # 2: models, registries, invariants, implicit solver, results
    "registry": 2, "torques": 2, "invariants": 2, "implicit": 2, "accuracy": 2, "trajectory": 2,
    "discrete": 2, "reference": 2, "exact": 2, "control": 2,
    "environment": 2,
    # 3: systems and the driver (the core)
    "driver": 3, "systems": 3, "integrator": 3, "ensemble": 3, "modified": 3,
    # 4: input/output, verification baselines
    "streaming": 4, "outputs": 4, "scenario": 4, "baselines": 4,
    "scenario_space": 4,
    # 5: plots; 6: the command line and the package's front door
    "plot": 5, "cli": 6, "__main__": 6, "__init__": 6,
}
CORE = {"driver", "systems", "integrator", "ensemble", "modified", "registry", "torques", "invariants",
        "implicit", "trajectory", "body", "so3"}
IO_CLI_PLOT = {"streaming", "outputs", "scenario", "cli", "plot", "__main__"}

# Imports that run back up, each with its reason; the test fails when one disappears (so that the
# list stays true) or when a new one appears.
ALLOWED_UPWARD = {
    # the accuracy estimate re-runs lgvi.simulate at h/2 (a shadow run of the same problem)
    ("accuracy", "integrator"),
}


def _modules() -> dict[str, Path]:
    out = {}
    for path in SRC.rglob("*.py"):
        rel = path.relative_to(SRC).with_suffix("")
        out[".".join(rel.parts)] = path
    return out


def _top(mod: str) -> str:
    return mod.split(".")[0]


def _imports(mod: str, path: Path) -> set[str]:
    """Dotted names (below ``lgvi``) that module ``mod`` imports, anywhere in its body."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = mod.split(".")[:-1] if path.name != "__init__.py" else mod.split(".")
    if path.name == "__init__.py" and mod == "__init__":
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
                    base = node.module[5:]
                else:
                    continue
            else:
                parts = package[:len(package) - (node.level - 1)] if node.level > 1 else package
                base = ".".join(parts + ([node.module] if node.module else []))
            if base:
                found.add(base)
            else:  # from . import x
                found.update(a.name for a in node.names)
    return found


def _edges() -> list[tuple[str, str]]:
    mods = _modules()
    edges = []
    for mod, path in mods.items():
        for target in _imports(mod, path):
            if target and _top(target) != _top(mod):
                edges.append((mod, target))
    return edges


def test_every_module_has_a_layer():
    missing = sorted({_top(m) for m in _modules()} - set(LAYERS) - {"__init__"})
    assert not missing, f"modules without a layer in tests/test_layers.py: {missing}"


def test_kernels_import_only_jit_and_kernels():
    bad = [(m, t) for m, t in _edges() if _top(m) == "_kernels" and _top(t) not in ("_jit", "_kernels")]
    assert not bad, f"kernels may import only lgvi._jit and other kernels: {bad}"


def test_core_never_imports_io_cli_or_plot():
    bad = [(m, t) for m, t in _edges() if _top(m) in CORE and _top(t) in IO_CLI_PLOT]
    assert not bad, f"the core imports the io/cli/plot layer: {bad}"


def test_nothing_below_imports_anything_above():
    up = {(_top(m), _top(t)) for m, t in _edges() if _top(t) in LAYERS and LAYERS[_top(t)] > LAYERS[_top(m)]}
    assert up - ALLOWED_UPWARD == set(), f"imports running back up the layers: {sorted(up - ALLOWED_UPWARD)}"
    assert ALLOWED_UPWARD - up == set(), f"listed as allowed but gone (remove from the list): {ALLOWED_UPWARD - up}"


@pytest.mark.parametrize("source, target", [("integrator", "streaming"), ("_kernels.solvers", "torques")])
def test_the_checker_sees_a_violation(tmp_path, source, target):
    """The AST reader finds relative and absolute imports, also inside functions."""
    p = tmp_path / "m.py"
    p.write_text(f"def f():\n    from .{target.split('.')[-1]} import x\n    import lgvi.{target}\n")
    found = _imports(source, p)
    assert target in found or target.split(".")[-1] in {f.split(".")[-1] for f in found}


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
