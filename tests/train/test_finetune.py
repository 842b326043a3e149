"""Few-shot recalibration (`train.finetune`, `spectratac train --finetune`), real training."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.decode import Decoder, DecoderConfigError, DecoderUnitWarning
from spectratac.train import TrainSpec, train
from spectratac.train.finetune import (
    MIN_VAL_GROUPS,
    FinetuneCheckError,
    FinetuneMismatchError,
    finetune,
    grouped_validation,
    model_id,
    validation_groups,
)

pytestmark = pytest.mark.train

SPEC = TrainSpec.paper(features="generic", targets=("Fz", "Fx"), epochs=20, hidden=32, blocks=1)


def _unit(seed: int, gain: float, offset: float, n: int = 600) -> Dataset:
    """A generic three-channel sensor; units differ in channel gain and offset."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 1.0, (n, 3))
    y = np.stack([2.0 * x[:, 0] - x[:, 1] + x[:, 2] ** 2, x[:, 1] * x[:, 2]], axis=1)
    raw = gain * x + offset
    ds = Dataset.generic(raw, y, ["a", "b", "c"], ["Fz", "Fx"])
    ds.arrays["press"][:] = np.arange(n) // 20  # 30 presses of 20 rows
    ds.meta["unit_id"] = f"unit-{gain}"
    return ds


def _mae(dec: Decoder, ds: Dataset) -> float:
    with warnings.catch_warnings():  # decoders of other units, on purpose
        warnings.simplefilter("ignore", DecoderUnitWarning)
        est = dec.predict(ds)
    return float(np.mean(np.abs(est.targets - ds.targets)))


@pytest.fixture(scope="module")
def base() -> Decoder:
    return train(_unit(0, 1.0, 0.0, 2000), SPEC, progress=False)


@pytest.fixture(scope="module")
def new_unit() -> tuple[Dataset, Dataset]:
    """A few-shot set and a test set of another unit (other gains and offsets)."""
    return _unit(1, 1.4, 0.3, 300), _unit(2, 1.4, 0.3, 600)


def test_finetuning_recalibrates_a_new_unit(base, new_unit) -> None:
    shots, test = new_unit
    before = _mae(base, test)
    full = finetune(base, shots, progress=False)  # mode "first"
    scratch = train(shots, SPEC, progress=False)
    assert _mae(full, test) < 0.5 * before
    assert _mae(full, test) < _mae(scratch, test)
    rec = full.meta["finetuned_from"]
    assert rec["id"] == model_id(base) and rec["unit_id"] == "unit-1.0"
    assert rec["mode"] == "first" and rec["early_stopping"] is True
    assert full.unit_id == "unit-1.4" and "holdout" not in full.meta
    assert len(full.meta["val_history"]) == rec["epochs"]


def test_modes_update_only_their_parameters(base, new_unit) -> None:
    shots, _ = new_unit
    bw = base.runtime.weights
    scaler = finetune(base, shots, mode="scaler", progress=False)
    assert all(np.array_equal(scaler.runtime.weights[k], bw[k]) for k in bw)
    assert not np.allclose(scaler.runtime.scaler.mean, base.runtime.scaler.mean)
    assert scaler.meta["history"] == [] and scaler.meta["finetuned_from"]["epochs"] == 0
    head = finetune(base, shots, mode="head", epochs=3, progress=False)
    changed = {k for k in bw if not np.array_equal(head.runtime.weights[k], bw[k])}
    assert changed == {"head.weight", "head.bias"}
    first = finetune(base, shots, mode="first", epochs=3, progress=False)
    changed = {k for k in bw if not np.array_equal(first.runtime.weights[k], bw[k])}
    assert changed == {"head.weight", "head.bias", "stem.weight", "stem.bias"}
    kept = finetune(base, shots, mode="head", refit_scaler=False, epochs=2, progress=False)
    assert np.array_equal(kept.runtime.scaler.mean, base.runtime.scaler.mean)
    with pytest.raises(DecoderConfigError, match="fine-tuning mode 'all'"):
        finetune(base, shots, mode="all", progress=False)


def test_a_recalibration_that_does_not_help_is_not_kept(base, new_unit) -> None:
    same = _unit(3, 1.0, 0.0, 600)  # the base's own kind of unit: nothing to recalibrate
    wild = finetune(base, same, lr=5.0, epochs=4, progress=False)  # a step size that wrecks it
    rec = wild.meta["finetuned_from"]
    assert rec["kept"] == "base" and rec["refit_scaler"] is False
    scores = rec["val_mae_scaled"]
    assert set(scores) == {"finetuned", "finetuned+refit", "base", "gain"}
    assert scores["base"] < min(scores["finetuned"], scores["finetuned+refit"])
    bw = base.runtime.weights
    assert all(np.array_equal(wild.runtime.weights[k], bw[k]) for k in bw)
    assert _mae(wild, same) <= 1.05 * _mae(base, same)
    shots, _ = new_unit  # a unit that differs: the recalibration earns its place
    dec = finetune(base, shots, progress=False)
    assert dec.meta["finetuned_from"]["kept"].startswith("finetuned")


def test_grouped_validation_holds_out_whole_presses(new_unit) -> None:
    shots, _ = new_unit
    order = np.arange(shots.n)
    fit, val = grouped_validation(shots, order)
    assert val.size and np.intersect1d(shots.press[fit], shots.press[val]).size == 0
    few = shots.subset(np.arange(20 * (MIN_VAL_GROUPS - 1)))
    fit, val, kind = validation_groups(few, np.arange(few.n))
    # too few presses: guarded time blocks are held out instead (the check still runs)
    assert kind == "block" and val.size and fit.size and np.intersect1d(fit, val).size == 0


def test_few_presses_still_check_against_the_base_on_time_blocks(base) -> None:
    """Issue 22: with fewer than MIN_VAL_GROUPS groups the keep-the-base check never ran and
    the message blamed 'too few presses'; now it runs on time blocks."""
    few = _unit(3, 1.4, 0.3, 20 * (MIN_VAL_GROUPS - 1))
    dec = finetune(base, few, epochs=4, progress=False)
    rec = dec.meta["finetuned_from"]
    assert rec["early_stopping"] is True and rec["val_groups"] == "block"
    assert "base" in rec["val_mae_scaled"] and dec.meta["n_val"] > 0


def test_too_little_data_to_check_fails_loudly(base) -> None:
    tiny = _unit(3, 1.4, 0.3, 12)
    with pytest.raises(FinetuneCheckError, match="too few to hold some"):
        finetune(base, tiny, epochs=2, progress=False)


def test_mismatching_data_is_refused(base) -> None:
    other_inputs = Dataset.generic(
        np.ones((50, 3)), np.ones((50, 2)), ["a", "b", "d"], ["Fz", "Fx"]
    )
    with pytest.raises(FinetuneMismatchError, match=r"inputs \['a', 'b', 'd'\]"):
        finetune(base, other_inputs, progress=False)
    no_fx = Dataset.generic(np.ones((50, 3)), np.ones((50, 1)), ["a", "b", "c"], ["Fz"])
    with pytest.raises(FinetuneMismatchError, match=r"targets \['Fx'\] are not in the new data"):
        finetune(base, no_fx, progress=False)
    with pytest.raises(FinetuneMismatchError, match="differ from the base decoder's"):
        finetune(base, _unit(1, 1.0, 0.0, 100), targets=["Fz"], progress=False)


def test_another_led_configuration_is_refused() -> None:
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=1, duration_s=20.0)
    ds50 = from_twin_session(generate_session(scene, seed=1), scene)
    ds100 = from_twin_session(generate_session(scene, seed=2, integration_ms=100), scene)
    spec = TrainSpec.paper(epochs=1, hidden=8, blocks=1, targets=("Fz",))
    base = train(ds50, spec, progress=False)
    with pytest.raises(FinetuneMismatchError, match="sensor configuration"):
        finetune(base, ds100, progress=False)


def _csv(path: Path, ds: Dataset) -> Path:
    lines = ["a,b,c,Fz,Fx,press"]
    for i in range(ds.n):
        row = [*ds.inputs[i], *ds.targets[i], ds.press[i]]
        lines.append(",".join(str(v) for v in row))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_cli_finetune(base, new_unit, tmp_path, capsys) -> None:
    shots, test = new_unit
    base_file = base.save(tmp_path / "base.stac")
    data = _csv(tmp_path / "new.csv", shots)
    out = tmp_path / "ft.stac"
    argv = ["train", str(data), "--inputs", "a,b,c", "--finetune", str(base_file), "-o", str(out)]
    assert main([*argv, "--epochs", "5", "--no-progress", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["finetuned_from"]["path"] == str(base_file)
    dec = Decoder.load(out)
    assert dec.meta["finetuned_from"]["id"] == model_id(Decoder.load(base_file))
    assert dec.meta["finetuned_from"]["epochs"] == 5
    assert main([*argv, "--force", "--targets", "Fz", "--no-progress"]) == 3
    assert "differ from the base decoder's" in capsys.readouterr().err
    test_file = _csv(tmp_path / "test.csv", test)
    rep = tmp_path / "rep"
    ev = ["evaluate", str(out), str(test_file), "-o", str(rep), "--oracle-samples", "0"]
    assert main([*ev, "--json", "--no-progress"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["model"]["finetuned_from"]["id"] == model_id(base)
    assert report["sections"]["all"]["model"]["finetuned_from"]["mode"] == "first"


def test_cli_says_when_it_kept_the_base(base, tmp_path, capsys) -> None:
    base_file = base.save(tmp_path / "base.stac")
    data = _csv(tmp_path / "same.csv", _unit(3, 1.0, 0.0, 600))
    argv = ["train", str(data), "--inputs", "a,b,c", "--finetune", str(base_file)]
    argv += ["-o", str(tmp_path / "ft.stac"), "--lr", "5", "--epochs", "4", "--no-progress"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "kept the base" in out and "fine-tuning did worse on the held-out presses" in out


def test_cli_checks_few_presses_and_refuses_data_too_short_to_check(base, tmp_path, capsys) -> None:
    base_file = base.save(tmp_path / "base.stac")
    data = _csv(tmp_path / "few.csv", _unit(3, 1.4, 0.3, 20 * (MIN_VAL_GROUPS - 1)))
    argv = ["train", str(data), "--inputs", "a,b,c", "--finetune", str(base_file)]
    assert main([*argv, "-o", str(tmp_path / "ft.stac"), "--epochs", "2", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "held-out blocks: early stopping and the check against the base" in out, out
    assert "unchecked" not in out and "too few presses" not in out
    tiny = _csv(tmp_path / "tiny.csv", _unit(3, 1.4, 0.3, 12))
    argv = ["train", str(tiny), "--inputs", "a,b,c", "--finetune", str(base_file)]
    assert main([*argv, "-o", str(tmp_path / "t.stac"), "--epochs", "2", "--no-progress"]) != 0
    assert "cannot check the recalibration" in capsys.readouterr().err


def test_gain_drift_is_recalibrated_by_a_gain_before_any_layer(base) -> None:
    """Issue 22: a sensor whose response drifted by a factor (forces read 62-87 % of the
    truth) is recalibrated by one output gain per target first; layers are kept only if they
    beat it on held-out data."""
    same = _unit(7, 1.0, 0.0, 600)
    drifted = Dataset(
        {**same.arrays, "targets": same.targets * 1.35}, dict(same.meta, unit_id="unit-drift")
    )
    dec = finetune(base, drifted, epochs=1, lr=1e-6, progress=False)
    rec = dec.meta["finetuned_from"]
    assert {"base", "gain", "finetuned"} <= set(rec["val_mae_scaled"])
    assert rec["kept"] == "gain", rec
    assert rec["val_mae_scaled"]["gain"] < 0.7 * rec["val_mae_scaled"]["base"]
    assert _mae(dec, drifted) < 0.7 * _mae(base, drifted)
