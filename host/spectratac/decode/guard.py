"""Out-of-distribution guard: flags samples a decoder was not trained to handle.

A sample is out of distribution when any current input lies outside the training range
widened by MARGIN of its span, when a channel is saturated (counts at the 16-bit limit, or
the device's status says so), when a SpectraTac sensor is dark (Clear below DARK_COUNTS),
when its distance from the training inputs (Mahalanobis, whitened by their covariance)
exceeds DIST_MARGIN x the DIST_QUANTILE of the training rows' distances, or when a decoded
target lies outside its training range widened the same way, or at the
edge of it: within EDGE of the span from the training extreme that lies away from zero (a
network saturates there, so a load beyond the training range reads as one at its edge).
A decoder trained under a gain (`TrainSpec.gain_jitter` g) was taught to read inputs scaled
by 1 - g ... 1 + g: its guard is fitted on the training inputs at those gains too, so a unit
whose optical gain differs by less than g is not flagged for that alone (`Guard.fit`'s gain).

Bounds: inputs are clipped to INPUT_SPANS spans around their training range before decoding
(an input of 1e30 overflows float32 features to NaN) and targets to one span beyond their
widened range (`bound_inputs`, `bound_targets`): estimates stay finite and bounded, and such
rows are flagged by `check` anyway.

>>> g = Guard.fit(np.array([[0.0, 10.0], [1.0, 20.0]]), np.array([[0.0], [2.0]]))
>>> g.check(np.array([[0.5, 15.0], [0.5, 40.0]]), np.array([[1.0], [1.0]])).tolist()
[False, True]
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.hardware.generated import veml3328

F64 = NDArray[np.float64]
MARGIN = 0.10
SATURATION = float(veml3328.FULL_SCALE)  # the VEML3328's largest count: clipped
DARK_COUNTS = 20.0
DARK_CHANNEL = "C"  # the channel checked for darkness: Clear, the sum of the colours
# SENSOR_SATURATED | SENSOR_BUS_FAULT | SENSOR_STALE | SENSOR_ABSENT
STATUS_BAD = 0x0F
EDGE = 0.05  # outputs this close (fraction of the span) to a training extreme are flagged
EDGE_MIN_REACH = 0.25  # ... when that extreme lies at least this far (of the span) from zero
INPUT_SPANS = 10.0  # inputs are clipped this many spans beyond their training range
NO_EDGE = 1e30  # the edge bound of a target without one


@dataclass
class Guard:
    in_lo: F64
    in_hi: F64
    t_lo: F64
    t_hi: F64
    saturation: float | None = None  # inputs at or above this are saturated
    dark_cols: list[int] = field(default_factory=list)  # columns that must not be dark
    # Distance in input space: rows whose whitened distance from the training mean exceeds
    # dist_max are flagged (None in models saved before it: no distance check).
    center: F64 | None = None  # (B,)
    whiten: F64 | None = None  # (B, B): (x - center) @ whiten has identity covariance
    dist_max: F64 | None = None  # (1,)

    @classmethod
    def fit(
        cls,
        x: F64,
        y: F64,
        saturation: float | None = None,
        dark_cols: list[int] | None = None,
        gain: float = 0.0,
    ) -> Guard:
        """The guard of training inputs x (N, B) and targets y (N, R); with `gain` g > 0
        the inputs' range and distance model also cover x scaled by 1 - g and 1 + g.

        >>> x, y = np.array([[10.0, 20.0], [20.0, 10.0], [15.0, 15.0]]), np.zeros((3, 1))
        >>> [bool(Guard.fit(x, y, gain=g).check(1.12 * x[:1])[0]) for g in (0.0, 0.15)]
        [True, False]
        """

        def rng(a: F64) -> tuple[F64, F64]:
            if a.shape[0] == 0:
                return np.full(a.shape[1], -np.inf), np.full(a.shape[1], np.inf)
            lo, hi = np.nanmin(a, axis=0), np.nanmax(a, axis=0)
            span = np.maximum(hi - lo, 1e-9 * np.maximum(np.abs(hi), 1.0))
            return lo - MARGIN * span, hi + MARGIN * span

        x = np.asarray(x, np.float64)
        if not 0.0 <= gain < 1.0:
            raise ValueError(f"guard gain {gain}: use 0 <= gain < 1 (TrainSpec.gain_jitter)")
        if gain > 0:  # the network was trained on these scalings: they are in distribution
            x = np.concatenate([(1.0 - gain) * x, x, (1.0 + gain) * x])
        in_lo, in_hi = rng(x)
        t_lo, t_hi = rng(np.asarray(y, np.float64))
        g = cls(in_lo, in_hi, t_lo, t_hi, saturation, list(dark_cols or []))
        ok = np.all(np.isfinite(x), axis=1)
        if ok.sum() > 2 * x.shape[1] + 1:
            g.center, g.whiten, g.dist_max = _distance_model(x[ok])
        return g

    def check(self, x: F64, y: F64 | None = None, status: NDArray[Any] | None = None) -> NDArray:
        """(N,) True where a row of current inputs x (N, B) or targets y (N, R) is OOD."""
        with np.errstate(invalid="ignore"):
            bad = np.any((x < self.in_lo) | (x > self.in_hi), axis=1)
            if self.saturation is not None:
                bad |= np.any(x >= self.saturation, axis=1)
            if self.dark_cols:
                bad |= np.any(x[:, self.dark_cols] < DARK_COUNTS, axis=1)
            if y is not None and y.shape[1]:
                bad |= np.any((y < self.t_lo) | (y > self.t_hi), axis=1)
            if y is not None and y.shape[1]:
                bad |= self.at_edge(y)
            if self.center is not None and self.whiten is not None and self.dist_max is not None:
                d = np.linalg.norm((x - self.center) @ self.whiten, axis=1)
                bad |= ~(d <= self.dist_max[0])
        if status is not None:
            st = np.asarray(status).reshape(x.shape[0], -1)
            bad |= np.any(st & STATUS_BAD, axis=1)
        return bad

    def _raw_targets(self) -> tuple[F64, F64, F64]:
        """The training targets' (min, max, span), undoing the MARGIN widening."""
        wide = np.asarray(self.t_hi, np.float64) - np.asarray(self.t_lo, np.float64)
        span = wide / (1 + 2 * MARGIN)
        return self.t_lo + MARGIN * span, self.t_hi - MARGIN * span, span

    def edge_bounds(self) -> tuple[F64, F64]:
        """(lo, hi) per target: a target <= lo or >= hi is at (or beyond) the edge of the
        training targets: within EDGE of the span from an extreme that lies at least
        EDGE_MIN_REACH of the span away from zero (so rest, near zero, is never an edge);
        NO_EDGE (+-1e30, a finite value every export can hold) where there is none."""
        lo, hi, span = self._raw_targets()
        with np.errstate(invalid="ignore"):
            reach_hi = np.isfinite(hi) & (hi >= EDGE_MIN_REACH * span)
            reach_lo = np.isfinite(lo) & (lo <= -EDGE_MIN_REACH * span)
            e_lo = np.where(reach_lo, lo + EDGE * span, -NO_EDGE)
            e_hi = np.where(reach_hi, hi - EDGE * span, NO_EDGE)
        return e_lo, e_hi

    def on_device(self) -> Guard:
        """The checks an on-device model image carries (input and target ranges, saturation,
        dark inputs, sensor status): the distance model and the edge band stay on the host,
        so the device flags a little less than the host does. The reference its flags match."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return _DeviceGuard(**values | {"center": None, "whiten": None, "dist_max": None})

    def at_edge(self, y: F64) -> NDArray[np.bool_]:
        """(N,) True where a target is at the edge of the training targets (`edge_bounds`)."""
        e_lo, e_hi = self.edge_bounds()
        with np.errstate(invalid="ignore"):
            return np.any((y <= e_lo) | (y >= e_hi), axis=1)

    def bound_inputs(self, u: F64) -> F64:
        """Assembled vectors (N, D) clipped to INPUT_SPANS spans around the training range of
        the current inputs (every block of `u` holds the same channels: context, baseline)."""
        lo, hi = np.asarray(self.in_lo, np.float64), np.asarray(self.in_hi, np.float64)
        if not (np.isfinite(lo).all() and np.isfinite(hi).all()) or u.shape[-1] % lo.size:
            return u
        span = hi - lo
        reps = u.shape[-1] // lo.size
        return np.clip(u, np.tile(lo - INPUT_SPANS * span, reps),
                       np.tile(hi + INPUT_SPANS * span, reps))  # fmt: skip

    def bound_targets(self, y: F64) -> F64:
        """Targets (N, R) clipped to one span beyond their widened training range."""
        lo, hi = np.asarray(self.t_lo, np.float64), np.asarray(self.t_hi, np.float64)
        span = hi - lo
        return np.clip(y, lo - span, hi + span)

    def arrays(self) -> dict[str, F64]:
        a = {"in_lo": self.in_lo, "in_hi": self.in_hi, "t_lo": self.t_lo, "t_hi": self.t_hi}
        if self.center is not None and self.whiten is not None and self.dist_max is not None:
            a.update(center=self.center, whiten=self.whiten, dist_max=self.dist_max)
        return a

    def header(self) -> dict[str, Any]:
        return {"saturation": self.saturation, "dark_cols": self.dark_cols}

    def validate(self, n_inputs: int, n_targets: int) -> None:
        """ValueError unless the ranges fit `n_inputs` current inputs and `n_targets` targets
        and hold no NaN (a NaN bound would silently never flag anything)."""
        for name, n in (("in_lo", n_inputs), ("in_hi", n_inputs), ("t_lo", n_targets),
                        ("t_hi", n_targets)):  # fmt: skip
            a = np.asarray(getattr(self, name))
            if a.shape != (n,) or not np.issubdtype(a.dtype, np.number) or np.isnan(a).any():
                raise ValueError(f"guard range {name} is {a.shape} {a.dtype}; expected ({n},)")
        if self.center is not None and (
            np.shape(self.center) != (n_inputs,)
            or np.shape(self.whiten) != (n_inputs, n_inputs)
            or np.shape(self.dist_max) != (1,)
        ):
            raise ValueError(f"guard distance model does not fit {n_inputs} inputs")
        if any(not 0 <= c < n_inputs for c in self.dark_cols):
            raise ValueError(f"guard dark_cols {self.dark_cols} outside 0..{n_inputs - 1}")

    @classmethod
    def from_parts(cls, header: dict[str, Any], arrays: dict[str, F64]) -> Guard:
        return cls(
            arrays["in_lo"],
            arrays["in_hi"],
            arrays["t_lo"],
            arrays["t_hi"],
            header.get("saturation"),
            list(header.get("dark_cols", [])),
            arrays.get("center"),
            arrays.get("whiten"),
            arrays.get("dist_max"),
        )


DIST_QUANTILE = 0.995  # of the training rows' distances ...
DIST_MARGIN = 1.10  # ... widened by this factor: the distance beyond which a row is flagged


def _distance_model(x: F64) -> tuple[F64, F64, F64]:
    """(center, whitening matrix, flag distance) of training inputs x (N, B): a Mahalanobis
    distance, regularised so that a channel constant in training does not divide by 0."""
    center = x.mean(axis=0)
    cov = np.atleast_2d(np.cov(x.T))
    ridge = 1e-6 * max(float(np.trace(cov)) / cov.shape[0], 1e-12)
    chol = np.linalg.cholesky(cov + ridge * np.eye(cov.shape[0]))
    whiten = np.linalg.inv(chol).T
    d = np.linalg.norm((x - center) @ whiten, axis=1)
    return center, whiten, np.array([DIST_MARGIN * float(np.quantile(d, DIST_QUANTILE))])


class _DeviceGuard(Guard):
    """`Guard.on_device`: no edge band (the model image has no room for it)."""

    def at_edge(self, y: F64) -> NDArray[np.bool_]:
        return np.zeros(np.asarray(y).shape[0], dtype=bool)
