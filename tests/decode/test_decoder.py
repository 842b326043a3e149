"""The Decoder API: target subsets, model file checks, reproducibility, LED sequences,
temporal context and baseline assembly, contact and uncertainty heads."""

from __future__ import annotations

import json
import warnings
import zipfile

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.dataset import FT_NAMES, SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder, DecoderConfigError, DecoderError, DecoderUnitWarning
from spectratac.decode.assemble import GATE, STUCK, Assembler, assemble
from spectratac.decode.errors import DecoderFileError
from spectratac.decode.layout import Layout
from spectratac.train import TrainSpec, train

pytestmark = pytest.mark.train

TINY = {"epochs": 3, "hidden": 16, "blocks": 1, "threads": 1, "batch_size": 256}


def test_target_subset_leaves_other_axes_nan(twin_ds) -> None:
    dec = train(twin_ds, TrainSpec.paper(targets=("Fz", "region"), **TINY), progress=False)
    est = dec.predict(twin_ds, rows=np.arange(100))
    assert est.target_names == ("Fz",) and est.targets.shape == (100, 1)
    assert np.isnan(est.force[:, :2]).all() and np.isfinite(est.force[:, 2]).all()
    assert np.isnan(est.torque).all() and est.std is None
    assert set(np.unique(est.region)) <= set(range(1, 10))
    assert dec.meta["targets"] == ["Fz", "region"] and dec.heads.n_out == 10


def test_unknown_target_and_wrong_features_are_refused(twin_ds) -> None:
    with pytest.raises(DecoderConfigError, match="'Fq' is not in this dataset"):
        train(twin_ds, TrainSpec.paper(targets=("Fq",), **TINY), progress=False)
    other = Dataset.generic(np.ones((10, 4)), np.zeros((10, 1)), list("abcd"), ["Fz"])
    with pytest.raises(DecoderConfigError, match="features='paper33' needs"):
        train(other, TrainSpec.paper(targets=("Fz",), **TINY), progress=False)


def test_same_seed_same_model_other_seed_other_model(synth_ds) -> None:
    a = train(synth_ds, TrainSpec.paper(**TINY), progress=False)
    b = train(synth_ds, TrainSpec.paper(**TINY), progress=False)
    c = train(synth_ds, TrainSpec.paper(seed=1, **TINY), progress=False)
    for k, v in a.runtime.weights.items():
        np.testing.assert_array_equal(v, b.runtime.weights[k])
    assert not np.array_equal(a.runtime.weights["head.weight"], c.runtime.weights["head.weight"])


def test_model_file_refuses_config_mismatch_and_warns_on_unit(twin_ds, tmp_path) -> None:
    dec = train(twin_ds, TrainSpec.paper(**TINY), progress=False)
    path = dec.save(tmp_path / "m.stac")
    cfg = dict(twin_ds.meta["config"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        same = Decoder.load(path, expect_config=dict(cfg, settle_us=999), expect_unit="twin-3")
    assert same.meta["config"] == cfg and same.meta["unit_id"] == "twin-3"
    assert same.meta["spec"] == TrainSpec.paper(**TINY).to_dict()
    with pytest.raises(DecoderConfigError, match="integration_ms: trained 50, got 100"):
        Decoder.load(path, expect_config=dict(cfg, integration_ms=100))
    with pytest.raises(DecoderConfigError, match="leds"):
        Decoder.load(path, expect_config=dict(cfg, leds=[[[500] * 3] * 3]))
    with pytest.warns(DecoderUnitWarning, match="unit 'twin-9'"):
        Decoder.load(path, expect_unit="twin-9")
    other = twin_ds.subset(slice(0, 50))
    other.meta["config"] = dict(cfg, gain=2.0)
    with pytest.raises(DecoderConfigError, match="gain"):
        same.predict(other)


def test_model_file_versions_and_damage(synth_ds, tmp_path) -> None:
    path = train(synth_ds, TrainSpec.paper(**TINY), progress=False).save(tmp_path / "m.stac")
    with zipfile.ZipFile(path) as z:
        meta, arrays = json.loads(z.read("meta.json")), z.read("arrays.npz")

    def write(name: str, m: dict) -> str:
        p = tmp_path / name
        with zipfile.ZipFile(p, "w") as z:
            z.writestr("meta.json", json.dumps(m))
            z.writestr("arrays.npz", arrays)
        return str(p)

    Decoder.load(write("minor.stac", dict(meta, version="1.7")))  # newer minor: loads
    with pytest.raises(DecoderFileError, match=r"format 2\.0, newer .*update spectratac"):
        Decoder.load(write("major.stac", dict(meta, version="2.0")))
    (tmp_path / "junk.stac").write_bytes(b"not a zip")
    with pytest.raises(DecoderFileError, match="not a SpectraTac model file"):
        Decoder.load(tmp_path / "junk.stac")
    with pytest.raises(DecoderFileError, match="no model file"):
        Decoder.load(tmp_path / "missing.stac")
    # A file saved when generic datasets kept Mx My Mz as torque names is refused, saying why.
    old = json.loads(json.dumps(meta).replace('"Tx"', '"Mx"').replace('"Tz"', '"Mz"'))
    with pytest.raises(DecoderFileError, match=r"torque targets \['Mx', 'Mz'\].*retrain"):
        Decoder.load(write("old_torque_names.stac", old))


@settings(max_examples=40, deadline=None)
@given(steps=st.lists(st.integers(0, 2), min_size=1, max_size=30))
def test_led_sequence_assembly_takes_the_latest_sample_of_each_step(steps) -> None:
    lay = Layout(("a", "b"), steps=3)
    x = np.arange(len(steps) * 2, dtype=float).reshape(-1, 2)
    u, valid = assemble(lay, x, np.array(steps))
    latest: dict[int, np.ndarray] = {}
    for i, s in enumerate(steps):
        latest[s] = x[i]
        assert valid[i] == (len(latest) == 3)
        if valid[i]:
            np.testing.assert_array_equal(u[i], np.concatenate([latest[k] for k in range(3)]))
        else:
            assert np.isnan(u[i]).all()


def test_assembly_runs_per_session_in_time_order_with_context() -> None:
    lay = Layout(("a",), lags=(1, 3))
    x = np.array([[10.0], [11.0], [0.0], [12.0], [1.0], [13.0]])
    session = np.array([0, 0, 1, 0, 1, 0])
    t = np.array([0.0, 1.0, 5.0, 2.0, 6.0, 3.0])
    order = np.array([5, 3, 1, 0, 4, 2])  # rows shuffled: time order still rules
    u, valid = assemble(lay, x[order], None, session[order], t[order])
    got = {tuple(x[order][i]): u[i].tolist() for i in range(6)}
    assert got[(13.0,)] == [13.0, 12.0, 10.0] and got[(10.0,)] == [10.0, 10.0, 10.0]
    assert got[(1.0,)] == [1.0, 0.0, 0.0] and valid.all()


def test_baseline_follows_slow_drift_but_not_presses() -> None:
    lay = Layout(("a", "b"), drift=True)
    asm = Assembler(lay)
    level = 1000.0
    for i in range(20000):
        level *= 1.000005  # ~10 % over the run: slow drift
        pressed = (i // 200) % 2 == 1  # 10 s presses every 20 s at 20 Hz
        x = np.array([level, level]) * (0.7 if pressed else 1.0)
        u, _ = asm.push(0, x)
    base = u[2:]
    assert np.all(np.abs(base / level - 1.0) < GATE)  # tracks the drift, ignores the presses


def test_contact_and_uncertainty_heads(twin_ds) -> None:
    spec = TrainSpec.paper(
        targets=("Fx", "Fy", "Fz", "contact"), uncertainty=True, epochs=15, hidden=32,
        blocks=1, threads=1, batch_size=128,
    )  # fmt: skip
    dec = train(twin_ds, spec, rows=np.arange(2000), progress=False)
    est = dec.predict(twin_ds, rows=np.arange(2000, twin_ds.n))
    truth = twin_ds.in_contact[2000:]
    assert np.mean(est.contact == truth) > 0.85
    assert np.all((est.contact_prob >= 0) & (est.contact_prob <= 1))
    assert est.std is not None and np.all(est.std > 0)
    assert dec.meta["n_val"] > 0 and len(dec.meta["std_scale"]) == 3
    err = np.abs(est.targets - twin_ds.targets[2000:, :3])
    inside = np.mean(err < 2 * est.std)  # ~ 94 % for a calibrated Laplace; be lenient
    assert 0.7 < inside < 0.995


def test_spec_validation() -> None:
    with pytest.raises(DecoderError, match=r"TrainSpec\.drift='slow'"):
        TrainSpec(drift="slow")
    with pytest.raises(DecoderError, match="distinct"):
        TrainSpec(targets=("Fz", "Fz"))
    assert TrainSpec(context=4, context_dilated=True).lags == (1, 2, 4, 8)
    assert TrainSpec(model="resmlp-large").arch == ("resmlp", 256, 6)
    assert TrainSpec(uncertainty=True).val_fraction == 0.1
    with pytest.raises(DecoderError, match=r"loss_weights names \['Mz'\]"):
        TrainSpec(loss_weights=(("Mz", 1.0),))
    with pytest.raises(DecoderError, match="finite and >= 0"):
        TrainSpec(loss_weights=(("Fz", -1.0),))
    with pytest.raises(DecoderError, match="augment='spin'"):
        TrainSpec(augment="spin")


def test_flops_and_params_of_the_paper_model(synth_ds) -> None:
    dec = Decoder.untrained(synth_ds, features="paper33", targets=(*FT_NAMES, "region"),
                            arch=("resmlp", 128, 3))  # fmt: skip
    assert dec.n_params == 106_383
    assert 200_000 < dec.flops_per_sample < 220_000
    assert tuple(dec.layout.channels) == SPECTRATAC_INPUTS


def test_baseline_recovers_when_a_session_starts_under_contact() -> None:
    asm = Assembler(Layout(("a",), drift=True))
    for _ in range(100):
        asm.push(0, np.array([700.0]))  # pressed from the start
    for _ in range(STUCK + 5 * 600):
        u, _ = asm.push(0, np.array([1000.0]))
    assert abs(u[1] / 1000.0 - 1.0) < GATE


def test_moving_average_context_sees_only_the_past() -> None:
    lay = Layout(("a",), emas=(2.0,))
    u, valid = assemble(lay, np.array([[0.0], [4.0], [4.0], [4.0]]))
    assert valid.all() and u[:, 1].tolist() == [0.0, 0.0, 2.0, 3.0]
    assert lay.names() == ["a", "ema2:a"]


def test_led_sequence_decoder_end_to_end() -> None:
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    steps = np.zeros((3, 3, 3))
    for c in range(3):
        steps[c, :, c] = 0.6  # step c lights every LED in colour c (R, G, B)
    scene = scenes.calibration_session(seed=1, duration_s=40.0)
    ds = from_twin_session(generate_session(scene, seed=1, led_steps=steps), scene)
    assert len(ds.meta["config"]["leds"]) == 3
    dec = train(ds, TrainSpec.paper(**TINY), progress=False)
    assert dec.layout.steps == 3 and dec.runtime.features.n_features == 99
    est = dec.predict(ds)
    assert est.invalid.tolist()[:3] == [True, True, False] and est.invalid.sum() == 2
    assert np.isfinite(est.targets[2:]).all()


@settings(max_examples=40, deadline=None)
@given(
    steps=st.lists(st.integers(-1, 2), min_size=1, max_size=60),
    nan_rows=st.sets(st.integers(0, 59), max_size=5),
    lags=st.sets(st.integers(1, 5), max_size=3),
    emas=st.sets(st.sampled_from([2.0, 5.0]), max_size=2),
    drift=st.booleans(),
)
def test_batch_assembly_equals_streaming_push(steps, nan_rows, lags, emas, drift) -> None:
    lay = Layout(("a", "b"), steps=3, lags=tuple(sorted(lags)), drift=drift,
                 emas=tuple(sorted(emas)))  # fmt: skip
    rng = np.random.default_rng(len(steps))
    x = (
        rng.uniform(900, 1100, (len(steps), 2))
        * np.where(rng.random(len(steps)) < 0.3, 0.6, 1)[:, None]
    )
    for r in nan_rows:
        if r < len(steps):
            x[r, 1] = np.nan
    u, valid = assemble(lay, x, np.array(steps))
    asm = Assembler(lay)
    for i, s in enumerate(steps):
        vec, ok = asm.push(s, x[i])
        assert ok == valid[i]
        np.testing.assert_array_equal(vec, u[i])


def test_training_only_regularisers(synth_ds) -> None:
    plain = train(synth_ds, TrainSpec.paper(**TINY), progress=False)
    spec = TrainSpec.paper(dropout=0.1, input_noise=0.1, best_val=True, weight_average=0.9, **TINY)
    assert spec.val_fraction == 0.1
    reg = train(synth_ds, spec, progress=False)
    assert len(reg.meta["val_history"]) == TINY["epochs"] and reg.meta["n_val"] > 0
    assert not np.array_equal(
        plain.runtime.weights["head.weight"], reg.runtime.weights["head.weight"]
    )
    assert np.isfinite(reg.predict(synth_ds).targets).all()
    with pytest.raises(DecoderError, match="dropout"):
        TrainSpec(dropout=1.0)
    with pytest.raises(DecoderError, match="weight_average"):
        TrainSpec(weight_average=1.0)


def test_best_spec_costs_no_more_than_the_paper(twin_ds) -> None:
    small = {"epochs": 1, "threads": 1}
    paper = train(twin_ds, TrainSpec.paper(**small), progress=False)
    best = train(twin_ds, TrainSpec.best(**small), progress=False)
    assert best.flops_per_sample <= paper.flops_per_sample
    assert best.n_params <= paper.n_params
    assert best.layout.drift and best.layout.lags == tuple(range(1, 9))
    assert best.meta["n_augmented"] == 5 * best.meta["n_train"]  # rotated and mirrored presses
    # the Fz loss weight follows the targets asked for
    assert TrainSpec.best(targets=("Fx", "region")).loss_weights == ()
    assert TrainSpec.best().loss_weights == (("Fz", 2.0),)
