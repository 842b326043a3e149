"""A seeded mutation loop: the same seed gives the same inputs on every machine.

Byte-level mutations (bit flips, interesting values, inserted or deleted runs, truncation,
duplicated runs, splices with another seed) reach framing and header checks; container-aware
ones (members of a zip mutated and re-packed, JSON values swapped for other types) get past a
zip's own checks into the loaders' validation.

>>> m = Mutator(7)
>>> m.mutate(b"hello world", [b"other seed"]) == Mutator(7).mutate(b"hello world", [b"other seed"])
True
"""

from __future__ import annotations

import io
import json
import random
import zipfile
from collections.abc import Sequence
from typing import Any

INTERESTING_BYTES = (0x00, 0x01, 0x7F, 0x80, 0xFF, 0xAA, 0x2C, 0x0A)
INTERESTING_WORDS = (
    b"\xff\xff\xff\xff",
    b"\x00\x00\x00\x80",
    b"\xff\xff\xff\x7f",
    b"\x00\x00\x80\x7f",  # float32 +inf
    b"\x00\x00\xc0\x7f",  # float32 NaN
    b"\x99\x76\x96\x7e",  # float32 1e38
)
JSON_SWAPS: tuple[Any, ...] = (None, -1, 0, 2**63, 1e308, float("nan"), "", "x", [], {}, True)
TEXT_SWAPS = ("nan", "inf", "-1", "1e999", "", ",", "\n", "\x00", "é", "0x10", "9" * 400)


class Mutator:
    def __init__(self, seed: int) -> None:
        self.rng = random.Random(seed)

    # ------------------------------------------------------------------ bytes
    def mutate(self, data: bytes, pool: Sequence[bytes], rounds: int | None = None) -> bytes:
        """`data` with 1-4 random byte-level mutations (splices take from `pool`)."""
        out = bytearray(data)
        for _ in range(rounds or self.rng.randint(1, 4)):
            out = self._one(out, pool)
        return bytes(out)

    def _one(self, b: bytearray, pool: Sequence[bytes]) -> bytearray:
        r = self.rng
        kind = r.randrange(9)
        at = r.randrange(len(b) + 1)
        if kind == 0 and b:  # flip one bit
            i = r.randrange(len(b))
            b[i] ^= 1 << r.randrange(8)
        elif kind == 1 and b:  # an interesting byte
            b[r.randrange(len(b))] = r.choice(INTERESTING_BYTES)
        elif kind == 2:  # an interesting 32-bit word
            word = r.choice(INTERESTING_WORDS)
            b[at : at + len(word)] = word
        elif kind == 3:  # insert random bytes
            b[at:at] = r.randbytes(r.randint(1, 64))
        elif kind == 4 and b:  # delete a run
            del b[at : at + r.randint(1, 64)]
        elif kind == 5:  # truncate
            del b[at:]
        elif kind == 6 and b:  # duplicate a run
            start = r.randrange(len(b))
            b[at:at] = b[start : start + r.randint(1, 256)]
        elif kind == 7 and pool:  # splice: our head, another seed's tail
            other = r.choice(pool)
            b = b[:at] + other[r.randrange(len(other) + 1) :]
        elif kind == 8 and b:  # overwrite a run with one byte (long runs, no delimiters)
            b[at : at + r.randint(1, 300)] = bytes([r.choice(INTERESTING_BYTES)]) * r.randint(
                1, 300
            )
        return b

    # ------------------------------------------------------------------ text
    def mutate_text(self, text: str) -> str:
        """Line/field-level damage to CSV-like text: swap fields, drop or repeat lines."""
        r = self.rng
        lines = text.split("\n")
        for _ in range(r.randint(1, 3)):
            i = r.randrange(len(lines))
            kind = r.randrange(4)
            if kind == 0:
                fields = lines[i].split(",")
                fields[r.randrange(len(fields))] = r.choice(TEXT_SWAPS)
                lines[i] = ",".join(fields)
            elif kind == 1:
                del lines[i]
                if not lines:
                    lines = [""]
            elif kind == 2:
                lines.insert(i, lines[r.randrange(len(lines))])
            else:
                lines[i] = lines[i] + "," + r.choice(TEXT_SWAPS)
        return "\n".join(lines)

    # ------------------------------------------------------------------ JSON
    def mutate_json(self, obj: Any) -> Any:
        """`obj` with one value (at any depth) replaced by a value of another type."""
        paths = list(_paths(obj, ()))
        if not paths:
            return self.rng.choice(JSON_SWAPS)
        path = self.rng.choice(paths)
        return _replace(obj, path, self.rng.choice(JSON_SWAPS))

    # ------------------------------------------------------------------ zip containers
    def mutate_zip(self, data: bytes, pool: Sequence[bytes]) -> bytes:
        """Re-pack a zip (.npz, .stac) with one member mutated: JSON members by value, zip
        members (an npz inside) recursively, others byte-wise or dropped."""
        try:
            with zipfile.ZipFile(io.BytesIO(data)) as z:
                members = {name: z.read(name) for name in z.namelist()}
        except (zipfile.BadZipFile, OSError, ValueError, EOFError):
            return self.mutate(data, pool)
        if not members:
            return self.mutate(data, pool)
        name = self.rng.choice(sorted(members))
        body = members[name]
        choice = self.rng.randrange(10)
        if choice == 0:
            del members[name]
        elif name.endswith(".json"):
            try:
                obj = json.loads(body)
            except ValueError:
                members[name] = self.mutate(body, ())
            else:
                members[name] = json.dumps(self.mutate_json(obj)).encode()
        elif body[:2] == b"PK":
            members[name] = self.mutate_zip(body, ())
        elif body[:6] == b"\x93NUMPY" and choice < 5:  # the .npy header: shape, dtype, order
            end = body.find(b"\n", 10) + 1
            header = self.mutate_text(body[10:end].decode("latin-1")).encode("latin-1")
            members[name] = body[:8] + len(header).to_bytes(2, "little") + header + body[end:]
        else:
            members[name] = self.mutate(body, ())
        out = io.BytesIO()
        with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as z:
            for member, content in members.items():
                z.writestr(member, content)
        return out.getvalue()


def _paths(obj: Any, prefix: tuple[Any, ...]) -> Any:
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, (*prefix, i))


def _replace(obj: Any, path: tuple[Any, ...], value: Any) -> Any:
    if not path:
        return value
    head, rest = path[0], path[1:]
    if isinstance(obj, dict):
        return {k: (_replace(v, rest, value) if k == head else v) for k, v in obj.items()}
    return [(_replace(v, rest, value) if i == head else v) for i, v in enumerate(obj)]
