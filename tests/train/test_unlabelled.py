"""Adapting a decoder to a new unit without a reference F/T (`train.unlabelled`, `spectratac
train g.npz --finetune base.stac` on a guided session's dataset): what region labels teach
changes, the force layers stay the base's, and data it cannot use is refused."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.dataset.build import build_datasets
from spectratac.decode import Decoder, DecoderDataError
from spectratac.record import GuidedProtocol, RecordOptions, record_url
from spectratac.train import TrainSpec, train
from spectratac.train.unlabelled import adapt_without_targets

pytestmark = pytest.mark.train


@pytest.fixture(scope="module")
def base(twin_ds: Dataset) -> Decoder:
    """Unit 3's small decoder with a drift baseline, trained under a gain as `best` is."""
    spec = TrainSpec.paper(targets=("Fx", "Fy", "Fz", "region"), epochs=8, hidden=32,
                           blocks=1, context=2, drift="baseline", gain_jitter=0.15,
                           augment="rotate+mirror", threads=1)  # fmt: skip
    return train(twin_ds, spec, progress=False)


@pytest.fixture(scope="module")
def guided(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A guided session of unit 5 without a reference F/T, built into a dataset."""
    folder = tmp_path_factory.mktemp("unit5")
    leds = [[[250, 250, 250]] * 3]  # the twin session's LED duty, which the base was trained at
    record_url("sim://?scene=guided&seed=5&speed=max", folder / "g.mcap",
               RecordOptions(leds=leds), guided=GuidedProtocol(9, out=io.StringIO()))  # fmt: skip
    [ds] = build_datasets([folder / "g.mcap"])
    return ds.save(folder / "g.npz")


def test_the_region_head_guard_and_rest_adapt_and_the_forces_stay(
    base: Decoder, guided: Path
) -> None:
    ds = Dataset.load(guided)
    dec, report = adapt_without_targets(base, ds, progress=False, epochs=20)
    sl = base.heads.slices()
    w0, w1 = base.runtime.weights, dec.runtime.weights
    for name in w0:
        if not name.startswith("head."):  # the hidden layers: the base's
            np.testing.assert_array_equal(np.asarray(w0[name]), np.asarray(w1[name]))
    np.testing.assert_array_equal(  # the force rows of the head: the base's
        np.asarray(w0["head.weight"])[sl["targets"]], np.asarray(w1["head.weight"])[sl["targets"]]
    )
    classes = np.asarray(w1["head.weight"])[sl["classes"]]
    assert not np.allclose(classes, np.asarray(w0["head.weight"])[sl["classes"]])
    assert dec.layout.rest != base.layout.rest and dec.unit_id == ds.meta["unit_id"]
    assert not np.allclose(dec.guard.center, base.guard.center)
    np.testing.assert_array_equal(dec.guard.t_lo, base.guard.t_lo)
    f = report.figures
    assert f["ood_after"] < f["ood_before"] and f["ood_after"] <= 0.05
    assert f["region_after"] > f["region_before"]
    assert abs(f["rest_force_after"][2]) < 1e-6  # "rest": the unit's rest reads zero
    assert any("force and torque scale" in what for what in report.not_adapted)
    assert dec.meta["finetuned_from"]["mode"] == "regions"


def test_kept_forces_leave_every_force_weight_alone(base: Decoder, guided: Path) -> None:
    dec, report = adapt_without_targets(base, Dataset.load(guided), forces="kept", epochs=2,
                                        progress=False)  # fmt: skip
    sl = base.heads.slices()
    for name in ("head.weight", "head.bias"):
        before = np.asarray(base.runtime.weights[name])[sl["targets"]]
        np.testing.assert_array_equal(before, np.asarray(dec.runtime.weights[name])[sl["targets"]])
    assert any("offset at rest" in what for what in report.not_adapted)


def test_data_it_cannot_use_is_refused(base: Decoder, guided: Path, twin_ds: Dataset) -> None:
    with pytest.raises(DecoderDataError, match="force targets"):
        adapt_without_targets(base, twin_ds, progress=False)
    ds = Dataset.load(guided)
    ds.arrays["region"][:] = -1
    with pytest.raises(DecoderDataError, match="--guided 9"):
        adapt_without_targets(base, ds, progress=False)


def test_the_cli_says_what_it_could_not_adapt(
    base: Decoder, guided: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base.save(tmp_path / "base.stac")
    args = ["train", str(guided), "--finetune", str(tmp_path / "base.stac"), "-o",
            str(tmp_path / "unit.stac"), "--epochs", "2", "--no-progress"]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "could not adapt" in out and "force and torque scale" in out
    assert main([*args, "--force", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["targets"] == "none" and summary["forces"] == "rest"
    assert Decoder.load(tmp_path / "unit.stac").meta["targets_from"] == "base"


def test_gain_only_without_force_targets_is_a_usage_error(
    base: Decoder, guided: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--gain-only fits the force gain to F/T targets: a guided session without them is
    refused naming why (it went down the label-only path and ignored the option)."""
    base.save(tmp_path / "base.stac")
    args = ["train", str(guided), "--finetune", str(tmp_path / "base.stac"), "--gain-only",
            "-o", str(tmp_path / "unit.stac"), "--no-progress"]  # fmt: skip
    assert main(args) == 2
    assert "has none (a guided session without --ft)" in capsys.readouterr().err
    assert not (tmp_path / "unit.stac").exists()
