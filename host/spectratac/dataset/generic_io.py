"""Datasets from any sensor: a CSV file or an .npz of named columns -> `Dataset.generic`.

One row per sample, one column per channel or target (see
host/spectratac/decode/DATA_FORMAT.md). Special column names: ``t`` or ``time`` (s, time
order), ``session``, ``press``, ``contact`` (0/1). A class column (e.g. ``position``) is
recognised by a ``:class`` suffix in its name, by being listed in `classes`, by holding
non-numbers, or (a target) by holding only integers with at most MAX_AUTO_CLASSES distinct
values; its labels become 1..K (meta ``region_labels``; empty, ``-1``, ``nan`` or ``none``:
unlabelled). Pass classes=[] to treat no column as a class.
Empty or NaN target cells are dropouts: ``target_valid`` False, never filled in.
Torque columns may be spelled Mx My Mz; they load as Tx Ty Tz, the only name inside.

>>> import io
>>> text = "ch0,ch1,Fz,position\\n1,2,0.5,left\\n3,4,,right\\n5,6,1.5,\\n"
>>> ds = load_table(io.StringIO(text), inputs=["ch0", "ch1"], targets=["Fz", "position"])
>>> ds.input_names, ds.target_names, ds.region.tolist(), ds.target_valid.tolist()
(['ch0', 'ch1'], ['Fz'], [1, 2, -1], [True, False, True])
>>> ds.meta["region_name"], ds.meta["region_labels"]
('position', ['left', 'right'])
"""

from __future__ import annotations

import csv
import io
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.npz_file import NpzDamageError, read_npz
from spectratac.dataset.schema import Dataset, DatasetError
from spectratac.hardware.generated import vocabulary as vocab

SPECIAL = {"t": "t", "time": "t", "session": "session", "press": "press", "contact": "contact"}
UNLABELLED = {"", "-1", "nan", "none", "null"}
MAX_AUTO_CLASSES = 20
KNOWN_TARGETS = set(vocab.FT_AXES)
#: Accepted input spelling of torque columns (and of --inputs/--targets naming them).
TORQUE_SPELLING = {"Mx": "Tx", "My": "Ty", "Mz": "Tz"}
CLASS_SUFFIX = ":class"


def read_columns(source: str | Path | io.TextIOBase) -> dict[str, NDArray[Any]]:
    """Columns of a CSV (header row) or an .npz of equal-length 1-D arrays, as arrays of
    strings (CSV) or their stored dtype (npz)."""
    if isinstance(source, (str, Path)) and str(source).endswith(".npz"):
        try:
            cols = read_npz(source)
        except NpzDamageError as exc:
            raise DatasetError(f"cannot read {source}: {exc}") from None
        bad = [k for k, v in cols.items() if v.ndim != 1]
        if bad:
            raise DatasetError(
                f"{source}: columns {bad} are not 1-D; a generic .npz holds one 1-D array per "
                f"column (see DATA_FORMAT.md), or use a SpectraTac dataset file"
            )
    else:
        try:
            if isinstance(source, (str, Path)):
                raw = Path(source).read_bytes()
                rows = _csv_rows(io.StringIO(raw.decode("utf-8"), newline=""))
            else:
                rows = _csv_rows(source)
        except OSError as exc:
            raise DatasetError(f"cannot read {source}: {exc}") from None
        except UnicodeDecodeError as exc:
            line = exc.object[: exc.start].count(b"\n") + 1
            raise DatasetError(
                f"{source} is not UTF-8 text (byte {exc.object[exc.start]:#04x} on line {line}); "
                f"save it as UTF-8 CSV"
            ) from None
        except csv.Error as exc:
            raise DatasetError(f"{source}: not a readable CSV file ({exc})") from None
        if not rows:
            raise DatasetError(f"{source}: empty file; the first row must name the columns")
        header = [h.strip() for h in rows[0]]
        body = [r for r in rows[1:] if any(c.strip() for c in r)]
        short = [i + 2 for i, r in enumerate(body) if len(r) != len(header)][:5]
        if short:
            raise DatasetError(
                f"{source}: lines {short} have another number of cells than the header "
                f"({len(header)})"
            )
        cols = {h: np.array([r[i].strip() for r in body], dtype=str) for i, h in enumerate(header)}
    lengths = {len(v) for v in cols.values()}
    if len(lengths) > 1:
        raise DatasetError(f"{source}: columns have different lengths {sorted(lengths)}")
    return cols


def _csv_rows(f: Any) -> list[list[str]]:
    return list(csv.reader(line for line in f if not line.startswith("#")))


def _floats(name: str, col: NDArray[Any]) -> NDArray[np.float64]:
    if col.dtype.kind in "fiub":
        return col.astype(np.float64)
    out = np.empty(col.shape[0])
    for i, v in enumerate(col):
        s = str(v).strip()
        try:
            out[i] = float(s) if s else np.nan
        except ValueError:
            raise DatasetError(
                f"column {name!r}, row {i}: {s!r} is not a number (mark class columns with "
                f"'{CLASS_SUFFIX}' or --classes)"
            ) from None
    return out


def _is_text(col: NDArray[Any]) -> bool:
    """Holds a non-number other than an unlabelled marker."""
    return any(not _num(str(v).strip()) for v in col if str(v).strip().lower() not in UNLABELLED)


def _is_class(col: NDArray[Any]) -> bool:
    vals = [str(v).strip().lower() for v in col]
    vals = [v for v in vals if v not in UNLABELLED]
    try:
        nums = np.array([float(v) for v in vals])
    except ValueError:
        return True  # non-numeric labels
    return bool(nums.size and np.all(nums == np.round(nums)) and len(set(nums)) <= MAX_AUTO_CLASSES)


def _labels(col: NDArray[Any]) -> tuple[NDArray[np.int64], list[str]]:
    txt = [str(v).strip() for v in col]
    keys = sorted(
        {v for v in txt if v.lower() not in UNLABELLED},
        key=lambda v: (0, float(v), v) if _num(v) else (1, 0.0, v),
    )
    index = {k: i + 1 for i, k in enumerate(keys)}
    return np.array([index.get(v, -1) for v in txt], np.int64), keys


def _num(v: str) -> bool:
    try:
        float(v)
    except ValueError:
        return False
    return True


def load_table(
    source: str | Path | io.TextIOBase,
    inputs: Sequence[str] | None = None,
    targets: Sequence[str] | None = None,
    classes: Sequence[str] | None = None,
    unit_id: str | None = None,
) -> Dataset:
    """A generic Dataset from a CSV or column .npz.

    inputs: channel columns in order (default: every numeric column that is neither a
    target nor special). targets: target columns, regression and at most one class column
    (default: every non-input, non-special column; with inputs not given either, the F/T
    names Fx..Tz and the class columns). classes: columns to treat as classes
    (default: automatic, see the module docstring).
    """
    raw = _torques_as_t(read_columns(source), source)
    inputs, targets, classes = _t_names(inputs), _t_names(targets), _t_names(classes)
    cols = {k[: -len(CLASS_SUFFIX)] if k.endswith(CLASS_SUFFIX) else k: v for k, v in raw.items()}
    marked = {k[: -len(CLASS_SUFFIX)] for k in raw if k.endswith(CLASS_SUFFIX)}
    special = {k: SPECIAL[k.lower()] for k in cols if k.lower() in SPECIAL}
    missing = [c for c in list(inputs or []) + list(targets or []) if c not in cols]
    if missing:
        raise DatasetError(f"{source}: no column(s) {missing}; it has {list(cols)}")
    forced = set(classes) if classes is not None else set()
    if targets is None and inputs is None:  # known F/T names and class columns are targets
        targets = [
            k for k in cols
            if k in KNOWN_TARGETS or k in marked or k in forced or _is_text(cols[k])
        ]  # fmt: skip
    if inputs is None:
        taken = set(targets or []) | set(special) | marked | forced
        inputs = [k for k in cols if k not in taken and not _is_text(cols[k])]
    if targets is None:
        targets = [k for k in cols if k not in set(inputs) | set(special)]
    if not inputs:
        raise DatasetError(f"{source}: no input columns; name them (--inputs a,b,c)")
    cls_cols = [
        t for t in targets
        if t in marked or t in forced or (classes is None and _is_class(cols[t]))
    ]  # fmt: skip
    if len(cls_cols) > 1:
        raise DatasetError(
            f"{source}: several class columns {cls_cols}; a decoder has one class head: "
            f"train on one (--targets)"
        )
    reg = [t for t in targets if t not in cls_cols]
    x = np.stack([_floats(c, cols[c]) for c in inputs], axis=1)
    n = x.shape[0]
    y = np.stack([_floats(c, cols[c]) for c in reg], axis=1) if reg else np.zeros((n, 0))
    region, labels = _labels(cols[cls_cols[0]]) if cls_cols else (None, None)
    by = {v: k for k, v in special.items()}
    t = _floats(by["t"], cols[by["t"]]) if "t" in by else None
    press = _floats(by["press"], cols[by["press"]]).astype(np.int64) if "press" in by else None
    meta: dict[str, Any] = {
        "unit_id": unit_id,
        "sessions": [{"source": str(source) if isinstance(source, (str, Path)) else "stream"}],
    }
    if cls_cols:
        meta.update(region_name=cls_cols[0], region_labels=labels)
    ds = Dataset.generic(x, y, list(inputs), reg, region=region, t=t, press=press, meta=meta)
    if "session" in by:
        ds.arrays["session"] = _floats(by["session"], cols[by["session"]]).astype(np.int16)
        n_ses = int(ds.arrays["session"].max(initial=0)) + 1
        ds.meta["sessions"] = ds.meta["sessions"] * max(n_ses, 1)
    # A class column names regions, not contact: without a contact column there are no
    # contact labels to score against.
    ds.meta["contact_labels"] = "given" if "contact" in by else "none"
    if "contact" in by:
        ds.arrays["in_contact"] = _floats(by["contact"], cols[by["contact"]]) > 0.5
    ds.validate()
    return ds


def _torques_as_t(cols: dict[str, NDArray[Any]], source: Any) -> dict[str, NDArray[Any]]:
    """Columns with Mx My Mz renamed Tx Ty Tz (a ``:class`` suffix is kept)."""
    out: dict[str, NDArray[Any]] = {}
    for k, v in cols.items():
        cut = len(CLASS_SUFFIX) if k.endswith(CLASS_SUFFIX) else 0
        base = k[: len(k) - cut]
        name = TORQUE_SPELLING.get(base, base) + k[len(k) - cut :]
        if name in out:
            raise DatasetError(f"{source}: columns {name} and {k} are the same torque; keep one")
        out[name] = v
    return out


def _t_names(names: Sequence[str] | None) -> list[str] | None:
    return None if names is None else [TORQUE_SPELLING.get(n, n) for n in names]


def load_any(
    path: str | Path,
    inputs: Sequence[str] | None = None,
    targets: Sequence[str] | None = None,
    classes: Sequence[str] | None = None,
) -> Dataset:
    """A SpectraTac dataset file as it is, or any other CSV / column .npz via `load_table`."""
    p = Path(path)
    if p.suffix == ".npz":
        try:
            with zipfile.ZipFile(p) as z:  # the member names say which kind it is
                names = {Path(n).stem for n in z.namelist()}
        except (OSError, zipfile.BadZipFile, NotImplementedError) as exc:  # a zip of the future
            raise DatasetError(f"cannot read dataset {p}: {exc}") from None
        is_dataset = {"meta", "inputs"} <= names
        if is_dataset:
            return Dataset.load(p)
    return load_table(p, inputs, targets, classes)


def load_data(
    paths: Sequence[str | Path],
    inputs: Sequence[str] | None = None,
    targets: Sequence[str] | None = None,
    classes: Sequence[str] | None = None,
) -> Dataset:
    """Every file `spectratac train` and `spectratac evaluate` read (SpectraTac dataset .npz,
    generic CSV, column .npz; see `load_any`), joined row-wise when there are several."""
    from spectratac.dataset.schema import concat

    if not paths:
        raise DatasetError("no data files given")
    sets = [load_any(p, inputs, targets, classes) for p in paths]
    return sets[0] if len(sets) == 1 else concat(sets)
