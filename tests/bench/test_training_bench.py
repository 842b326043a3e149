"""The training benchmark (tools/bench/training.py): its NumPy reference (numpy_resmlp.py)
computes what torch computes for the paper network (the same loss, gradients and AdamW
steps, so that the ratio compares the same work), and its figures come out end to end on a
small scale (no timing asserted)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.decode.export.torch_net import Net

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools" / "bench"))

import numpy_resmlp

pytestmark = pytest.mark.train
F, H, B, R, K = 5, 8, 2, 3, 4  # features, hidden, blocks, regression targets, classes


def torch_loss(net: Net, z: np.ndarray, y: np.ndarray, label: np.ndarray) -> torch.Tensor:
    out = net(torch.from_numpy(z))
    reg = (out[:, :R] - torch.from_numpy(y)).abs().sum() / (z.shape[0] * R)
    ok = torch.from_numpy(label >= 0)
    lab = torch.from_numpy(label)[ok]
    ce = torch.nn.functional.cross_entropy(out[ok][:, R:], lab, reduction="sum") / lab.numel()
    return reg + ce


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**16), rows=st.integers(2, 40))
def test_loss_and_gradients_match_torch_autograd(seed: int, rows: int) -> None:
    rng = np.random.default_rng(seed)
    ref = numpy_resmlp.ResMLP(F, H, B, R + K, seed=seed)
    for v in ref.w.values():  # norms away from their start, so their gradients matter
        v += rng.normal(0.0, 0.3, v.shape).astype(np.float32)
    z = rng.standard_normal((rows, F)).astype(np.float32)
    y = rng.standard_normal((rows, R)).astype(np.float32)
    label = rng.integers(-1, K, rows)
    label[0] = 1  # at least one labelled row
    loss, grads = ref.loss_and_grads(z, y, label, np.ones(R, np.float32))
    net = Net(("resmlp", H, B), F, R + K)
    net.load_state_dict({k: torch.from_numpy(v.copy()) for k, v in ref.w.items()})
    want = torch_loss(net, z, y, label)
    want.backward()
    assert loss == pytest.approx(float(want.detach()), rel=1e-4)
    for name, p in net.named_parameters():
        assert p.grad is not None
        np.testing.assert_allclose(grads[name], p.grad.numpy(), rtol=2e-3, atol=2e-5, err_msg=name)


def test_adamw_steps_match_torch() -> None:
    ref = numpy_resmlp.ResMLP(F, H, B, R + K, seed=0)
    net = Net(("resmlp", H, B), F, R + K)
    net.load_state_dict({k: torch.from_numpy(v.copy()) for k, v in ref.w.items()})
    opt = torch.optim.AdamW(net.parameters(), lr=3e-3, weight_decay=0.05)
    rng = np.random.default_rng(1)
    for _ in range(3):
        grads = {k: rng.standard_normal(v.shape).astype(np.float32) for k, v in ref.w.items()}
        ref.adamw(grads, 3e-3, 0.05)
        for name, p in net.named_parameters():
            p.grad = torch.from_numpy(grads[name])
        opt.step()
    for name, p in net.named_parameters():
        np.testing.assert_allclose(ref.w[name], p.detach().numpy(), rtol=1e-5, atol=1e-6)


@pytest.mark.slow
def test_training_bench_json_for_the_recipes_and_the_paper_run(run_bench) -> None:
    figures = run_bench(
        "training.py", "--nets", "paper,best", "--epochs", "1", "--rounds", "1", "--busy", "1",
        "--paper-rows", "2000", "--paper-epochs", "2",
    )  # fmt: skip
    for net in ("paper", "best"):
        quiet, loaded = (
            figures[f"{net} recipe training, quiet"],
            figures[f"{net} recipe training, 1 busy loops"],
        )
        assert loaded["reference_value"] == quiet["value"] > 0
        assert quiet["extra"]["cpu_s"] > 0 and loaded["extra"]["target_ratio"] == 0.4
    best = figures["best recipe training, quiet"]["extra"]
    assert best["batch"] == 256 and best["rows"] == 12_000
    paper = figures["paper recipe, 2000 rows x 2 epochs"]
    assert paper["reference_name"].startswith("NumPy reference")
    assert paper["ratio"] == pytest.approx(paper["value"] / paper["reference_value"])
    assert paper["extra"]["cpu_s"] > 0 and paper["extra"]["reference_cpu_s"] > 0
