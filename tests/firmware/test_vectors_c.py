"""The firmware's C decoder and encoder agree with every golden vector (protocol/vectors).

The C probe decodes each frame; valid ones must carry the written version, type and sequence
number, their payload must hold the written fields (compared as the generated C pack of the
decoded struct against the Python pack of the vector's meaning), and canonical vectors must
re-encode byte for byte. Frames from a later minor version or cut short are not canonical:
there the decoded fields are compared only."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

import pytest
from spectratac.protocol.generated import messages

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]

VECTOR_DIR = Path(__file__).resolve().parents[2] / "protocol" / "vectors"
VECTORS = sorted(VECTOR_DIR.glob("*.json"))


def load(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def decoded(vector_binary: Path) -> dict[str, list[str]]:
    vectors = [load(p) for p in VECTORS]
    stdin = "".join(v["hex"] + "\n" for v in vectors)
    result = subprocess.run(
        [str(vector_binary)], input=stdin, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == len(vectors), result.stdout + result.stderr
    return {v["name"]: line.split() for v, line in zip(vectors, lines, strict=True)}


def test_vectors_exist() -> None:
    assert len(VECTORS) >= 20, "protocol/vectors/*.json missing"


@pytest.mark.parametrize("path", VECTORS, ids=lambda p: p.stem)
def test_c_decodes_vector(path: Path, decoded: dict[str, list[str]]) -> None:
    vector = load(path)
    kind, major, minor, type_id, seq, payload_hex, frame_hex = decoded[vector["name"]]
    if not vector["valid"]:
        assert kind == vector["error"]
        return
    assert kind == "ok"
    meaning = dict(vector["message"])
    seq_w, version = meaning.pop("seq"), tuple(meaning.pop("version"))
    cls = messages.MESSAGES_BY_NAME[meaning["type"]]
    assert (int(major), int(minor)) == version
    assert int(type_id) == cls.TYPE_ID
    assert int(seq) == seq_w
    expected_payload = cls.from_dict(meaning).pack()
    assert bytes.fromhex(payload_hex.replace("-", "")) == expected_payload
    if not (vector.get("future_minor") or vector.get("short")):
        assert frame_hex == vector["hex"], "C re-encoding differs from the golden bytes"
