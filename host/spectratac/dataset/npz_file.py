"""Reading .npz files someone else may have damaged: every way NumPy can fail on one.

`np.load` on a damaged archive raises more than its documented errors: a garbled array
header reaches Python's tokenizer and parser (`SyntaxError`, `tokenize.TokenError`), a
zip member may use a compression zipfile lacks (`NotImplementedError`), and a text array
may hold code points no string can (NumPy then raises `SystemError` when an element is
read), and a flipped bit can flag a member encrypted (zipfile then raises `RuntimeError`
asking for a password; NumPy never writes encrypted archives). `read_npz` turns all of them
into `NpzDamageError` with the reason, so each reader (datasets, column files, model files)
raises its own typed error from one place.

>>> import io
>>> buf = io.BytesIO()
>>> np.savez(buf, a=np.arange(3))
>>> read_npz(io.BytesIO(buf.getvalue()))["a"].tolist()
[0, 1, 2]
>>> try:
...     read_npz(io.BytesIO(b"PK not really"))
... except NpzDamageError as exc:
...     print(type(exc).__name__, "instead of", type(exc.__cause__).__name__)
NpzDamageError instead of ValueError
"""

from __future__ import annotations

import io
import tokenize
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.bounds import check_members

#: What NumPy and zipfile raise on a damaged archive (see the module docstring).
DAMAGE = (
    OSError,
    EOFError,
    ValueError,
    SyntaxError,
    tokenize.TokenError,
    NotImplementedError,
    zipfile.BadZipFile,
    zlib.error,
)
MAX_CODE_POINT = 0x10FFFF


class NpzDamageError(ValueError):
    """The archive cannot be read; the message says why (its cause is NumPy's error)."""


def read_npz(
    source: str | Path | io.BytesIO, max_bytes: int | None = None
) -> dict[str, NDArray[Any]]:
    """Every array of an .npz archive (no pickles), or NpzDamageError; with `max_bytes`,
    an archive whose members declare more inflated is refused before any is read."""
    try:
        if max_bytes is not None:
            check_members(source, max_bytes, "the archive")
        with np.load(source, allow_pickle=False) as z:
            arrays = {k: np.asarray(z[k]) for k in z.files}
    except DAMAGE as exc:
        raise NpzDamageError(str(exc) or type(exc).__name__) from exc
    except MemoryError:  # an array header declaring more than this machine holds
        raise NpzDamageError(
            "an array declares more data than fits in memory: the file is damaged"
        ) from None
    except RuntimeError as exc:  # zipfile's only RuntimeError here: a member flagged encrypted
        raise NpzDamageError(
            f"{exc}: NumPy archives are never encrypted, so the file is damaged; build or "
            f"save it again from its source"
        ) from exc
    for name, a in arrays.items():
        # UCS-4 text beyond U+10FFFF cannot become a str: NumPy fails later, on first use
        if a.dtype.kind == "U" and a.size and _max_code_point(a) > MAX_CODE_POINT:
            raise NpzDamageError(f"array {name!r} holds text that is not Unicode")
    return arrays


def _max_code_point(a: NDArray[np.str_]) -> int:
    """The largest UCS-4 code unit stored in a text array of any shape (0-d included)."""
    return int(np.ascontiguousarray(a).reshape(-1).view(np.uint32).max())
