"""`spectratac model info|upload|clear` and `stream --estimates` against the simulated device
(the model store lives in a file, so it outlives each verb's connection, as flash does)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder
from spectratac.decode.export import model_image


@pytest.fixture
def url(tmp_path: Path) -> str:
    return f"sim://?scene=tour&seed=2&speed=max&model_store={tmp_path / 'store.flash'}"


@pytest.fixture
def model_file(tmp_path: Path) -> Path:
    ds = Dataset.generic(
        np.arange(1.0, 37.0).reshape(3, 12) * 100.0,
        np.zeros((3, 1)),
        list(SPECTRATAC_INPUTS),
        ["Fz"],
    )
    return Decoder.untrained(ds, features="paper33").save(tmp_path / "tiny.stac")


def _json(capsys: pytest.CaptureFixture[str]) -> dict:
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])


def test_upload_info_stream_and_clear(
    url: str, model_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["model", "info", url, "--json"]) == ExitCode.OK
    assert _json(capsys)["present"] == "none"
    assert main(["model", "upload", url, str(model_file), "--weights", "f16"]) == ExitCode.OK
    out = capsys.readouterr().out
    expected = model_image.model_id(model_image.encode(Decoder.load(model_file), "f16"))
    assert f"uploaded model 0x{expected:08X}" in out and "f16 weights" in out
    assert main(["model", "info", url, "--json"]) == ExitCode.OK
    info = _json(capsys)
    assert (info["present"], info["model_id"], info["weight_format"]) == (
        "uploaded",
        expected,
        "f16",
    )
    assert main(["stream", url, "--count", "4", "--estimates", "beside", "--format", "jsonl"]) == (
        ExitCode.OK
    )
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["seq"] for r in rows] == [0, 1, 2, 3] and "s0R" in rows[0]
    assert all(math.isfinite(r["Fz"]) and math.isnan(r["Tx"]) for r in rows)
    assert main(["stream", url, "--count", "3", "--estimates", "instead", "--format", "csv"]) == (
        ExitCode.OK
    )
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "seq,t_ms,host_ms,Fx,Fy,Fz,Tx,Ty,Tz,region,est_flags" and len(lines) == 4
    assert main(["model", "clear", url, "--json"]) == ExitCode.OK
    assert _json(capsys)["present"] == "none"


def test_estimates_without_a_model_exit_3_with_the_device_s_reason(
    url: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["stream", url, "--count", "1", "--estimates", "instead"]) == ExitCode.ERROR
    err = capsys.readouterr().err
    assert "NO_MODEL" in err and "Upload a model" in err


def test_a_missing_model_file_exits_3_naming_it(
    url: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    missing = tmp_path / "missing.stac"
    assert main(["model", "upload", url, str(missing)]) == ExitCode.ERROR
    assert "missing.stac" in capsys.readouterr().err


def test_upload_reports_what_int8_weights_cost_on_data(
    url: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(4)
    counts = rng.uniform(500.0, 20_000.0, (200, 12))
    ds = Dataset.generic(counts, counts[:, :1] / 5000.0, list(SPECTRATAC_INPUTS), ["Fz"])
    data = ds.save(tmp_path / "data.npz")
    model = Decoder.untrained(ds, features="paper33", arch=("resmlp", 32, 2)).save(
        tmp_path / "m.stac"
    )
    args = ["model", "upload", url, str(model), "--weights", "i8", "--data", str(data)]
    assert main([*args, "--json"]) == ExitCode.OK
    fz = _json(capsys)["weight_error"]["targets"]["Fz"]
    assert fz["mae"] == pytest.approx(fz["mae_f32"] + fz["extra_mae"])
    assert 0.0 < fz["max_abs_change"] < 1.0  # int8 rounding moves estimates, a little
    assert main(args) == ExitCode.OK
    out = capsys.readouterr().out
    assert "i8 weights against f32 on 200 rows" in out and "Fz" in out
    assert main(["model", "upload", url, str(model), "--weights", "f16"]) == ExitCode.OK
    assert "add --data FILE" in capsys.readouterr().err


def test_model_info_tells_whether_the_device_runs_a_file(
    url: str, model_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two models give two image CRCs on the device, each the one of its file's image, so
    `model info --file` names the file the device runs (and its weight format)."""
    other = Decoder.untrained(
        Dataset.generic(
            np.arange(2.0, 38.0).reshape(3, 12) * 90.0,
            np.zeros((3, 1)),
            list(SPECTRATAC_INPUTS),
            ["Fz"],
        ),
        features="paper33",
    ).save(tmp_path / "other.stac")
    crcs = {}
    for path, weights in ((model_file, "f16"), (other, "f32")):
        assert main(["model", "upload", url, str(path), "--weights", weights]) == ExitCode.OK
        capsys.readouterr()
        assert main(["model", "info", url, "--json"]) == ExitCode.OK
        info = _json(capsys)
        image = model_image.encode(Decoder.load(path), weights)
        assert info["image_crc"] == model_image.image_crc(image)
        crcs[path] = info["image_crc"]
    assert crcs[model_file] != crcs[other]
    # The device now runs `other` in f32: the file is named, `model_file` is not.
    assert main(["model", "info", url, "--file", str(other)]) == ExitCode.OK
    out = capsys.readouterr().out
    assert f"image CRC 0x{crcs[other]:08X}" in out
    assert "this is the device's model (f32 weights)" in out
    assert main(["model", "info", url, "--file", str(model_file), "--json"]) == ExitCode.FAILURE
    info = _json(capsys)
    assert (info["runs_file"], info["file_weights"], info["image_crc"]) == (
        False,
        None,
        crcs[other],
    )
    assert main(["model", "info", url, "--file", str(model_file)]) == ExitCode.FAILURE
    assert "not the device's model" in capsys.readouterr().out


def test_a_sim_url_without_a_store_says_how_to_keep_a_model(
    model_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Each run of spectratac starts `sim://` with an empty store: upload then info (two
    processes) said "no model" with no word why; both now name model_store=PATH, and the
    help of the model verbs documents it."""
    assert main(["model", "info", "sim://?seed=7"]) == ExitCode.OK
    out = capsys.readouterr()
    assert "no model" in out.out and "model_store=PATH" in out.err
    assert main(["model", "upload", "sim://?seed=7", str(model_file)]) == ExitCode.OK
    assert "model_store=PATH" in capsys.readouterr().err
    stored = f"sim://?seed=7&model_store={tmp_path / 'dev.flash'}"
    assert main(["model", "info", stored]) == ExitCode.OK
    assert "model_store" not in capsys.readouterr().err  # a named store needs no note
    with pytest.raises(SystemExit):
        main(["model", "info", "--help"])
    assert "model_store=PATH" in " ".join(capsys.readouterr().out.split())
