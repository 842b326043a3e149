"""`spectratac model upload` checks the unit as `decode` does (issue 36): another unit's model
is uploaded with a warning naming both units and `train --finetune`, and `--strict-unit`
refuses it (exit code 3) before anything is written to the device."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder


@pytest.fixture
def url(tmp_path: Path) -> str:
    return f"sim://?seed=1&speed=max&model_store={tmp_path / 'store.flash'}"


def model_of(unit: str, path: Path) -> Path:
    ds = Dataset.generic(np.arange(1.0, 37.0).reshape(3, 12) * 100.0, np.zeros((3, 1)),
                         list(SPECTRATAC_INPUTS), ["Fz"])  # fmt: skip
    dec = Decoder.untrained(ds, features="paper33")
    dec.meta["unit_id"] = unit
    return dec.save(path)


def present(url: str, capsys: pytest.CaptureFixture[str]) -> str:
    assert main(["model", "info", url, "--json"]) == ExitCode.OK
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])["present"]


def test_another_units_model_warns_on_upload(
    url: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = model_of("twin-0", tmp_path / "unit0.stac")
    assert main(["model", "upload", url, str(model), "--json"]) == ExitCode.OK
    err = capsys.readouterr().err
    assert "warning: the sensor is unit" in err and "(twin-1)" in err, err
    assert "calibrated on unit 'twin-0'" in err and "--finetune" in err
    assert present(url, capsys) == "uploaded"


def test_strict_unit_refuses_before_writing_anything(
    url: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = model_of("twin-0", tmp_path / "unit0.stac")
    assert main(["model", "upload", url, str(model), "--strict-unit"]) == ExitCode.ERROR
    err = capsys.readouterr().err
    assert "error: the sensor is unit" in err and "'twin-0'" in err and "Traceback" not in err
    assert present(url, capsys) == "none"
    # the user's own word (--unit) is checked before the device is opened at all
    assert main(["model", "upload", url, str(model), "--unit", "twin-1", "--strict-unit"]) == 3
    assert present(url, capsys) == "none"


def test_the_models_own_unit_uploads_silently(
    url: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = model_of("twin-1", tmp_path / "unit1.stac")
    assert main(["model", "upload", url, str(model), "--strict-unit", "--json"]) == ExitCode.OK
    assert "warning" not in capsys.readouterr().err
    assert present(url, capsys) == "uploaded"
