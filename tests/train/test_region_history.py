"""The region head with temporal context: taught on the evidence of the moment, so that the
press's history (lag and moving-average deltas) cannot move its decision
(TrainSpec.region_history_swap, train/torch_loop.HistorySwap)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
from spectratac.decode import DecoderError
from spectratac.decode.feature_matrices import build_features
from spectratac.decode.layout import Layout
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.train import TrainSpec, train
from spectratac.train.torch_loop import HistorySwap, history_columns

pytestmark = pytest.mark.train
PRESS_ROWS = 12


def presses(n_presses: int, seed: int, history_agrees: bool) -> Dataset:
    """Presses alternating between regions 3 and 7. The evidence now (sensor 0's R against
    sensor 1's) points to the press's region on 80 % of its rows; the history (sensor 2's R
    climbing through a region-3 press, falling through a region-7 one) tells the training
    presses apart on every row, at a level that says nothing by itself. With
    `history_agrees=False` the history points the other way: only the evidence now holds."""
    rng = np.random.default_rng(seed)
    raw, region = [], []
    for k in range(n_presses):
        reg = 3 if k % 2 == 0 else 7
        x = rng.uniform(8000, 12000, (PRESS_ROWS, 12))
        sign = (1 if reg == 3 else -1) * np.where(rng.random(PRESS_ROWS) < 0.2, -1, 1)
        d = rng.uniform(300, 2000, PRESS_ROWS) * sign
        x[:, 0], x[:, 4] = 10000 + d, 10000 - d
        climb = 400.0 if (reg == 3) == history_agrees else -400.0
        x[:, 8] = rng.uniform(6000, 14000) + (np.arange(PRESS_ROWS) - 5.5) * climb
        raw.append(x)
        region.append(np.full(PRESS_ROWS, reg))
    counts = np.concatenate(raw)
    ft = np.stack([counts[:, 0] / 1e4, counts[:, 4] / 1e4, -counts[:, 1] / 5e3], axis=1)
    ft = np.concatenate([ft, counts[:, 2:5] / 1e6], axis=1)
    ds = Dataset.generic(
        counts,
        ft,
        SPECTRATAC_INPUTS,
        vocab.FT_AXES,
        region=np.concatenate(region),
        press=np.repeat(np.arange(n_presses), PRESS_ROWS),
    )
    ds.meta.update(kind="spectratac", unit_id="synthetic", config=None)
    return ds


def test_a_region_taught_with_swapped_history_reads_the_evidence_not_the_history() -> None:
    """Without the swap, the network learns the history that tells the training presses
    apart and misreads nearly every row once the history points elsewhere; with it, the
    region follows the evidence now (about 80 % right, as a network without context)."""
    fit_on, score_on = (
        presses(60, seed=0, history_agrees=True),
        presses(20, seed=1, history_agrees=False),
    )
    rows = np.arange(score_on.n)
    later = np.asarray(score_on.press) == np.roll(np.asarray(score_on.press), 1)  # lag in press
    labels = np.asarray(score_on.region)[later]

    def accuracy(**options: float | int) -> float:
        spec = TrainSpec.paper(
            epochs=30, hidden=32, blocks=1, threads=1, batch_size=64,
            targets=("Fx", "Fz", "region"), **options,
        )  # fmt: skip
        est = train(fit_on, spec, progress=False).predict(score_on, rows)
        return float(np.mean(est.region[later] == labels))

    without, with_swap = accuracy(context=1), accuracy(context=1, region_history_swap=0.5)
    no_context = accuracy(context=0)
    assert without < 0.2, f"the shortcut was not learnt ({without:.2f}): the test lost its point"
    assert with_swap > 0.65, f"region still follows the history: {with_swap:.2f} vs {without:.2f}"
    assert with_swap > no_context - 0.15, f"swap {with_swap:.2f}, no context {no_context:.2f}"


def test_the_history_columns_are_the_lag_and_moving_average_deltas() -> None:
    lay = Layout(SPECTRATAC_INPUTS, lags=(1, 2), drift=True, emas=(10.0,))
    fs = build_features("paper33", lay)
    names = [fs.names[i] for i in history_columns(fs, lay)]
    expected = [n for n in fs.names if "[t-" in n or "ema" in n]
    assert names == expected and len(names) == 12 * 3
    assert history_columns(build_features("paper33", Layout(SPECTRATAC_INPUTS)), Layout(
        SPECTRATAC_INPUTS)).size == 0  # fmt: skip


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**16), share=st.floats(0.05, 0.95), n=st.integers(1, 40))
def test_a_swap_moves_only_history_of_labelled_rows_and_silences_their_other_losses(
    seed: int, share: float, n: int
) -> None:
    import torch

    rng = np.random.default_rng(seed)
    cols = np.array([1, 3, 4])
    z = torch.from_numpy(rng.normal(size=(n, 6)).astype(np.float32))
    label = torch.from_numpy(rng.integers(-1, 9, n))
    label[label < 0] = -100  # the loop's unlabelled rows
    batch = {"label": label, "y_ok": torch.ones(n), "contact": torch.zeros(n)}
    out, b = HistorySwap(share, cols, 6).apply(z, batch, torch.Generator().manual_seed(seed))
    moved = ~torch.all(out == z, dim=1)
    picked = b["y_ok"] == 0
    assert torch.equal(b["contact_ok"], 1.0 - picked.float())
    assert not torch.any(picked & (label < 0)), "an unlabelled row lost its losses"
    assert not torch.any(moved & ~picked), "a row kept its losses with another's history"
    other = [c for c in range(6) if c not in cols]
    assert torch.equal(out[:, other], z[:, other]), "a column of the evidence now moved"
    for i in np.flatnonzero(picked.numpy()):  # the history of some row of the batch
        assert torch.any(torch.all(z[:, cols] == out[i, cols], dim=1))


def test_best_swaps_and_the_option_is_checked_and_older_specs_load() -> None:
    assert TrainSpec.best().region_history_swap == 0.5
    old = TrainSpec.paper().to_dict()
    del old["region_history_swap"]  # a model file written before the option existed
    assert TrainSpec.from_dict(old) == TrainSpec.paper()
    with pytest.raises(DecoderError, match=r"region_history_swap=1.0: use 0 <= s < 1"):
        TrainSpec.paper(region_history_swap=1.0)
