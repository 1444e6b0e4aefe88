"""SECURITY.md says exactly what is checked: every sentence of its "What a file cannot do"
section names the tests that hold it, and each named test exists (issue 29, part 6)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests"


def _checks() -> list[tuple[str, list[str]]]:
    """``(sentence, ["file.py::test", ...])`` for every bullet of the section."""
    text = (ROOT / "SECURITY.md").read_text()
    section = text[text.index("## What a file cannot do"):text.index("## What lgvi trusts")]
    bullets = re.split(r"\n- ", section)[1:]
    out = []
    for bullet in bullets:
        claim, _, tests = bullet.partition("Tests:")
        out.append((" ".join(claim.split()), re.findall(r"`([\w.]+\.py::\w+)`", tests)))
    return out


def _test_names(file: str) -> set[str]:
    tree = ast.parse((TESTS / file).read_text())
    return {n.name for n in tree.body if isinstance(n, ast.FunctionDef) and n.name.startswith("test_")}


def test_every_sentence_names_existing_tests():
    checks = _checks()
    assert len(checks) >= 15, "the section lost its checks"
    for claim, tests in checks:
        assert tests, f"SECURITY.md states a check that no test holds: {claim!r}"
        for ref in tests:
            file, name = ref.split("::")
            assert (TESTS / file).is_file(), f"{ref}: no file tests/{file} ({claim!r})"
            assert name in _test_names(file), f"{ref}: no test {name} in tests/{file} ({claim!r})"
