"""tools/bench calls the benchmark library, never the command line: one implementation."""

from __future__ import annotations

import ast
from pathlib import Path


def test_tools_bench_does_not_import_the_cli(repo: Path) -> None:
    offenders = []
    for path in sorted((repo / "tools/bench").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else []
            )
            offenders += [f"{path.name}: {n}" for n in names if n.startswith("spectratac.cli")]
    assert not offenders, offenders
    assert (repo / "tools/bench/decoder.py").read_text().count("spectratac.studies.bench") == 1
