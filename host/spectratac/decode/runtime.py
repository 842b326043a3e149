"""The stateless NumPy runtime: assembled input vector -> physical outputs, without torch.

A `Runtime` holds everything after assembly: feature set, normalisation, network weights,
head layout and output scales. It is what every export computes and what the NumPy runtime
file stores (`save`/`load`: one .npz with a JSON header, readable with NumPy alone).

`run(U)` decodes a batch in the runtime's dtype (the reference path). `run1(u)` decodes one
vector through a fused plan (normalisation and LayerNorm affines folded into the following
layer, GELU's 1/2 folded forward, preallocated float32 buffers) for low single-sample latency;
tests check it against `run`.

>>> from spectratac.decode.layout import Layout
>>> from spectratac.decode.feature_matrices import build_features
>>> from spectratac.decode.heads import Heads
>>> from spectratac.decode.networks import init_weights
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
import threading
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.bounds import loads_bounded
from spectratac.decode.errors import DecoderFileError
from spectratac.decode.feature_matrices import FeatureSet
from spectratac.decode.heads import Heads, postprocess
from spectratac.decode.networks import (
    SKIP,
    Arch,
    Weights,
    forward,
    layer_shapes,
    norm_names,
)
from spectratac.decode.scaling import Standardizer

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]
RUNTIME_FORMAT = "spectratac.runtime"
RUNTIME_VERSION = 1
ARCH_KINDS = ("linear", "mlp", "resmlp")


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
    # fused plans by thread: a plan's buffers are scratch space, so two threads decoding with
    # one runtime (two streams of one model, a bench's three joins) each need their own; not
    # an __init__ field, so every `replace` (new weights, dtype, scales) starts without plans
    _plans: threading.local = field(
        default_factory=threading.local, init=False, repr=False, compare=False
    )

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
        return replace(self, dtype=dtype)

    def set_weights(self, weights: Weights) -> None:
        """New weights in place (training's last step); plans compiled before are dropped."""
        self.weights = weights
        self._plans = threading.local()

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without its compiled plans (closures; rebuilt on first use)."""
        return {k: v for k, v in self.__dict__.items() if k != "_plans"}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state, _plans=threading.local())

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

        The returned array is reused by the next call in the same thread: copy it to keep
        it. Each thread has its own plan, so threads never write into each other's buffers.
        """
        plan = getattr(self._plans, "plan", None)
        if plan is None:
            from spectratac.decode.fused import compile_single

            plan = self._plans.plan = compile_single(self)
        return plan(u)

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
            {k: arrays[f"feat/{k}"] for k in ("L", "P", "Q", "M") if f"feat/{k}" in arrays},
            header["feature_names"],
        )
        arch = (str(header["arch"][0]), int(header["arch"][1]), int(header["arch"][2]))
        runtime = cls(
            feats,
            arrays["center"],
            Standardizer(arrays["f_mean"], arrays["f_std"]),
            arch,
            {k: arrays[f"w/{k}"] for k in header["weights"]},
            Heads.from_dict(header["heads"]),
            arrays["y_scale"],
            arrays["std_scale"],
        )
        runtime.validate()
        return runtime

    def validate(self) -> None:
        """Raise DecoderFileError unless every array has the shape the architecture needs
        and holds only finite numbers (checked at load, not at the first prediction)."""
        d, f = self.n_inputs, self.features.n_features
        want: dict[str, tuple[int, ...]] = {
            "center": (d,),
            "feat/L": (self.features.L.shape[0], d),
            "feat/P": (self.features.P.shape[0], d),
            "feat/Q": (self.features.P.shape[0], d),
            "f_mean": (f,),
            "f_std": (f,),
            "y_scale": (self.heads.n_reg,),
            "std_scale": (self.heads.n_reg,),
        }
        damaged = "the file is damaged: retrain or re-copy it"
        if self.arch[0] not in ARCH_KINDS:
            raise DecoderFileError(f"unknown architecture {self.arch[0]!r}; {damaged}")
        # every block has its weights in the file: a larger count (a damaged number) would
        # have the shape check below list billions of layers before it found one missing
        if not 0 <= self.arch[2] <= len(self.weights) or self.arch[1] < 0:
            raise DecoderFileError(
                f"architecture {self.arch!r} does not fit the {len(self.weights)} weight "
                f"arrays in the file; {damaged}"
            )
        mon = self.features.M
        if mon.shape[0]:
            want["feat/M"] = (mon.shape[0], mon.shape[1])
            if mon.shape[1] != 3 or np.any(mon < -1) or np.any(mon >= self.features.n_base):
                raise DecoderFileError(f"monomial factor indices out of range; {damaged}")
        for name, o, i in layer_shapes(self.arch, f, self.heads.n_out):
            want[f"w/{name}.weight"], want[f"w/{name}.bias"] = (o, i), (o,)
        for name in norm_names(self.arch):
            want[f"w/{name}.weight"] = want[f"w/{name}.bias"] = (self.arch[1],)
        if SKIP in self.weights:
            want[f"w/{SKIP}"] = (self.heads.n_out, f)
        have = {f"w/{k}": v for k, v in self.weights.items()}
        have.update({f"feat/{k}": v for k, v in self.features.to_arrays().items()})
        have.update(center=self.center, f_mean=self.scaler.mean, f_std=self.scaler.std,
                    y_scale=self.y_scale, std_scale=self.std_scale)  # fmt: skip
        if len(self.features.names) != f:
            raise DecoderFileError(
                f"{len(self.features.names)} feature names for {f} features; {damaged}"
            )
        for key, shape in want.items():
            a = have.get(key)
            if a is None:
                raise DecoderFileError(f"array {key!r} is missing; {damaged}")
            if a.shape != shape:
                raise DecoderFileError(
                    f"array {key!r} has shape {a.shape}, expected {shape}; {damaged}"
                )
            if not np.issubdtype(a.dtype, np.number) or not np.all(np.isfinite(a)):
                raise DecoderFileError(f"array {key!r} holds NaN or inf values; {damaged}")

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
        try:
            header = loads_bounded(str(arrays.pop("header")), what=f"{path}: header")
            return cls.from_parts(header, arrays)
        except DecoderFileError as exc:
            raise DecoderFileError(f"{path}: {exc}") from None
        except (KeyError, IndexError, ValueError, TypeError, AttributeError) as exc:
            raise DecoderFileError(f"{path} is damaged ({exc!r}): re-export it") from None
