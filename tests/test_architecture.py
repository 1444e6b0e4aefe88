"""docs/architecture.md stays true."""

from __future__ import annotations


def test_the_architecture_page_lists_registries_that_exist():
    """docs/architecture.md stays true: every ``lgvi....`` name it lists resolves."""
    import importlib
    import re
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs" / "architecture.md").read_text(encoding="utf-8")
    names = set(re.findall(r"`(lgvi(?:\.\w+)+)`", page))
    assert {"lgvi.registry.SOLVER_METHODS", "lgvi.registry.TORQUE_MODELS", "lgvi.registry.COMPOSITIONS",
            "lgvi.registry.FORCINGS", "lgvi.systems.SYSTEMS"} <= names
    for name in sorted(names):
        parts = name.split(".")
        for i in range(len(parts), 0, -1):
            try:
                obj = importlib.import_module(".".join(parts[:i]))
            except ImportError:
                continue
            for attr in parts[i:]:
                obj = getattr(obj, attr)
            break
        else:  # pragma: no cover
            raise AssertionError(f"{name} does not import")
    # the recipe's files exist
    root = Path(__file__).resolve().parents[1]
    for path in re.findall(r"`(src/lgvi/[\w/]+\.py)`", page):
        assert (root / path).is_file(), path
