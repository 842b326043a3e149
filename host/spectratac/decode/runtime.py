"""The stateless NumPy runtime: assembled input vector -> physical outputs, without torch.

A `Runtime` holds everything after assembly: feature set, normalisation, network weights,
head layout and output scales. It is what every export computes and what the NumPy runtime
file stores (`save`/`load`: one .npz with a JSON header, readable with NumPy alone).

`run(U)` decodes a batch in the runtime's dtype (the reference path). `run1(u)` decodes one
vector through a fused plan (normalisation and LayerNorm affines folded into the following
layer, GELU's 1/2 folded forward, preallocated float32 buffers) for low single-sample latency;
tests check it against `run`.

>>> from spectratac.decode.layout import Layout
>>> from spectratac.decode.featureset import build_features
>>> from spectratac.decode.heads import Heads
>>> from spectratac.decode.model import init_weights
>>> fs = build_features("generic", Layout(("a", "b")))
>>> heads = Heads(("Fz",), n_classes=2)
>>> w = init_weights(("resmlp", 8, 1), fs.n_features, heads.n_out, np.random.default_rng(0))
>>> rt = Runtime.create(fs, ("resmlp", 8, 1), w, heads, np.ones((5, 2)))
>>> out = rt.run(np.ones((3, 2)))
>>> out.shape, bool(np.allclose(rt.run1(np.ones(2)), out[0], atol=1e-5))
((3, 3), True)
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.decode.errors import DecoderFileError
from spectratac.decode.featureset import FeatureSet
from spectratac.decode.heads import Heads, postprocess
from spectratac.decode.model import LN_EPS, SQRT_2_OVER_PI, Arch, Weights, forward
from spectratac.decode.scaling import Standardizer

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]
RUNTIME_FORMAT = "spectratac.runtime"
RUNTIME_VERSION = 1


@dataclass
class Runtime:
    features: FeatureSet
    center: F64  # (D,) subtracted from u before the linear features (float32-representable)
    scaler: Standardizer  # over the features
    arch: Arch
    weights: Weights
    heads: Heads
    y_scale: F64  # (R,) zero-anchored target scales
    std_scale: F64  # (R,) post-hoc calibration of the uncertainty head (1 = none)
    dtype: Any = np.float32
    _plan: Any = field(default=None, repr=False)

    # ------------------------------------------------------------------ construction
    @classmethod
    def create(
        cls,
        features: FeatureSet,
        arch: Arch,
        weights: Weights,
        heads: Heads,
        u_train: F64,
        y_scale: F64 | None = None,
    ) -> Runtime:
        """Fit normalisation on training vectors `u_train` (N, D) and wrap the weights."""
        center = np.mean(u_train, axis=0).astype(np.float32).astype(np.float64)
        scaler = Standardizer.fit(features.apply(u_train, center))
        ys = np.ones(heads.n_reg) if y_scale is None else np.asarray(y_scale, np.float64)
        return cls(features, center, scaler, arch, weights, heads, ys, np.ones(heads.n_reg))

    def with_dtype(self, dtype: Any) -> Runtime:
        return replace(self, dtype=dtype, _plan=None)

    @property
    def n_inputs(self) -> int:
        return int(self.center.shape[0])

    # ------------------------------------------------------------------ evaluation
    def normalised(self, u: F64) -> F64:
        """z-scored features (N, F) of assembled vectors, in the runtime dtype."""
        dt = np.dtype(self.dtype).type
        f = self.features.apply(u, self.center, dt)
        return (f - self.scaler.mean.astype(dt)) / self.scaler.std.astype(dt)

    def raw(self, u: F64) -> F64:
        """Raw head values (N, O)."""
        return forward(self.arch, self.weights, self.normalised(u))

    def run(self, u: F64) -> F64:
        """Physical outputs (N, O) for assembled vectors (N, D); NaN rows give NaN rows."""
        u = np.atleast_2d(np.asarray(u, dtype=np.float64))
        with np.errstate(all="ignore"):
            return postprocess(self.heads, self.raw(u), self.y_scale, self.std_scale)

    def run1(self, u: F64) -> F32:
        """Outputs (O,) of one assembled vector through the fused float32 plan.

        The returned array is reused by the next call: copy it to keep it.
        """
        if self._plan is None:
            self._plan = _Plan(self)
        return self._plan(u)

    # ------------------------------------------------------------------ files
    def header(self) -> dict[str, Any]:
        return {
            "format": RUNTIME_FORMAT,
            "version": RUNTIME_VERSION,
            "feature_kind": self.features.kind,
            "feature_names": self.features.names,
            "arch": list(self.arch),
            "heads": self.heads.to_dict(),
            "outputs": self.heads.output_names(),
            "weights": sorted(self.weights),
        }

    def arrays(self) -> dict[str, NDArray[Any]]:
        a: dict[str, NDArray[Any]] = {f"feat/{k}": v for k, v in self.features.to_arrays().items()}
        a.update({f"w/{k}": v for k, v in self.weights.items()})
        a.update(
            center=self.center,
            f_mean=self.scaler.mean,
            f_std=self.scaler.std,
            y_scale=self.y_scale,
            std_scale=self.std_scale,
        )
        return a

    @classmethod
    def from_parts(cls, header: dict[str, Any], arrays: dict[str, NDArray[Any]]) -> Runtime:
        if header.get("format") != RUNTIME_FORMAT:
            raise DecoderFileError("not a SpectraTac runtime: header format missing")
        if int(header.get("version", 0)) > RUNTIME_VERSION:
            raise DecoderFileError(
                f"runtime version {header['version']} is newer than this library reads "
                f"({RUNTIME_VERSION}): update spectratac"
            )
        feats = FeatureSet.from_arrays(
            header["feature_kind"],
            {k: arrays[f"feat/{k}"] for k in ("L", "P", "Q")},
            header["feature_names"],
        )
        arch = (str(header["arch"][0]), int(header["arch"][1]), int(header["arch"][2]))
        return cls(
            feats,
            arrays["center"],
            Standardizer(arrays["f_mean"], arrays["f_std"]),
            arch,
            {k: arrays[f"w/{k}"] for k in header["weights"]},
            Heads.from_dict(header["heads"]),
            arrays["y_scale"],
            arrays["std_scale"],
        )

    def save(self, path: str | Path) -> Path:
        """One .npz: arrays plus the JSON header under key "header"."""
        path = Path(path)
        with open(path, "wb") as f:
            np.savez(f, header=np.array(json.dumps(self.header())), **self.arrays())
        return path

    @classmethod
    def load(cls, path: str | Path | io.BytesIO) -> Runtime:
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
        except (OSError, ValueError, EOFError) as exc:
            raise DecoderFileError(f"cannot read runtime file {path}: {exc}") from None
        if "header" not in arrays:
            raise DecoderFileError(f"{path} is not a SpectraTac runtime file (no header)")
        return cls.from_parts(json.loads(str(arrays.pop("header"))), arrays)


class _Plan:
    """Fused single-sample evaluation with preallocated float32 buffers."""

    def __init__(self, rt: Runtime) -> None:
        f32 = np.float32
        fs, w, heads = rt.features, rt.weights, rt.heads
        kind, hidden, blocks = rt.arch
        n_lin = fs.L.shape[0]
        inv = 1.0 / rt.scaler.std
        first = "head" if kind == "linear" else ("layers.0" if kind == "mlp" else "stem")
        w0 = w[first + ".weight"].astype(np.float64) * inv[None, :]
        b0 = w[first + ".bias"].astype(np.float64) - w0[:, :n_lin] @ rt.scaler.mean[:n_lin]
        self.center = rt.center.astype(f32)
        self.wa_t = np.ascontiguousarray((w0[:, :n_lin] @ fs.L).T, f32)  # (D, H0)
        self.has_rat = fs.P.shape[0] > 0
        self.p_t = np.ascontiguousarray(fs.P.T, f32)
        self.q_t = np.ascontiguousarray(fs.Q.T, f32)
        self.rat_mean = rt.scaler.mean[n_lin:].astype(f32)
        self.wr_t = np.ascontiguousarray(w0[:, n_lin:].T, f32)
        self.b0 = b0.astype(f32)
        self.kind, self.blocks = kind, blocks
        self.uc = np.empty(self.center.shape[0], f32)
        self.au = np.empty_like(self.uc)
        n_rat = fs.P.shape[0]
        self.num = np.empty(n_rat, f32)
        self.den = np.empty(n_rat, f32)
        h0 = w0.shape[0]
        self.h = np.empty(h0, f32)
        self.t = np.empty(max(hidden, h0), f32)
        self.eps = f32(1e-5)
        self.layers: list[tuple[F32, F32]] = []  # weight (in, out) and bias, affines folded
        if kind == "mlp":
            for i in range(1, blocks):
                self.layers.append(self._lin(w, f"layers.{i}", half=True))
            self.head = self._lin(w, "head", half=blocks > 0)
        elif kind == "resmlp":
            for i in range(blocks):
                p = f"blocks.{i}."
                self.layers.append(self._lin(w, p + "fc1", norm=p + "norm"))
                self.layers.append(self._lin(w, p + "fc2", half=True))
            self.head = self._lin(w, "head", norm="norm")
        else:
            self.head = (np.zeros((0, 0), f32), np.zeros(0, f32))
        self.hid = np.empty(hidden, f32)
        self.out_raw = np.empty(heads.n_out, f32)
        self.heads = heads
        self.y_scale = rt.y_scale.astype(f32)
        self.std_mul = (rt.y_scale * rt.std_scale).astype(f32)
        self.sl = heads.slices()
        self.out = np.empty(heads.n_out, f32)

    @staticmethod
    def _lin(w: Weights, name: str, half: bool = False, norm: str | None = None):
        wt = w[name + ".weight"].astype(np.float64)
        b = w[name + ".bias"].astype(np.float64)
        if norm is not None:  # W (g * n + beta) + b = (W g) n + (W beta + b)
            b = b + wt @ w[norm + ".bias"].astype(np.float64)
            wt = wt * w[norm + ".weight"].astype(np.float64)[None, :]
        if half:  # the previous GELU leaves out its factor 1/2
            wt = wt * 0.5
        return np.ascontiguousarray(wt.T, np.float32), b.astype(np.float32)

    def _gelu2(self, x: F32, t: F32) -> None:
        """x <- 2 GELU(x) in place (tanh form)."""
        np.multiply(x, x, out=t)
        t *= np.float32(0.044715 * SQRT_2_OVER_PI)
        t += np.float32(SQRT_2_OVER_PI)
        t *= x
        np.tanh(t, out=t)
        t += np.float32(1.0)
        x *= t

    def _norm(self, h: F32, out: F32) -> None:
        np.subtract(h, h.mean(), out=out)
        var = np.dot(out, out) / np.float32(out.shape[0])
        out *= np.float32(1.0) / np.sqrt(var + np.float32(LN_EPS))

    def __call__(self, u: F64) -> F32:
        f32 = np.float32
        uc, h = self.uc, self.h
        np.subtract(np.asarray(u, f32), self.center, out=uc)
        np.dot(uc, self.wa_t, out=h)
        h += self.b0
        if self.has_rat:
            ua = np.asarray(u, f32)
            np.dot(ua, self.p_t, out=self.num)
            np.abs(ua, out=self.au)
            np.dot(self.au, self.q_t, out=self.den)
            self.den += self.eps
            self.num /= self.den
            self.num -= self.rat_mean
            h += np.dot(self.num, self.wr_t)
        raw = self.out_raw
        if self.kind == "linear":
            raw[:] = h
        elif self.kind == "mlp":
            t = self.t[: h.shape[0]]
            self._gelu2(h, t)
            for wt, b in self.layers:
                x = np.dot(h, wt) + b
                h = x
                self._gelu2(h, self.t[: h.shape[0]])
            if self.blocks:
                np.dot(h, self.head[0], out=raw)
                raw += self.head[1]
            else:
                raw[:] = h
        else:
            t = self.t
            self._gelu2(h, t)
            h *= f32(0.5)
            n, hid = self.hid, self.t
            for i in range(self.blocks):
                (w1, b1), (w2, b2) = self.layers[2 * i], self.layers[2 * i + 1]
                self._norm(h, n)
                np.dot(n, w1, out=hid)
                hid += b1
                self._gelu2(hid, n)
                h += np.dot(hid, w2)
                h += b2
            self._norm(h, n)
            np.dot(n, self.head[0], out=raw)
            raw += self.head[1]
        return self._post(raw)

    def _post(self, raw: F32) -> F32:
        out, sl, heads = self.out, self.sl, self.heads
        np.multiply(raw[sl["targets"]], self.y_scale, out=out[sl["targets"]])
        if heads.uncertainty:
            np.exp(raw[sl["std"]], out=out[sl["std"]])
            out[sl["std"]] *= self.std_mul
        if heads.n_classes:
            c = out[sl["classes"]]
            np.subtract(raw[sl["classes"]], raw[sl["classes"]].max(), out=c)
            np.exp(c, out=c)
            c /= c.sum()
        if heads.contact:
            k = sl["contact"]
            out[k] = np.float32(0.5) * (np.float32(1.0) + np.tanh(np.float32(0.5) * raw[k]))
        return out
