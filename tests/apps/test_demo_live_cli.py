"""`spectratac demo --live` as a person reads it, and as a script reads its --json."""

from __future__ import annotations

import json

import pytest
from spectratac.cli import main


def test_live_demo_ends_with_sentences_not_a_python_dict(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["demo", "--live", "--speed", "max", "--duration", "2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[-2].startswith("40 of 40 samples in ") and lines[-2].endswith(": complete")
    assert lines[-1].startswith("link: ") and "no CRC errors, no sample gaps" in lines[-1]
    assert not any("{" in line or "_" in line for line in lines[-2:]), lines[-2:]


def test_live_demo_json_is_one_object(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--live", "--speed", "max", "--duration", "2", "--json"]) == 0
    (line,) = capsys.readouterr().out.splitlines()
    summary = json.loads(line)
    assert summary["samples"] == summary["expected"] == 40
    assert summary["stats"]["crc_errors"] == 0
