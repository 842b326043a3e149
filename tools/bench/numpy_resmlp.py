"""The reference for the training benchmarks: the paper network's training step in plain NumPy.

The same ResMLP (stem Linear -> GELU, pre-norm residual blocks, final LayerNorm, fused head;
spectratac.decode.networks), the same loss shape (weighted L1 on the regression outputs plus
softmax cross-entropy on the class logits), a hand-written backward pass and AdamW, in
float32, batches sliced from one shuffle per epoch. It is what a competent hand-written
trainer costs on this machine, so `torch training time / this time` is the training loop's
overhead. `python numpy_resmlp.py ROWS FEATURES TARGETS CLASSES EPOCHS BATCH` times it in a
process of its own with one BLAS thread: NumPy's OpenBLAS threads spin while they wait, and
beside other work two of them took 14x the CPU time of one (measured 2026-11-27, load 23).
`tests/bench/test_training_bench.py` checks its gradients against torch's autograd.
"""

from __future__ import annotations

import json
import os
import sys
import time

import numpy as np
from numpy.typing import NDArray

F32 = NDArray[np.float32]
K = np.float32(0.7978845608028654)  # sqrt(2 / pi): the tanh GELU
C = np.float32(0.044715)
EPS_LN = np.float32(1e-5)


def gelu(x: F32) -> tuple[F32, F32]:
    """tanh GELU and its derivative."""
    t = np.tanh(K * (x + C * (x * x * x)))
    y = 0.5 * x * (1 + t)
    d = 0.5 * (1 + t) + 0.5 * x * (1 - t * t) * K * (1 + 3 * C * x * x)
    return y, d


def layer_norm(x: F32, g: F32, b: F32) -> tuple[F32, tuple[F32, F32, F32]]:
    mu = x.mean(axis=1, keepdims=True)
    xc = x - mu
    inv = 1.0 / np.sqrt((xc * xc).mean(axis=1, keepdims=True) + EPS_LN)
    xhat = xc * inv
    return xhat * g + b, (xhat, inv, g)


def layer_norm_back(dy: F32, cache: tuple[F32, F32, F32]) -> tuple[F32, F32, F32]:
    xhat, inv, g = cache
    dxhat = dy * g
    dx = inv * (
        dxhat
        - dxhat.mean(axis=1, keepdims=True)
        - xhat * (dxhat * xhat).mean(axis=1, keepdims=True)
    )
    return dx, (dy * xhat).sum(axis=0), dy.sum(axis=0)


class ResMLP:
    """Weights in a dict (torch's state_dict names), AdamW state beside them."""

    def __init__(self, n_in: int, hidden: int, blocks: int, n_out: int, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)

        def lin(o: int, i: int) -> tuple[F32, F32]:
            s = 1.0 / np.sqrt(i)
            return (rng.uniform(-s, s, (o, i)).astype(np.float32), np.zeros(o, np.float32))

        self.w: dict[str, F32] = {}
        self.w["stem.weight"], self.w["stem.bias"] = lin(hidden, n_in)
        for k in range(blocks):
            self.w[f"blocks.{k}.norm.weight"] = np.ones(hidden, np.float32)
            self.w[f"blocks.{k}.norm.bias"] = np.zeros(hidden, np.float32)
            self.w[f"blocks.{k}.fc1.weight"], self.w[f"blocks.{k}.fc1.bias"] = lin(hidden, hidden)
            self.w[f"blocks.{k}.fc2.weight"], self.w[f"blocks.{k}.fc2.bias"] = lin(hidden, hidden)
        self.w["norm.weight"] = np.ones(hidden, np.float32)
        self.w["norm.bias"] = np.zeros(hidden, np.float32)
        self.w["head.weight"], self.w["head.bias"] = lin(n_out, hidden)
        self.blocks = blocks
        self.m = {k: np.zeros_like(v) for k, v in self.w.items()}
        self.v = {k: np.zeros_like(v) for k, v in self.w.items()}
        self.t = 0

    def loss_and_grads(
        self, z: F32, y: F32, label: NDArray[np.int64], reg_w: F32
    ) -> tuple[float, dict[str, F32]]:
        """Loss of one batch and the gradient of every weight: regression outputs are the
        first y.shape[1] columns, class logits the rest (label -1: unlabelled)."""
        w, g = self.w, {}
        h0 = z @ w["stem.weight"].T + w["stem.bias"]
        x, d_stem = gelu(h0)
        caches = []
        for k in range(self.blocks):
            p = f"blocks.{k}."
            n, ln = layer_norm(x, w[p + "norm.weight"], w[p + "norm.bias"])
            u = n @ w[p + "fc1.weight"].T + w[p + "fc1.bias"]
            a, da = gelu(u)
            x = x + a @ w[p + "fc2.weight"].T + w[p + "fc2.bias"]
            caches.append((n, ln, a, da))
        nf, lnf = layer_norm(x, w["norm.weight"], w["norm.bias"])
        out = nf @ w["head.weight"].T + w["head.bias"]
        r = y.shape[1]
        rows = z.shape[0]
        err = out[:, :r] - y
        loss = float((np.abs(err) * reg_w).sum()) / (rows * r)
        dout = np.zeros_like(out)
        dout[:, :r] = np.sign(err) * reg_w / (rows * r)
        logits = out[:, r:]
        ok = label >= 0
        if logits.shape[1] and ok.any():
            e = np.exp(logits - logits.max(axis=1, keepdims=True))
            prob = e / e.sum(axis=1, keepdims=True)
            idx = np.flatnonzero(ok)
            lab = label[idx]
            loss += float(-np.log(prob[idx, lab] + 1e-30).sum()) / idx.size
            prob[idx, lab] -= 1.0
            prob[~ok] = 0.0
            dout[:, r:] = prob / idx.size
        g["head.weight"], g["head.bias"] = dout.T @ nf, dout.sum(axis=0)
        dx, g["norm.weight"], g["norm.bias"] = layer_norm_back(dout @ w["head.weight"], lnf)
        for k in reversed(range(self.blocks)):
            p = f"blocks.{k}."
            n, ln, a, da = caches[k]
            g[p + "fc2.weight"], g[p + "fc2.bias"] = dx.T @ a, dx.sum(axis=0)
            du = (dx @ w[p + "fc2.weight"]) * da
            g[p + "fc1.weight"], g[p + "fc1.bias"] = du.T @ n, du.sum(axis=0)
            dn, g[p + "norm.weight"], g[p + "norm.bias"] = layer_norm_back(
                du @ w[p + "fc1.weight"], ln
            )
            dx = dx + dn
        dh0 = dx * d_stem
        g["stem.weight"], g["stem.bias"] = dh0.T @ z, dh0.sum(axis=0)
        return loss, g

    def adamw(self, grads: dict[str, F32], lr: float, wd: float) -> None:
        """One AdamW step (torch's defaults: betas 0.9, 0.999, eps 1e-8)."""
        self.t += 1
        c1, c2 = 1 - 0.9**self.t, 1 - 0.999**self.t
        for k, p in self.w.items():
            gk = grads[k]
            p *= 1 - lr * wd
            self.m[k] += 0.1 * (gk - self.m[k])
            self.v[k] = 0.999 * self.v[k] + 0.001 * gk * gk
            p -= (lr / c1) * self.m[k] / (np.sqrt(self.v[k] / c2) + 1e-8)


def train_epochs(
    net: ResMLP,
    z: F32,
    y: F32,
    label: NDArray[np.int64],
    epochs: int,
    batch: int,
    lr: float = 3e-3,
    wd: float = 1e-4,
    seed: int = 0,
) -> list[float]:
    """`epochs` epochs of shuffled batches of `batch` rows; the mean loss per epoch."""
    rng = np.random.default_rng(seed)
    reg_w = np.ones(y.shape[1], np.float32)
    history = []
    for _ in range(epochs):
        perm = rng.permutation(z.shape[0])
        zs, ys, ls = z[perm], y[perm], label[perm]
        total = 0.0
        for s in range(0, z.shape[0], batch):
            loss, g = net.loss_and_grads(
                zs[s : s + batch], ys[s : s + batch], ls[s : s + batch], reg_w
            )
            net.adamw(g, lr, wd)
            total += loss * min(batch, z.shape[0] - s)
        history.append(total / z.shape[0])
    return history


def main(argv: list[str]) -> None:
    """Time `epochs` epochs on random rows of the given shape; print wall and CPU s per epoch."""
    rows, features, targets, classes, epochs, batch = map(int, argv)
    rng = np.random.default_rng(0)
    z = rng.standard_normal((rows, features)).astype(np.float32)
    y = rng.standard_normal((rows, targets)).astype(np.float32)
    label = rng.integers(-1, classes, rows)
    net = ResMLP(features, 128, 3, targets + classes)
    t0, c0 = time.perf_counter(), time.process_time()
    train_epochs(net, z, y, label, epochs, batch)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    blas = os.environ.get("OPENBLAS_NUM_THREADS")
    print(json.dumps({"wall_s": wall / epochs, "cpu_s": cpu / epochs, "blas_threads": blas}))


if __name__ == "__main__":
    main(sys.argv[1:])
