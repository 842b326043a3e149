"""The sensor's vocabulary has one home: the package reads the F/T axis names, the region
tables and the count names from spectratac.hardware.generated.vocabulary (generated from
hardware/definitions/vocabulary.toml) and restates none of them.

What counts as a restatement, found in the syntax tree of every module outside the generated
one: a tuple, list or set literal naming three or more F/T axes ("Fx", "Fy", "Fz", ...), or
three or more region prompts ("upper left", ...); a dict literal keyed by five or more region
numbers (a mirror map, sector angles, prompts); a count name built by hand (f"s{k}.{c}" or
the string "RGBC"); and range(1, 10) or arange(1, 10) for the regions.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

from spectratac.hardware.generated import vocabulary as vocab

PACKAGE = Path(__file__).resolve().parents[2] / "host" / "spectratac"
GENERATED = PACKAGE / "hardware" / "generated"
AXES = set(vocab.FT_AXES)
PROMPTS = {p for p in vocab.REGION_PROMPTS.values() if " " in p}  # not plain words


def _strings(node: ast.expr) -> list[str]:
    elts = getattr(node, "elts", [])
    return [e.value for e in elts if isinstance(e, ast.Constant) and isinstance(e.value, str)]


def _hand_made_count_name(node: ast.JoinedStr) -> bool:
    """f"s{...}.{...}" (with or without the dot): a count name built from its parts."""
    v = node.values
    return (
        len(v) >= 3
        and isinstance(v[0], ast.Constant)
        and v[0].value == "s"
        and isinstance(v[1], ast.FormattedValue)
    )


def restatements(tree: ast.AST) -> Iterator[tuple[int, str]]:
    for node in ast.walk(tree):
        if isinstance(node, ast.Tuple | ast.List | ast.Set):
            names = _strings(node)
            if len(AXES.intersection(names)) >= 3:
                yield node.lineno, "F/T axis names"
            if len(PROMPTS.intersection(names)) >= 3:
                yield node.lineno, "region prompts"
        elif isinstance(node, ast.Dict):
            keys = {k.value for k in node.keys if isinstance(k, ast.Constant)}
            if len(keys.intersection(vocab.REGIONS)) >= 5 and all(
                isinstance(k, ast.Constant) and type(k.value) is int for k in node.keys
            ):
                yield node.lineno, "a table keyed by region"
        elif isinstance(node, ast.JoinedStr) and _hand_made_count_name(node):
            yield node.lineno, "a count name built by hand"
        elif isinstance(node, ast.Constant) and node.value == "RGBC":
            yield node.lineno, "the channel letters"
        elif isinstance(node, ast.Call):
            name = getattr(node.func, "id", getattr(node.func, "attr", ""))
            args = [a.value for a in node.args if isinstance(a, ast.Constant)]
            if name in ("range", "arange") and args == [1, vocab.N_REGIONS + 1]:
                yield node.lineno, "the region numbers"


def test_no_module_restates_the_vocabulary() -> None:
    found = [
        f"{path.relative_to(PACKAGE)}:{line}: {what}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if GENERATED not in path.parents
        for line, what in restatements(ast.parse(path.read_text(encoding="utf-8")))
    ]
    assert not found, "use spectratac.hardware.generated.vocabulary instead:\n" + "\n".join(found)


def test_the_check_finds_restatements() -> None:
    bad = """
AXES = ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")
WHERE = {1: "upper left", 2: "top", 3: "upper right", 7: "lower left", 9: "lower right"}
NAMES = [f"s{s}.{c}" for s in range(3) for c in "RGBC"]
LABELS = list(range(1, 10))
"""
    assert sorted(what for _, what in restatements(ast.parse(bad))) == [
        "F/T axis names",
        "a count name built by hand",
        "a table keyed by region",
        "the channel letters",
        "the region numbers",
    ]
