"""The decoder networks, evaluated in NumPy (torch is needed for training only).

Architectures over z-scored features z (N, F), all ending in one fused linear head whose
outputs are [scaled targets, log-scales (uncertainty), class logits, contact logit]:

- linear: head(z)
- mlp:    `blocks` x (Linear(H) -> GELU), head
- resmlp: the paper's shared backbone: stem Linear(F, H) -> GELU, `blocks` pre-norm residual
          blocks h + W2 GELU(W1 LayerNorm(h)), a final LayerNorm, head

Optional linear skip (weights hold "skip.weight", shape (O, F), no bias): the head's output
plus skip.weight @ z, so that features beyond the training range move the outputs linearly
instead of through the backbone, whose final LayerNorm bounds what the head sees.

GELU is the tanh approximation in training and inference alike (exact GELU differs ~1e-3).
Weight names equal the torch module's state_dict keys.

>>> w = init_weights(("resmlp", 8, 1), n_in=33, n_out=15, rng=np.random.default_rng(0))
>>> forward(("resmlp", 8, 1), w, np.zeros((2, 33))).shape
(2, 15)
>>> n_params(w), flops(("resmlp", 8, 1), 33, 15)
(583, 1024)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
Weights = dict[str, NDArray[Any]]
Arch = tuple[str, int, int]  # (kind, hidden, blocks)

LN_EPS = 1e-5
SQRT_2_OVER_PI = 0.7978845608028654
SKIP = "skip.weight"  # the optional linear path from the features to the outputs


def gelu_tanh(x: F64) -> F64:
    return 0.5 * x * (1.0 + np.tanh(SQRT_2_OVER_PI * (x + 0.044715 * x * x * x)))


def layer_norm(x: F64, g: NDArray[Any], b: NDArray[Any]) -> F64:
    mu = x.mean(axis=-1, keepdims=True)
    var = x.var(axis=-1, keepdims=True)
    return (x - mu) / np.sqrt(var + x.dtype.type(LN_EPS)) * g + b


def forward(arch: Arch, w: Weights, z: F64) -> F64:
    """Fused head outputs (N, O) for z-scored features (N, F), in z's dtype."""
    kind, _, blocks = arch
    dt = z.dtype

    def lin(name: str, v: F64) -> F64:
        return v @ w[name + ".weight"].T.astype(dt) + w[name + ".bias"].astype(dt)

    h = z
    if kind == "mlp":
        for i in range(blocks):
            h = gelu_tanh(lin(f"layers.{i}", h))
    elif kind == "resmlp":
        h = gelu_tanh(lin("stem", h))
        for i in range(blocks):
            p = f"blocks.{i}."
            u = layer_norm(h, w[p + "norm.weight"].astype(dt), w[p + "norm.bias"].astype(dt))
            h = h + lin(p + "fc2", gelu_tanh(lin(p + "fc1", u)))
        h = layer_norm(h, w["norm.weight"].astype(dt), w["norm.bias"].astype(dt))
    out = lin("head", h)
    if SKIP in w:
        out = out + z @ w[SKIP].T.astype(dt)
    return out


def layer_shapes(arch: Arch, n_in: int, n_out: int) -> list[tuple[str, int, int]]:
    """(name, out, in) of every linear layer, in order."""
    kind, hidden, blocks = arch
    if kind == "linear":
        return [("head", n_out, n_in)]
    if kind == "mlp":
        dims = [n_in] + [hidden] * blocks
        layers = [(f"layers.{i}", dims[i + 1], dims[i]) for i in range(blocks)]
        return [*layers, ("head", n_out, dims[-1])]
    layers = [("stem", hidden, n_in)]
    for i in range(blocks):
        layers += [(f"blocks.{i}.fc1", hidden, hidden), (f"blocks.{i}.fc2", hidden, hidden)]
    return [*layers, ("head", n_out, hidden)]


def norm_names(arch: Arch) -> list[str]:
    if arch[0] != "resmlp":
        return []
    return [f"blocks.{i}.norm" for i in range(arch[2])] + ["norm"]


def init_weights(arch: Arch, n_in: int, n_out: int, rng: np.random.Generator) -> Weights:
    """Random weights with the torch module's names and shapes (for tests)."""
    w: Weights = {}
    for name, o, i in layer_shapes(arch, n_in, n_out):
        k = 1.0 / np.sqrt(i)
        w[name + ".weight"] = rng.uniform(-k, k, (o, i)).astype(np.float32)
        w[name + ".bias"] = rng.uniform(-k, k, o).astype(np.float32)
    for name in norm_names(arch):
        w[name + ".weight"] = np.ones(arch[1], np.float32)
        w[name + ".bias"] = np.zeros(arch[1], np.float32)
    return w


def n_params(w: Weights) -> int:
    return int(sum(v.size for v in w.values()))


def flops(arch: Arch, n_in: int, n_out: int) -> int:
    """Multiply-adds x 2 of the linear layers per sample (activations and norms excluded)."""
    return int(sum(2 * o * i for _, o, i in layer_shapes(arch, n_in, n_out)))
