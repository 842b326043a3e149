"""A fused single-sample evaluator of a Runtime: low latency without torch.

`compile_single(rt)` returns ``run1(u) -> out``: everything is prepared once (float32,
transposed weights, LayerNorm gains and the standardisation folded into the following
layer, biases appended as a last weight row multiplied by a constant 1, GELU's factor 1/2
moved into the next layer) and the call itself is a straight line of in-place NumPy calls
on preallocated buffers with every name bound locally (no attribute lookups).
The output array is reused by the next call.

>>> from spectratac.decode.runtime import Runtime
>>> callable(compile_single)
True
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.decode.networks import LN_EPS, SKIP, SQRT_2_OVER_PI

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]


def _aug(wt: F64, b: F64) -> F32:
    """(in + 1, out) float32: weight transposed with the bias as the last row."""
    return np.ascontiguousarray(np.vstack([wt.T, b[None, :]]), np.float32)


def _lin(w: dict[str, Any], name: str, half: bool = False, norm: str | None = None) -> F32:
    wt = w[name + ".weight"].astype(np.float64)
    b = w[name + ".bias"].astype(np.float64)
    if norm is not None:  # W (g n + beta) + b = (W g) n + (W beta + b)
        b = b + wt @ w[norm + ".bias"].astype(np.float64)
        wt = wt * w[norm + ".weight"].astype(np.float64)[None, :]
    if half:  # the previous GELU leaves out its factor 1/2
        wt = wt * 0.5
    return _aug(wt, b)


def compile_single(rt: Any) -> Callable[[Any], F32]:
    if rt.features.M.shape[0] or SKIP in rt.weights:
        return _unfused(rt)
    f32 = np.float32
    fs, w, heads = rt.features, rt.weights, rt.heads
    kind, hidden, blocks = rt.arch
    d = int(rt.center.shape[0])
    n_lin, n_rat = fs.L.shape[0], fs.P.shape[0]
    inv = 1.0 / rt.scaler.std
    first = "head" if kind == "linear" else ("layers.0" if kind == "mlp" else "stem")
    w0 = w[first + ".weight"].astype(np.float64) * inv[None, :]
    b0 = w[first + ".bias"].astype(np.float64) - w0[:, :n_lin] @ rt.scaler.mean[:n_lin]
    # first layer over a = [u - center (D), ratios - their mean (R), 1]
    w_first = _aug(np.hstack([w0[:, :n_lin] @ fs.L, w0[:, n_lin:]]), b0)
    center = rt.center.astype(f32)
    p_t = np.ascontiguousarray(fs.P.T, f32)
    q_t = np.ascontiguousarray(fs.Q.T, f32)
    rat_mean = rt.scaler.mean[n_lin:].astype(f32)
    a = np.ones(d + n_rat + 1, f32)
    a_u, a_r = a[:d], a[d : d + n_rat]
    au = np.empty(d, f32)
    den = np.empty(n_rat, f32)
    eps = f32(1e-5)
    h0 = w_first.shape[1]
    h = np.empty(h0, f32)
    width = max(hidden, 1)
    nb = np.ones(width + 1, f32)  # normalised / hidden activations, trailing 1 for the bias
    n_ = nb[:width]
    t = np.empty(max(width, h0), f32)
    ones = np.ones(width, f32)
    inv_w = 1.0 / width
    ln_eps = LN_EPS
    c1 = f32(0.044715 * SQRT_2_OVER_PI)
    c2 = f32(SQRT_2_OVER_PI)
    one, half_ = f32(1.0), f32(0.5)
    layers: list[F32] = []
    head = np.zeros((0, 0), f32)
    if kind == "mlp":
        layers = [_lin(w, f"layers.{i}", half=True) for i in range(1, blocks)]
        head = _lin(w, "head", half=blocks > 0)
    elif kind == "resmlp":
        for i in range(blocks):
            p = f"blocks.{i}."
            layers += [_lin(w, p + "fc1", norm=p + "norm"), _lin(w, p + "fc2", half=True)]
        head = _lin(w, "head", norm="norm")
    raw = np.empty(heads.n_out, f32)
    out = np.empty(heads.n_out, f32)
    sl = heads.slices()
    tg, sd, cl, ct = sl["targets"], sl["std"], sl["classes"], sl["contact"]
    y_scale = rt.y_scale.astype(f32)
    std_mul = (rt.y_scale * rt.std_scale).astype(f32)
    o_t, o_s, o_c = out[tg], out[sd], out[cl]
    r_t, r_s, r_c, r_k = raw[tg], raw[sd], raw[cl], raw[ct]
    has_std, has_cls, has_ct = heads.uncertainty, heads.n_classes > 0, heads.contact
    k_ct = ct.start
    dot, add, sub, mul, tanh, divide, absolute, exp = (
        np.dot, np.add, np.subtract, np.multiply, np.tanh, np.divide, np.abs, np.exp,
    )  # fmt: skip
    sqrt = np.sqrt

    def gelu2(x: F32, tmp: F32) -> None:  # x <- 2 GELU(x)
        mul(x, x, out=tmp)
        mul(tmp, c1, out=tmp)
        add(tmp, c2, out=tmp)
        mul(tmp, x, out=tmp)
        tanh(tmp, out=tmp)
        add(tmp, one, out=tmp)
        mul(x, tmp, out=x)

    def norm(x: F32) -> None:  # n_ <- LayerNorm(x) without affine (folded)
        sub(x, dot(x, ones) * inv_w, out=n_)
        mul(n_, 1.0 / sqrt(dot(n_, n_) * inv_w + ln_eps), out=n_)

    pairs = [(layers[2 * i], layers[2 * i + 1]) for i in range(blocks)] if kind == "resmlp" else []

    def run1(u: Any) -> F32:
        v = np.asarray(u, f32)
        sub(v, center, out=a_u)
        if n_rat:
            absolute(v, out=au)
            dot(au, q_t, out=den)
            add(den, eps, out=den)
            divide(dot(v, p_t), den, out=a_r)
            sub(a_r, rat_mean, out=a_r)
        dot(a, w_first, out=h)
        if kind == "resmlp":
            gelu2(h, t)
            mul(h, half_, out=h)
            for w1, w2 in pairs:
                norm(h)
                dot(nb, w1, out=n_)
                gelu2(n_, t)
                add(h, dot(nb, w2), out=h)
            norm(h)
            dot(nb, head, out=raw)
        elif kind == "mlp":
            x = h
            gelu2(x, t[: x.shape[0]])
            for wl in layers:
                nb[: x.shape[0]] = x
                x = dot(nb, wl)
                gelu2(x, t)
            if blocks:
                nb[:width] = x
                dot(nb, head, out=raw)
            else:
                raw[:] = x
        else:
            raw[:] = h
        mul(r_t, y_scale, out=o_t)
        if has_std:
            exp(r_s, out=o_s)
            mul(o_s, std_mul, out=o_s)
        if has_cls:
            sub(r_c, r_c.max(), out=o_c)
            exp(o_c, out=o_c)
            divide(o_c, o_c.sum(), out=o_c)
        if has_ct:
            out[k_ct] = half_ * (one + tanh(half_ * r_k[0]))
        return out

    return run1


def _unfused(rt: Any) -> Callable[[Any], F32]:
    """The batch path on one row, for polynomial features (their products cannot be folded
    into the first layer; a polynomial ridge is one small matrix product anyway) and for a
    linear skip (a second path from the features the fused plan does not carry)."""
    rt32 = rt.with_dtype(np.float32)
    out = np.empty(rt.heads.n_out, np.float32)

    def run1(u: Any) -> F32:
        out[:] = rt32.run(np.asarray(u, np.float64)[None, :])[0]
        return out

    return run1
