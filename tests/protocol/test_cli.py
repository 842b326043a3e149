"""`spectratac protocol` decodes captures, with meaningful exit codes and typed errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.protocol import encode_frame
from spectratac.protocol.generated import messages


def test_show_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["protocol", "show", "--json"]) == ExitCode.OK
    shown = json.loads(capsys.readouterr().out)
    assert shown["definition_hash"] == f"0x{messages.DEFINITION_HASH:08X}"
    assert len(shown["messages"]) == len(messages.MESSAGES)


def test_decode_file_counts_damage(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    capture = tmp_path / "capture.bin"
    good = encode_frame(messages.Ack(acked_type=3, acked_seq=1), seq=9)
    capture.write_bytes(good + b"\x12\x34\x00" + good)
    assert main(["protocol", "decode", "-f", str(capture), "--json"]) == ExitCode.FAILURE
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [row["type"] for row in lines[:-1]] == ["ACK", "ACK"]
    assert lines[-1]["stats"]["dropped"] == 1


def test_decode_bad_hex_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["protocol", "decode", "not-hex"]) == ExitCode.ERROR
    assert "is not hex" in capsys.readouterr().err


def test_decode_missing_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["protocol", "decode", "-f", str(tmp_path / "nope.bin")]) == ExitCode.ERROR
    assert "cannot read" in capsys.readouterr().err
