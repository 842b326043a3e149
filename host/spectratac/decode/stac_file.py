"""The `.stac` model file: one zip holding ``meta.json`` and ``arrays.npz``.

meta.json: ``format`` ("spectratac.decoder"), ``version`` ("major.minor"), the decoder's
meta (spec, features, targets, config, unit_id, n_train, train_seconds, history, ...), the
input layout, the runtime header (feature kind and names, architecture, heads, outputs)
and the OOD guard's settings. arrays.npz: the runtime's arrays (feature matrices,
normalisation, weights, scales) and the guard's ranges. A newer major version is refused;
a newer minor version loads (fields it adds are ignored). Every array's shape and
finiteness is checked at load: a damaged file of any kind raises DecoderFileError.

>>> VERSION
'1.0'
"""

from __future__ import annotations

import io
import json
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from spectratac.bounds import MAX_JSON_BYTES, BoundsError, loads_bounded, read_member
from spectratac.dataset.npz_file import NpzDamageError, read_npz
from spectratac.decode.errors import DecoderFileError
from spectratac.decode.guard import Guard
from spectratac.decode.layout import Layout
from spectratac.decode.parts import DecoderParts
from spectratac.decode.runtime import Runtime

D = TypeVar("D")
#: Builds the decoder from the pieces a file holds: Decoder itself (`Decoder.load`).
Build = Callable[[Runtime, Layout, Guard, dict[str, Any]], D]

FORMAT = "spectratac.decoder"
VERSION = "1.0"
#: What reading a damaged zip, npz or JSON part can raise (all become DecoderFileError).
_DAMAGE = (OSError, EOFError, KeyError, IndexError, ValueError, TypeError, AttributeError,
           NotImplementedError, zipfile.BadZipFile, zlib.error, NpzDamageError)  # fmt: skip
#: Bytes a model's arrays may inflate to (a large decoder is a few MB): a zip bomb is refused
#: from the zip's directory, before anything is inflated.
MAX_ARRAYS_BYTES = 256 * 2**20
#: Torque names of generic datasets before Tx Ty Tz became the only spelling.
RETIRED_TORQUE_NAMES = ("Mx", "My", "Mz")


def _jsonable(v: Any) -> Any:
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


def write_model(dec: DecoderParts, path: str | Path) -> Path:
    path = Path(path)
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "decoder": _jsonable(dec.meta),
        "layout": dec.layout.to_dict(),
        "runtime": dec.runtime.header(),
        "guard": dec.guard.header(),
    }
    arrays = dict(dec.runtime.arrays())
    arrays.update({f"guard/{k}": v for k, v in dec.guard.arrays().items()})
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as z:
            z.writestr("meta.json", json.dumps(meta, indent=1, allow_nan=True))
            z.writestr("arrays.npz", buf.getvalue())
        tmp.replace(path)  # never leave a half-written model under the real name
    finally:
        tmp.unlink(missing_ok=True)  # a full disk or a read-only folder: no half model left
    return path


def read_meta(path: str | Path) -> dict[str, Any]:
    """Only the JSON part of a model file (fast: no arrays)."""
    try:
        with zipfile.ZipFile(path) as z:
            text = read_member(z, "meta.json", MAX_JSON_BYTES, f"{path}")
        meta = loads_bounded(text, what=f"{path}: meta.json")
    except FileNotFoundError:
        raise DecoderFileError(f"no model file at {path}") from None
    except (BoundsError, RecursionError) as exc:
        raise DecoderFileError(f"{exc}: not a model file `spectratac train` wrote") from None
    except _DAMAGE as exc:
        raise DecoderFileError(
            f"{path} is not a SpectraTac model file ({exc}); train one with `spectratac train`"
        ) from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise DecoderFileError(f"{path} is not a SpectraTac model file (format {FORMAT!r})")
    try:
        major = int(str(meta.get("version", "0")).split(".")[0])
    except ValueError:
        raise DecoderFileError(f"{path}: unreadable version {meta.get('version')!r}") from None
    if major > int(VERSION.split(".")[0]):
        raise DecoderFileError(
            f"{path} is model format {meta['version']}, newer than this library reads "
            f"({VERSION}): update spectratac (pip install -U spectratac)"
        )
    return meta


def read_model(path: str | Path, build: Build[D]) -> D:
    """The model in `path`, made by `build(runtime, layout, guard, decoder meta)`."""
    meta = read_meta(path)
    try:
        with zipfile.ZipFile(path) as z:
            data = read_member(z, "arrays.npz", MAX_ARRAYS_BYTES, f"{path}")
        arrays = read_npz(io.BytesIO(data), max_bytes=MAX_ARRAYS_BYTES)
        runtime = Runtime.from_parts(meta["runtime"], arrays)
        guard = Guard.from_parts(
            meta["guard"], {k[6:]: v for k, v in arrays.items() if k.startswith("guard/")}
        )
        layout = Layout.from_dict(meta["layout"])
        if layout.size != runtime.n_inputs:
            raise ValueError(f"layout of {layout.size} inputs, runtime of {runtime.n_inputs}")
        guard.validate(layout.base, runtime.heads.n_reg)
        if not isinstance(meta["decoder"], dict):
            raise TypeError(f"decoder meta is {type(meta['decoder']).__name__}, not an object")
        dec = build(runtime, layout, guard, meta["decoder"])
        old = [n for n in runtime.heads.regression if n in RETIRED_TORQUE_NAMES]
    except DecoderFileError as exc:
        raise DecoderFileError(f"{path}: {exc}") from None
    except BoundsError as exc:
        raise DecoderFileError(f"{exc}: not a model file `spectratac train` wrote") from None
    except _DAMAGE as exc:
        raise DecoderFileError(f"{path} is damaged ({exc!r}): retrain or re-copy it") from None
    if old:
        raise DecoderFileError(
            f"{path} names torque targets {old}; torques are Tx Ty Tz now: retrain the "
            "decoder on the dataset (its Mx My Mz columns load as Tx Ty Tz)"
        )
    return dec
