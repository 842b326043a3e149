"""What a decoder returns: `Estimates` for many rows, `Estimate` for one live sample.

Columns a decoder was not trained for are NaN (force, torque, std) or their neutral value
(region -1 and region_prob NaN without a class head; contact_prob NaN without a contact
head, contact then derived from the force magnitude when forces are decoded).

>>> e = Estimates.empty(("Fz",), 2)
>>> e.force.shape, bool(np.isnan(e.force[0, 0])), e.region.tolist()
((2, 3), True, [-1, -1])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.hardware.generated import vocabulary as vocab
from spectratac.protocol.generated.messages import EstimateFlags

CONTACT_FORCE_N = 0.3  # |F| above which a decoder without a contact head reports contact

F64 = NDArray[np.float64]
FORCE = vocab.FORCE_AXES
TORQUE = vocab.TORQUE_AXES


def interval_factor(level: float) -> float:
    """Half-width of the central `level` interval in units of the predicted std.

    The uncertainty head models each error as Laplace (its training loss is the Laplace
    likelihood, and it is calibrated so that E|e| = std / sqrt(2)): P(|e| <= k std) =
    1 - exp(-sqrt(2) k). Its tails are heavier than a Gaussian's: the 68 % interval is
    narrower (0.81 std, not 1.0) and the 95 % one wider (2.12, not 1.96).

    >>> round(interval_factor(0.68), 3), round(interval_factor(0.95), 3)
    (0.806, 2.118)
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level={level}: give a probability in (0, 1), e.g. 0.95")
    return float(-np.log1p(-level) / np.sqrt(2.0))


@dataclass
class Estimates:
    target_names: tuple[str, ...]  # regression targets, columns of `targets`
    targets: F64  # (N, T)
    region: NDArray[np.int64]  # (N,) 1..K, -1 none
    region_prob: F64  # (N,) probability of the chosen region
    contact: NDArray[np.bool_]  # (N,)
    contact_prob: F64  # (N,)
    ood: NDArray[np.bool_]  # (N,) out of distribution: beyond training range, saturated, dark
    invalid: NDArray[np.bool_]  # (N,) NaN/inf inputs or incomplete LED sequence: NaN outputs
    std: F64 | None = None  # (N, T) calibrated standard deviation, if trained for
    region_probs: F64 | None = None  # (N, K) all class probabilities
    # (N,) the drift baseline has not yet seen the skin at rest (joined under load, no tare):
    # forces may be offset until it has; None is all False (no baseline)
    no_rest: NDArray[np.bool_] | None = None

    @classmethod
    def empty(cls, target_names: tuple[str, ...], n: int) -> Estimates:
        nan = np.full(n, np.nan)
        return cls(
            tuple(target_names),
            np.full((n, len(target_names)), np.nan),
            np.full(n, -1, np.int64),
            nan.copy(),
            np.zeros(n, bool),
            nan.copy(),
            np.zeros(n, bool),
            np.zeros(n, bool),
            no_rest=np.zeros(n, bool),
        )

    def __len__(self) -> int:
        return int(self.targets.shape[0])

    def column(self, name: str) -> F64:
        """One target's column; NaN if the decoder does not estimate it."""
        if name in self.target_names:
            return self.targets[:, self.target_names.index(name)]
        return np.full(len(self), np.nan)

    def interval(self, level: float = 0.95) -> tuple[F64, F64]:
        """(low, high), each (N, T): the central `level` interval of every target, from the
        calibrated uncertainty head (see `interval_factor`). NaN without one."""
        k = interval_factor(level)
        if self.std is None:
            nan = np.full_like(self.targets, np.nan)
            return nan, nan.copy()
        half = k * self.std
        return self.targets - half, self.targets + half

    def _group(self, names: tuple[str, ...]) -> F64:
        return np.stack([self.column(n) for n in names], axis=1)

    @property
    def force(self) -> F64:
        """(N, 3) Fx, Fy, Fz in N (NaN columns for axes not decoded)."""
        return self._group(FORCE)

    @property
    def torque(self) -> F64:
        """(N, 3) Tx, Ty, Tz in N·m (NaN columns for axes not decoded)."""
        return self._group(TORQUE)


@dataclass(frozen=True)
class Estimate:
    """One live estimate from `Decoder.stream` (decoded on the host, or by the device)."""

    time: float  # host time of the sample (s)
    force: F64  # (3,)
    torque: F64  # (3,)
    region: int
    region_prob: float
    contact: bool
    contact_prob: float
    ood: bool
    invalid: bool
    targets: F64  # (T,) every regression target, in target_names order
    std: F64 | None = None
    no_rest: bool = False  # the drift baseline has not yet seen the skin at rest (see tare)
    # the sample's window end on the sensor's own clock (µs, unwrapped) and its connection
    # epoch: what a duration on the sensor's clock counts, whatever the host's scheduling
    device_time_us: int = 0
    epoch: int = 0

    @classmethod
    def from_device(cls, row: Any, target_names: tuple[str, ...]) -> Estimate:
        """An ESTIMATE the device decoded (an EstimateRow of Sensor.iter_estimates) in host
        terms: region 0 becomes -1, contact, out-of-distribution and no rest yet come from
        EST_* flags, the contact probability and the uncertainty are not sent (NaN, None).

        >>> from types import SimpleNamespace
        >>> nan = float("nan")
        >>> row = SimpleNamespace(host_time=2.5, flags=0b101, force=(nan, nan, 1.5),
        ...                       torque=(nan, nan, nan), region=0, region_prob=nan,
        ...                       device_time_us=50_000, epoch=0)
        >>> e = Estimate.from_device(row, ("Fz",))
        >>> e.targets.tolist(), e.region, e.contact, e.ood, e.invalid, e.no_rest
        ([1.5], -1, True, True, False, False)
        """
        flags = int(row.flags)
        force = np.asarray(row.force, dtype=np.float64)
        torque = np.asarray(row.torque, dtype=np.float64)
        by_name = dict(zip(FORCE + TORQUE, [*force, *torque], strict=True))
        region = int(row.region)
        return cls(
            float(row.host_time),
            force,
            torque,
            region if region else -1,
            float(row.region_prob),
            bool(flags & EstimateFlags.EST_CONTACT),
            float("nan"),
            bool(flags & EstimateFlags.EST_OOD),
            bool(flags & EstimateFlags.EST_INVALID),
            np.array([by_name.get(n, np.nan) for n in target_names], dtype=np.float64),
            no_rest=bool(flags & EstimateFlags.EST_NO_REST),
            device_time_us=int(row.device_time_us),
            epoch=int(row.epoch),
        )
