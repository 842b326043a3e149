"""Code imports code as packages, never by editing the import path: the tools are a package
run from the repository root (`python -m tools.codegen.generate`), tests import
`tools.<part>.<module>`, and no module changes `sys.path` to reach a sibling."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOTS = ("host", "tools", "tests")


def is_sys_path(node: ast.expr) -> bool:
    return (
        isinstance(node, ast.Attribute)
        and node.attr == "path"
        and isinstance(node.value, ast.Name)
        and node.value.id == "sys"
    )


def path_edits(source: str) -> list[int]:
    """Lines that change sys.path: insert/append/extend calls, assignments to it or a slice
    of it, and augmented assignments."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        call = node.func if isinstance(node, ast.Call) else None
        edits = isinstance(call, ast.Attribute) and call.attr in ("insert", "append", "extend")
        if edits and is_sys_path(call.value):  # type: ignore[union-attr]
            lines.append(node.lineno)
        targets: list[ast.expr] = []
        if isinstance(node, ast.Assign):
            targets = node.targets
        elif isinstance(node, ast.AugAssign | ast.AnnAssign):
            targets = [node.target]
        for t in targets:
            if is_sys_path(t) or (isinstance(t, ast.Subscript) and is_sys_path(t.value)):
                lines.append(node.lineno)
    return lines


@pytest.mark.parametrize(
    "source",
    [
        "import sys\nsys.path.insert(0, 'x')",
        "import sys\nsys.path.append('x')",
        "import sys\nsys.path[:0] = ['x']",
        "import sys\nsys.path += ['x']",
        "import sys\nsys.path = ['x']",
        "import sys\ndef f():\n    sys.path.extend(['x'])",
    ],
)
def test_the_check_finds_each_way_of_editing_the_path(source: str) -> None:
    assert path_edits(source) != []


def test_reading_the_path_is_not_editing_it() -> None:
    assert path_edits("import sys\nprint(sys.path[0], len(sys.path))\nx = [].insert") == []


def test_no_module_edits_sys_path(repo: Path) -> None:
    offenders = [
        f"{path.relative_to(repo)}:{line}"
        for root in ROOTS
        for path in sorted((repo / root).rglob("*.py"))
        for line in path_edits(path.read_text(encoding="utf-8"))
    ]
    assert not offenders, f"import these as packages instead: {offenders}"


def test_every_tools_folder_with_python_is_a_package(repo: Path) -> None:
    """`python -m tools.<part>.<module>` and `from tools.<part> import ...` need them."""
    # PlatformIO's platform builders and tool-scons run inside PlatformIO, not as modules
    skip = {"platforms", "tool-scons"}
    folders = {p.parent for p in (repo / "tools").rglob("*.py")}
    folders = {f for f in folders if not skip & set(f.relative_to(repo / "tools").parts)}
    missing = sorted(str(f.relative_to(repo)) for f in folders if not (f / "__init__.py").exists())
    assert not missing, missing
