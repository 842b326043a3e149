"""Reading what users hand us within bounds: JSON size and nesting depth, zip members' sizes.

A model file, a dataset's metadata or a recording's JSON message may come from anywhere. A
zip member declares its size before it is inflated (zipfile never inflates past it), so a
zip bomb is refused from its directory; JSON is measured (bytes, then bracket depth outside
strings, counted with NumPy) before `json.loads`, whose recursion would otherwise end in
RecursionError. Each reader turns BoundsError into its own typed error. Shared: the model
and dataset readers use it, and so does the recording reader below them.

>>> loads_bounded('{"a": [1, 2]}', what="meta.json")
{'a': [1, 2]}
>>> try:
...     loads_bounded("[" * 100 + "]" * 100, what="meta.json")
... except BoundsError as exc:
...     print(exc)
meta.json nests 100 levels deep; at most 64 are read (a damaged or hostile file)
"""

from __future__ import annotations

import json
import re
import zipfile
from typing import Any

import numpy as np

#: Nesting no file of the toolkit comes near (a model's meta nests about 6 levels).
MAX_JSON_DEPTH = 64
#: Bytes of JSON read from a user's file (a model's meta.json is a few kB).
MAX_JSON_BYTES = 16 * 2**20
#: Text of JSON strings (escapes included), dropped before brackets are counted.
_STRINGS = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)


class BoundsError(ValueError):
    """Input beyond what the toolkit reads; the message says which limit and where."""


def json_depth(text: str | bytes) -> int:
    """The deepest nesting of arrays and objects in JSON `text` (brackets inside strings do
    not count).

    >>> json_depth('{"a": [[1]], "b": "[[[["}')
    3
    """
    raw = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else bytes(text)
    codes = np.frombuffer(_STRINGS.sub(b'""', raw), np.uint8)
    step = np.zeros(len(codes), np.int64)
    step[(codes == ord("[")) | (codes == ord("{"))] = 1
    step[(codes == ord("]")) | (codes == ord("}"))] = -1
    return int(np.cumsum(step).max(initial=0))


def loads_bounded(
    text: str | bytes,
    *,
    what: str,
    max_bytes: int = MAX_JSON_BYTES,
    max_depth: int = MAX_JSON_DEPTH,
) -> Any:
    """json.loads, after refusing (BoundsError) text over `max_bytes` or nesting deeper than
    `max_depth`; malformed JSON is json's ValueError as before."""
    if len(text) > max_bytes:
        raise BoundsError(
            f"{what} is {len(text)} bytes; at most {max_bytes} are read (a damaged or hostile file)"
        )
    depth = json_depth(text)
    if depth > max_depth:
        raise BoundsError(
            f"{what} nests {depth} levels deep; at most {max_depth} are read (a damaged or "
            f"hostile file)"
        )
    return json.loads(text)


def read_member(z: zipfile.ZipFile, name: str, max_bytes: int, what: str) -> bytes:
    """Member `name` of an open zip, refused (BoundsError) if it declares more than
    `max_bytes` inflated; zipfile stops inflating at the declared size (and checks its CRC),
    so the declaration bounds the memory."""
    info = z.getinfo(name)
    if info.file_size > max_bytes:
        raise BoundsError(
            f"{what}: {name} declares {info.file_size} bytes inflated from "
            f"{info.compress_size}; at most {max_bytes} are read (a damaged or hostile file)"
        )
    return z.read(info)


def check_members(source: Any, max_bytes: int, what: str) -> None:
    """Refuse (BoundsError) a zip (a path or a file object, e.g. an .npz) whose members
    declare more than `max_bytes` inflated in all; not a zip: nothing to check here."""
    try:
        with zipfile.ZipFile(source) as z:
            total = sum(i.file_size for i in z.infolist())
    except (zipfile.BadZipFile, OSError, ValueError, EOFError):
        return  # the reader says what is wrong with it
    finally:
        if hasattr(source, "seek"):
            source.seek(0)
    if total > max_bytes:
        raise BoundsError(
            f"{what} declares {total} bytes inflated; at most {max_bytes} are read (a damaged "
            f"or hostile file)"
        )
