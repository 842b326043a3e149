"""tools/bench calls the benchmark library, never the command line: one implementation."""

from __future__ import annotations

import ast
from pathlib import Path


def imported(path: Path) -> list[str]:
    names: list[str] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names.append(node.module or "")
    return names


def test_tools_bench_does_not_import_the_cli(repo: Path) -> None:
    offenders = [
        f"{path.name}: {n}"
        for path in sorted((repo / "tools/bench").glob("*.py"))
        for n in imported(path)
        if n.startswith("spectratac.cli")
    ]
    assert not offenders, offenders
    assert "spectratac.studies.bench" in imported(repo / "tools/bench/decoder.py")
