"""`spectratac demo` as a person reads it: the results table, and `--live`'s last lines
(and its --json, as a script reads it)."""

from __future__ import annotations

import json

import pytest
from spectratac.apps.calibration_demo import results_table
from spectratac.cli import main
from spectratac.hardware.generated import vocabulary as vocab

# the live demo streams the simulated sensor: it trains nothing
LIVE = ["demo", "--live", "--speed", "max", "--duration", "2"]


def test_live_demo_ends_with_sentences_not_a_python_dict(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(LIVE) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[-2].startswith("40 of 40 samples in ") and lines[-2].endswith(": complete")
    assert lines[-1].startswith("link: ") and "no CRC errors, no sample gaps" in lines[-1]
    assert not any("{" in line or "_" in line for line in lines[-2:]), lines[-2:]


def test_live_demo_json_is_one_object(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*LIVE, "--json"]) == 0
    (line,) = capsys.readouterr().out.splitlines()
    summary = json.loads(line)
    assert summary["samples"] == summary["expected"] == 40
    assert summary["stats"]["crc_errors"] == 0


def test_the_results_table_names_the_twin_inverse_truthfully() -> None:
    """The last column sits above the decoders (it knows no press history): it is called the
    twin's inverse and explained under the table, not an "oracle" floor."""

    def section(mae: float, oracle: float | None) -> dict:
        o = None if oracle is None else dict.fromkeys(vocab.FT_AXES, oracle)
        return {"mae": dict.fromkeys(vocab.FT_AXES, mae), "region_accuracy": 0.9, "oracle_mae": o}

    results = {
        "paper": {"random": section(0.2, None), "blocked": section(0.3, 0.5)},
        "best": {"random": section(0.1, None), "blocked": section(0.2, None)},
    }
    lines = results_table(results)
    assert lines[0].split()[-1] == "twin" and lines[1].split()[-1] == "inverse"
    assert not any("oracle" in line for line in lines)
    note = " ".join(lines[len(vocab.FT_AXES) + 3 :])
    assert note.startswith("twin inverse: ") and note.count("floor") == note.count("not a floor")
