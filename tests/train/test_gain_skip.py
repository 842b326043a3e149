"""Gain augmentation (TrainSpec.gain_jitter) and the linear skip beside the network
(TrainSpec.skip): what they train, that model files record them and that older files load."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder, DecoderError
from spectratac.decode.feature_matrices import build_features
from spectratac.decode.heads import Heads
from spectratac.decode.layout import Layout
from spectratac.decode.networks import SKIP, init_weights
from spectratac.decode.runtime import Runtime
from spectratac.train import TrainSpec, train
from spectratac.train.gain import GainView
from spectratac.train.torch_loop import GainJitter

from tests.decode.conftest import synthetic

pytestmark = pytest.mark.train
SMALL = {"epochs": 3, "hidden": 16, "blocks": 1, "threads": 1, "targets": ("Fx", "Fy", "Fz")}


def force_mae(dec: Decoder, ds: Dataset, rows: np.ndarray) -> float:
    est = dec.predict(ds, rows)
    y = np.asarray(ds.targets, np.float64)[rows][:, :3]
    return float(np.nanmean(np.abs(est.targets - y)))


def scaled(ds: Dataset, gain: float) -> Dataset:
    return Dataset({**ds.arrays, "inputs": np.asarray(ds.inputs) * gain}, dict(ds.meta))


def test_the_options_are_checked_and_older_specs_load() -> None:
    spec = TrainSpec.paper(gain_jitter=0.15, skip=True)
    assert TrainSpec.from_dict(spec.to_dict()) == spec
    old = TrainSpec.paper().to_dict()
    del old["gain_jitter"], old["skip"]  # a model file written before the options existed
    assert TrainSpec.from_dict(old) == TrainSpec.paper()
    with pytest.raises(DecoderError, match=r"gain_jitter=1.0: use 0 <= g < 1"):
        TrainSpec.paper(gain_jitter=1.0)
    with pytest.raises(DecoderError, match="model='ridge' is linear already"):
        TrainSpec(model="ridge", targets=("Fz",), skip=True)
    assert TrainSpec.best().gain_jitter == 0.15  # measured to help (tools/bench/MEASUREMENTS.md)
    assert TrainSpec.best(model="ridge", targets=("Fz",)).gain_jitter == 0.0  # no batches


@settings(max_examples=25, deadline=None)
@given(g=st.floats(0.0, 0.5), seed=st.integers(0, 2**16))
def test_a_jittered_batch_is_the_rows_under_one_gain_each(g: float, seed: int) -> None:
    """The loop's features of a jittered batch are exactly those of u[rows] x one factor per
    row in [1 - g, 1 + g] (sample, lags, averages and baseline alike), through the paper's
    features with the drift baseline's ratios and a polynomial's monomials."""
    import torch

    rng = np.random.default_rng(seed)
    for features, degree in (("paper33", 1), ("generic", 2)):
        lay = Layout(SPECTRATAC_INPUTS, lags=(1,), drift=True)
        fs = build_features(features, lay, degree=degree)
        u = rng.uniform(100.0, 3e4, (9, lay.size))
        arch = ("linear", 0, 0)
        w = init_weights(arch, fs.n_features, 3, rng)
        rt = Runtime.create(fs, arch, w, Heads(("Fx", "Fy", "Fz")), u)
        rows = np.array([8, 0, 3, 3])
        jitter = GainJitter(GainView(rt.with_dtype(np.float64), u), rows)  # as the loop does
        factors = GainJitter.factors(rows.size, g, np.random.default_rng(seed))
        z = jitter.z(jitter.take(torch.arange(rows.size)), factors).numpy()
        factor = np.random.default_rng(seed).uniform(1 - g, 1 + g, (rows.size, 1))
        assert np.all((factor >= 1 - g) & (factor <= 1 + g))
        want = rt.with_dtype(np.float64).normalised(u[rows] * factor)
        np.testing.assert_allclose(z, want, rtol=1e-4, atol=1e-4)


def test_gain_jitter_makes_the_decoder_hold_under_a_gain_drift(twin_ds, tmp_path) -> None:
    """The twin session read by a unit of -15 % and +15 % optical gain: trained with jitter
    (and the drift baseline, whose ratios a gain leaves alone) the decoder's force error
    there is clearly below the same recipe's without, and the file records the option."""
    small = {**SMALL, "epochs": 8, "drift": "baseline"}
    plain = train(twin_ds, TrainSpec.paper(**small), progress=False)
    jit = train(twin_ds, TrainSpec.paper(**small, gain_jitter=0.15), progress=False)
    rows = np.arange(twin_ds.n)

    def drifted(dec: Decoder) -> float:
        return float(np.mean([force_mae(dec, scaled(twin_ds, g), rows) for g in (0.85, 1.15)]))

    assert drifted(jit) < 0.9 * drifted(plain)
    loaded = Decoder.load(jit.save(tmp_path / "jit.stac"))
    assert TrainSpec.from_dict(loaded.meta["spec"]).gain_jitter == 0.15


def test_the_skip_extrapolates_beyond_the_training_forces(tmp_path) -> None:
    """Trained on the lighter 85 % of |Fz|, scored on the heavier 15 %: the targets are
    linear in the counts, and the network alone saturates where the skip goes on."""
    ds = synthetic(n=3000, seed=5)
    fz = np.abs(np.asarray(ds.targets)[:, 2])
    cut = np.quantile(fz, 0.85)
    light, heavy = np.flatnonzero(fz <= cut), np.flatnonzero(fz > cut)
    spec = TrainSpec.paper(**{**SMALL, "epochs": 20})
    plain = train(ds, spec, light, progress=False)
    skip = train(ds, TrainSpec.paper(**{**SMALL, "epochs": 20, "skip": True}), light,
                 progress=False)  # fmt: skip
    assert SKIP in skip.runtime.weights and SKIP not in plain.runtime.weights
    assert force_mae(skip, ds, heavy) < 0.5 * force_mae(plain, ds, heavy)
    loaded = Decoder.load(skip.save(tmp_path / "skip.stac"))
    np.testing.assert_array_equal(
        loaded.predict(ds, heavy).targets, skip.predict(ds, heavy).targets
    )


@pytest.mark.subprocess
def test_the_cli_trains_with_a_skip_and_gain_jitter(twin_ds, tmp_path) -> None:
    """`spectratac train --skip --gain-jitter 0.1`, run as a person runs it: the model file
    holds the skip and records both options."""
    import subprocess
    import sys

    data = twin_ds.save(tmp_path / "d.npz")
    out = tmp_path / "m.stac"
    args = ["train", str(data), "-o", str(out), "--epochs", "2", "--hidden", "16",
            "--skip", "--gain-jitter", "0.1", "--no-progress", "--threads", "1"]  # fmt: skip
    run = subprocess.run([sys.executable, "-m", "spectratac", *args], capture_output=True,
                         text=True, timeout=900)  # fmt: skip
    assert run.returncode == 0, run.stderr
    dec = Decoder.load(out)
    spec = TrainSpec.from_dict(dec.meta["spec"])
    assert spec.skip and spec.gain_jitter == 0.1 and SKIP in dec.runtime.weights


def test_the_guard_covers_the_gains_the_network_was_trained_on(twin_ds) -> None:
    """A unit read at 0.9 or 1.1 times the training gain is what gain_jitter=0.15 trained
    the network for: the guard's input checks (range and distance) do not flag it for that
    alone, where a plain model's flag every row; a gain far beyond the jitter still is."""
    small = {**SMALL, "epochs": 1, "drift": "baseline"}
    plain = train(twin_ds, TrainSpec.paper(**small), progress=False)
    jit = train(twin_ds, TrainSpec.paper(**small, gain_jitter=0.15), progress=False)
    x = np.asarray(twin_ds.inputs, np.float64)  # the current sample's inputs: the guard's
    assert x.shape[1] == jit.layout.base

    def flagged(dec: Decoder, gain: float) -> float:
        return float(np.mean(dec.guard.check(gain * x)))

    assert flagged(jit, 1.0) < 0.01 and flagged(plain, 1.0) < 0.01  # its own rows
    for gain in (0.9, 1.1):
        assert flagged(plain, gain) > 0.5, gain
        assert flagged(jit, gain) < 0.01, gain
    assert flagged(jit, 1.6) > 0.9
