"""The sensor's unit is compared with the model's on open (issue 22 item 2): a match is silent,
another unit is one warning line that points to `train --finetune`, `--strict-unit` refuses
with exit code 3, and a model without a unit id has nothing to compare."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from spectratac.cli import main
from spectratac.decode import Decoder
from spectratac.decode.errors import DecoderUnitError
from spectratac.device import Sensor
from spectratac.train import TrainSpec, train

pytestmark = pytest.mark.train


def url(seed: int) -> str:
    return f"sim://?scene=idle&seed={seed}&speed=max"


@pytest.fixture(scope="module")
def model(twin_ds, tmp_path_factory) -> Path:
    """Trained on twin unit 3 (twin_ds): the model carries unit id 'twin-3'."""
    spec = TrainSpec.paper(epochs=2, hidden=16, blocks=1, threads=1, context=2, drift="baseline")
    return train(twin_ds, spec, progress=False).save(tmp_path_factory.mktemp("m") / "m.stac")


def warnings_in(err: str) -> list[str]:
    return [line for line in err.splitlines() if "warning" in line]


def test_the_same_unit_decodes_without_a_word(model, capsys) -> None:
    assert Decoder.load(model).unit_id == "twin-3"
    assert main(["decode", str(model), url(3), "--count", "3", "--format", "jsonl"]) == 0
    assert warnings_in(capsys.readouterr().err) == []


def test_another_unit_is_one_clear_line_that_points_to_finetune(model, capsys) -> None:
    assert main(["decode", str(model), url(1), "--count", "3", "--format", "jsonl"]) == 0
    out, err = capsys.readouterr()
    lines = warnings_in(err)
    assert len(lines) == 1, err
    line = lines[0]
    assert line.startswith("spectratac: warning: the sensor is unit ")
    assert "twin-1" in line and "'twin-3'" in line and "train" in line and "--finetune" in line
    assert ".py:" not in err and "DecoderUnitWarning" not in err  # not warnings.warn's format
    assert len(out.splitlines()) == 3  # and it decodes


def test_strict_unit_refuses_another_unit_with_exit_code_3(model, capsys) -> None:
    code = main(["decode", str(model), url(1), "--count", "3", "--strict-unit"])
    out, err = capsys.readouterr()
    assert code == 3 and out == ""
    assert err.startswith("spectratac decode: error: the sensor is unit ") and "--finetune" in err
    assert main(["decode", str(model), url(3), "--count", "2", "--strict-unit"]) == 0


def test_strict_unit_in_the_python_api(model) -> None:
    dec = Decoder.load(model)
    dec.unit_policy = "strict"
    with Sensor.open(url(1)) as sensor, pytest.raises(DecoderUnitError, match="twin-1"):
        next(iter(dec.stream(sensor)))


def test_a_model_without_a_unit_id_has_nothing_to_compare(model, tmp_path, capsys) -> None:
    dec = Decoder.load(model)
    dec.meta["unit_id"] = None
    anon = dec.save(tmp_path / "anon.stac")
    assert main(["decode", str(anon), url(1), "--count", "2", "--strict-unit"]) == 0
    assert warnings_in(capsys.readouterr().err) == []


def test_tare_zeroes_on_the_first_sample(model, capsys) -> None:
    """--tare: every estimate stands on a zero; without it, rows say whether rest was seen."""
    args = ["decode", str(model), url(3), "--count", "5", "--format", "jsonl"]
    assert main([*args, "--tare"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["no_rest"] for r in rows] == [False] * 5
