"""Generated code is committed; regenerating it from protocol/messages.toml must change nothing."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from spectratac.protocol import messages

pytestmark = pytest.mark.subprocess

GENERATED = [
    "firmware/core/generated/stac_messages.h",
    "firmware/core/generated/stac_messages.c",
    "host/spectratac/protocol/messages.py",
    "protocol/MESSAGES.md",
]


def test_generated_code_has_not_drifted(repo: Path, tmp_path: Path) -> None:
    subprocess.run(
        [sys.executable, "tools/codegen/generate.py", "--root", str(tmp_path)],
        cwd=repo,
        check=True,
        capture_output=True,
    )
    for rel in GENERATED:
        fresh = (tmp_path / rel).read_text(encoding="utf-8")
        committed = (repo / rel).read_text(encoding="utf-8")
        assert fresh == committed, f"{rel} is stale: run `make regen` and commit the result"


def test_python_module_matches_definition(repo: Path) -> None:
    raw = tomllib.loads((repo / "protocol/messages.toml").read_text(encoding="utf-8"))
    assert (
        raw["protocol"]["major"],
        raw["protocol"]["minor"],
    ) == (messages.PROTOCOL_MAJOR, messages.PROTOCOL_MINOR)
    assert {m["name"]: m["id"] for m in raw["messages"]} == {
        cls.NAME: cls.TYPE_ID for cls in messages.MESSAGES
    }
    for cls in messages.MESSAGES:
        assert len(cls().pack()) == cls.PAYLOAD_SIZE <= messages.MAX_PAYLOAD


def test_hash_ignores_docs_but_not_wire_changes(repo: Path, tmp_path: Path) -> None:
    sys.path.insert(0, str(repo / "tools" / "codegen"))
    try:
        from definition import load  # type: ignore[import-not-found]
    finally:
        sys.path.pop(0)
    text = (repo / "protocol/messages.toml").read_text(encoding="utf-8")
    assert load(repo / "protocol/messages.toml").hash == messages.DEFINITION_HASH
    doc_edit = tmp_path / "doc.toml"
    doc_edit.write_text(text.replace("Echo of the request", "Copy of the request"), "utf-8")
    assert load(doc_edit).hash == messages.DEFINITION_HASH
    wire_edit = tmp_path / "wire.toml"
    wire_edit.write_text(text.replace("max = 10000", "max = 20000"), "utf-8")
    assert load(wire_edit).hash != messages.DEFINITION_HASH


def test_generated_c_compiles_warning_free(repo: Path, tmp_path: Path) -> None:
    result = subprocess.run(
        [
            "gcc",
            "-std=c11",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-c",
            str(repo / GENERATED[1]),
            "-o",
            str(tmp_path / "m.o"),
        ],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
