"""The dataset file: aligned arrays plus metadata, one `.npz` (the contract between recording,
training and evaluation).

One row per optical sample. Arrays (N rows):

============== =============== =========================================================
key            dtype, shape    meaning
============== =============== =========================================================
inputs         f8 (N, C)       decoder inputs, named by ``meta["input_names"]``; for
                               SpectraTac: R, G, B, C of sensors 0, 1, 2 (``s0.R`` …)
targets        f8 (N, T)       named by ``meta["target_names"]`` (Fx Fy Fz in N, Tx Ty Tz
                               in N·m); NaN where the reference had no data
target_valid   bool (N,)       False where a target is NaN (F/T dropout): never filled in
region         i1 (N,)         contact region 1..9; -1 for none, too light, or unlabelled
in_contact     bool (N,)       the reference says something touches the skin
t_start, t_end f8 (N,)         integration window in host time (s, aligned clock)
step           i2 (N,)         LED step that lit the sample
config_id      u2 (N,)         device configuration id of the sample
session        i2 (N,)         index into ``meta["sessions"]``
press          i4 (N,)         press id within the dataset; -1 between presses
counts         u2 (N, 3, 5)    SpectraTac only: raw counts (R, G, B, C, IR per sensor)
status         u1 (N, 3)       SpectraTac only: SENSOR_* status bits per sensor
sequence       u4 (N,)         recorded only: the device's sample sequence number
device_time_us i8 (N,)         recorded only: integration end on the device clock (µs)
ft_count       u4 (N,)         recorded only: F/T samples averaged into the targets
============== =============== =========================================================

Optional arrays (counts onwards) that only some datasets have are dropped when joining.

``meta`` (stored as one JSON string) holds ``format`` ("spectratac.dataset"), ``version``,
``kind`` ("spectratac" or "generic"), ``input_names``, ``target_names``, ``unit_id``,
``firmware_version``, ``protocol_version``, ``definition_hash``, ``config`` (integration_ms,
gain, digital_gain, sensitivity, leds as permille steps × 3 LEDs × RGB, settle_us; null for
generic data), ``sessions`` (one dict each: source, scene, seed, ft_url, …) and
``labels`` (where region labels came from: "scene", "guided" or "none"); recorded datasets
add ``force_targets`` ("reference", or "none": recorded without a reference F/T, every target
NaN and target_valid false: region labels only, for `train --finetune`).

>>> import numpy as np
>>> ds = Dataset.generic(np.ones((4, 2)), np.zeros((4, 1)), ["a", "b"], ["Fz"])
>>> ds.n, ds.meta["input_names"], ds.targets.shape
(4, ['a', 'b'], (4, 1))
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.bounds import loads_bounded
from spectratac.dataset.npz_file import NpzDamageError, read_npz
from spectratac.errors import SpectraTacError
from spectratac.hardware.generated import vocabulary as vocab

FORMAT = "spectratac.dataset"
VERSION = 1
FT_NAMES = vocab.FT_AXES  # a SpectraTac dataset's targets
SPECTRATAC_INPUTS = vocab.DECODED_INPUTS  # and its inputs

#: key -> (dtype, trailing shape or None for "any width"); required keys first
COLUMNS: dict[str, tuple[str, tuple[int, ...] | None]] = {
    "inputs": ("<f8", None),
    "targets": ("<f8", None),
    "target_valid": ("|b1", ()),
    "region": ("|i1", ()),
    "in_contact": ("|b1", ()),
    "t_start": ("<f8", ()),
    "t_end": ("<f8", ()),
    "step": ("<i2", ()),
    "config_id": ("<u2", ()),
    "session": ("<i2", ()),
    "press": ("<i4", ()),
    "counts": ("<u2", (3, 5)),
    "status": ("|u1", (3,)),
    "sequence": ("<u4", ()),
    "device_time_us": ("<i8", ()),
    "ft_count": ("<u4", ()),
}
OPTIONAL = ("counts", "status", "sequence", "device_time_us", "ft_count")


class DatasetError(SpectraTacError):
    """A dataset file or array is malformed, or datasets cannot be combined."""


@dataclass
class Dataset:
    arrays: dict[str, NDArray[Any]]
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.validate()

    # ------------------------------------------------------------------ access
    @property
    def n(self) -> int:
        return int(self.arrays["inputs"].shape[0])

    def __len__(self) -> int:
        return self.n

    def __getattr__(self, name: str) -> NDArray[Any]:
        arrays = self.__dict__.get("arrays", {})
        if name in arrays:
            return arrays[name]
        raise AttributeError(name)

    @property
    def input_names(self) -> list[str]:
        return list(self.meta["input_names"])

    @property
    def target_names(self) -> list[str]:
        return list(self.meta["target_names"])

    def press_count(self) -> int:
        """Presses the dataset holds: distinct press ids with at least one row (ids of
        presses whose rows were all lost leave gaps, so the largest id + 1 overcounts)."""
        press = self.arrays["press"]
        return int(np.unique(press[press >= 0]).size)

    def span_s(self) -> float:
        """Seconds of the sensor's clock the rows cover, summed over sessions. Recorded
        datasets count on the device clock (`device_time_us`): host times of a simulated
        device recorded at speed=10 are compressed tenfold. Steps back of the device clock (a
        reconnect restarted it) are skipped; gaps of lost samples count as time."""
        a = self.arrays
        total = 0.0
        for s in np.unique(a["session"]):
            rows = a["session"] == s
            if "device_time_us" in a:
                t_end = a["device_time_us"][rows].astype(np.float64) / 1e6
                steps = np.diff(t_end)
                total += float(steps[steps > 0].sum()) + self._window_s()
            else:
                total += float(a["t_end"][rows].max() - a["t_start"][rows].min())
        return total

    def _window_s(self) -> float:
        """One integration window on the device clock (0 when the config does not say)."""
        cfg = self.meta.get("config")
        ms = cfg.get("integration_ms") if isinstance(cfg, dict) else None
        return float(ms) / 1000.0 if isinstance(ms, (int, float)) else 0.0

    def subset(self, rows: NDArray[Any] | slice) -> Dataset:
        """The rows selected by a boolean mask, index array or slice (metadata shared)."""
        return Dataset({k: v[rows] for k, v in self.arrays.items()}, dict(self.meta))

    # ------------------------------------------------------------------ checks
    def validate(self) -> None:
        a = self.arrays
        missing = [k for k in COLUMNS if k not in a and k not in OPTIONAL]
        if missing:
            raise DatasetError(f"dataset lacks arrays {missing}; see spectratac.dataset.schema")
        n = a["inputs"].shape[0]
        for key, (dtype, tail) in COLUMNS.items():
            if key not in a:
                continue
            arr = np.asarray(a[key])
            if arr.dtype != np.dtype(dtype):
                a[key] = arr = arr.astype(dtype)
            want_ndim = 2 if tail is None else 1 + len(tail)
            if arr.shape[0] != n or arr.ndim != want_ndim or (tail and arr.shape[1:] != tail):
                raise DatasetError(
                    f"array {key!r} has shape {arr.shape}; expected ({n}"
                    + (", …)" if tail is None else "".join(f", {d}" for d in tail) + ")")
                )
        for key, names in (("inputs", "input_names"), ("targets", "target_names")):
            if len(self.meta.get(names, ())) != a[key].shape[1]:
                raise DatasetError(
                    f"meta[{names!r}] names {len(self.meta.get(names, ()))} columns but "
                    f"{key!r} has {a[key].shape[1]}"
                )
        self.meta.setdefault("format", FORMAT)
        self.meta.setdefault("version", VERSION)

    # ------------------------------------------------------------------ files
    def save(self, path: str | Path) -> Path:
        """Write a compressed .npz (arrays plus the JSON metadata). The file appears under
        its name only once complete: a crash while writing leaves no half-written dataset."""
        path = Path(path)
        final = path if path.suffix == ".npz" else path.with_suffix(path.suffix + ".npz")
        tmp = final.with_name(final.name + ".tmp")
        try:
            with open(tmp, "wb") as f:
                np.savez_compressed(f, meta=np.array(json.dumps(self.meta)), **self.arrays)
            tmp.replace(final)
        finally:
            tmp.unlink(missing_ok=True)
        return final

    @classmethod
    def load(cls, path: str | Path) -> Dataset:
        """Read a dataset file; raises DatasetError saying what is wrong with it."""
        try:
            arrays = read_npz(path)
            meta_text = arrays.pop("meta", None)
            meta = loads_bounded(str(meta_text), what="its meta") if meta_text is not None else None
        except (NpzDamageError, ValueError) as exc:  # ValueError: meta is not JSON or too deep
            raise DatasetError(f"cannot read dataset {path}: {exc}") from None
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise DatasetError(
                f"{path} is not a SpectraTac dataset (no meta with format {FORMAT!r}); build "
                f"one with `spectratac dataset build`"
            )
        version = meta.get("version", 0)
        if not isinstance(version, int):
            raise DatasetError(f"{path}: meta version {version!r} is not a whole number")
        if version > VERSION:
            raise DatasetError(
                f"{path} is dataset version {meta['version']}; this library reads up to "
                f"{VERSION}: update spectratac"
            )
        for names in ("input_names", "target_names"):
            value = meta.get(names)
            if not isinstance(value, list) or not all(isinstance(n, str) for n in value):
                raise DatasetError(
                    f"{path}: meta[{names!r}] is {value!r}, not a list of column names; the "
                    f"file is damaged: rebuild it with `spectratac dataset build`"
                )
        if not all(isinstance(a, np.ndarray) and a.ndim >= 1 for a in arrays.values()):
            raise DatasetError(f"{path}: an array is a bare scalar; the file is damaged")
        try:
            return cls(arrays, meta)
        except (ValueError, TypeError, OverflowError) as exc:  # e.g. text where numbers belong
            raise DatasetError(f"{path}: arrays do not fit the dataset schema ({exc})") from None

    # ------------------------------------------------------------------ building
    @classmethod
    def generic(
        cls,
        inputs: NDArray[Any],
        targets: NDArray[Any],
        input_names: Sequence[str],
        target_names: Sequence[str],
        *,
        region: NDArray[Any] | None = None,
        t: NDArray[Any] | None = None,
        press: NDArray[Any] | None = None,
        meta: dict[str, Any] | None = None,
    ) -> Dataset:
        """A dataset from any sensor: named input channels, named targets, optional classes."""
        x = np.asarray(inputs, dtype=np.float64)
        y = np.asarray(targets, dtype=np.float64)
        if y.ndim == 1:
            y = y[:, None]
        n = x.shape[0]
        tt = np.arange(n, dtype=np.float64) if t is None else np.asarray(t, dtype=np.float64)
        arrays = {
            "inputs": x,
            "targets": y,
            "target_valid": np.all(np.isfinite(y), axis=1),
            "region": np.full(n, -1) if region is None else np.asarray(region),
            "in_contact": np.zeros(n, bool) if region is None else np.asarray(region) > 0,
            "t_start": tt,
            "t_end": tt,
            "step": np.zeros(n),
            "config_id": np.zeros(n),
            "session": np.zeros(n),
            "press": np.full(n, -1) if press is None else np.asarray(press),
        }
        info = {
            "kind": "generic",
            "input_names": list(input_names),
            "target_names": list(target_names),
            "unit_id": None,
            "config": None,
            "sessions": [{"source": "generic"}],
            "labels": "none" if region is None else "given",
            # in_contact above is a default, not a measurement: scoring contact needs labels
            "contact_labels": "none" if region is None else "from regions",
        }
        return cls(arrays, {**info, **(meta or {})})


def concat(datasets: Sequence[Dataset], *, allow_mixed_config: bool = False) -> Dataset:
    """Join datasets row-wise; session and press ids are renumbered to stay unique.

    Datasets recorded under different sensor configurations (or with different inputs or
    targets) are refused unless `allow_mixed_config`; split them with `split_by_config`.
    """
    if not datasets:
        raise DatasetError("nothing to join: give at least one dataset")
    first = datasets[0].meta
    for ds in datasets[1:]:
        for key in ("input_names", "target_names", "kind"):
            if ds.meta.get(key) != first.get(key):
                raise DatasetError(f"datasets differ in {key}: cannot join them")
        if ds.meta.get("config") != first.get("config") and not allow_mixed_config:
            raise DatasetError(
                "datasets were recorded under different sensor configurations "
                f"({first.get('config')} vs {ds.meta.get('config')}); a decoder is valid for "
                "one configuration: build one dataset per configuration (--split)"
            )
    arrays: dict[str, list[NDArray[Any]]] = {
        k: []
        for k in datasets[0].arrays
        if k not in OPTIONAL or all(k in ds.arrays for ds in datasets)
    }
    sessions: list[Any] = []
    press_base = 0
    for ds in datasets:
        for k in arrays:
            if k not in ds.arrays:
                raise DatasetError(f"dataset lacks {k!r} that the others have")
            v = ds.arrays[k]
            if k == "session":
                v = v + len(sessions)
            elif k == "press":
                v = np.where(v >= 0, v + press_base, -1)
            arrays[k].append(v)
        sessions += ds.meta.get("sessions", [])
        press_base += int(ds.arrays["press"].max(initial=-1)) + 1
    meta = {**first, "sessions": sessions}
    if allow_mixed_config:
        meta["config"] = [ds.meta.get("config") for ds in datasets]
    return Dataset({k: np.concatenate(v) for k, v in arrays.items()}, meta)


def split_by_config(datasets: Sequence[Dataset]) -> list[Dataset]:
    """Group datasets by sensor configuration and join each group."""
    groups: dict[str, list[Dataset]] = {}
    for ds in datasets:
        groups.setdefault(json.dumps(ds.meta.get("config"), sort_keys=True), []).append(ds)
    return [concat(g) for g in groups.values()]
