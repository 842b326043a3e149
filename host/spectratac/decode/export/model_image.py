"""Model images: a whole decoder as the bytes the firmware's interpreter runs (stac_model.c).

An image carries everything `Decoder` computes for a live sample: the assembly (LED steps,
context lags, moving averages, drift baseline with TAU/GATE/STUCK and, from format 2, the
rest signature its search for rest needs: sections rest and press, flag rest), the feature rows as
sparse rows, the normalisation, the network (linear, mlp, resmlp) with float32, float16 or
int8 (per-output-row scale) weights, the heads and the out-of-distribution guard.

Layout (little-endian; one definition, hardware/definitions/model_image.toml, generated into
`spectratac.decode.generated.model_image_layout` here and stac_model_image.h for the firmware):
a 96-byte header (magic "STMI", format version, header size, model_id, total size, weight
format, dimensions, target map, guard and baseline constants), a table of N_SECTIONS (offset,
length) pairs, the sections (4-byte aligned, each exactly as long as the dimensions say), then
the CRC-32C of everything before it.

The guard's bounds are stored rounded so that the float32 comparisons on the device decide
exactly as the float64 ones in Python: input bounds become whole counts (inputs are counts),
target bounds the nearest float32 on the inside of the comparison.

>>> import numpy as np
>>> from spectratac.dataset import Dataset, SPECTRATAC_INPUTS
>>> ds = Dataset.generic(np.arange(1.0, 37.0).reshape(3, 12), np.zeros((3, 1)),
...                      list(SPECTRATAC_INPUTS), ["Fz"])
>>> from spectratac.decode import Decoder
>>> dec = Decoder.untrained(ds, features="paper33")
>>> image = encode(dec, weights="f16")
>>> d = describe(image)
>>> d["weight_format"], d["n_inputs"], d["n_features"], d["led_steps"], d["size"] == len(image)
('f16', 12, 33, 1, True)
>>> model_id(image) == model_id(encode(dec, weights="f16")) != model_id(encode(dec))
True
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import replace
from typing import Any, TypeVar

import crcmod.predefined
import numpy as np
from numpy.typing import NDArray

from spectratac.decode.assemble import GATE, STUCK, TAU
from spectratac.decode.errors import DecoderError
from spectratac.decode.estimates import CONTACT_FORCE_N
from spectratac.decode.generated.model_image_layout import (
    ALIGN,
    ARCHS,
    CRC,
    ENTRY,
    FLAG_CONTACT,
    FLAG_REST,
    FLAG_UNCERTAINTY,
    HEADER,
    HEADER_FIELDS,
    HEADER_SIZE,
    LIMITS,
    MAGIC,
    N_SECTIONS,
    SECTIONS,
    TARGET_ABSENT,
    TARGETS,
    VERSION,
    WEIGHT_FORMATS,
)
from spectratac.decode.guard import DARK_COUNTS
from spectratac.decode.networks import SKIP, layer_shapes, norm_names
from spectratac.decode.parts import DecoderParts
from spectratac.hardware.generated import vocabulary as vocab

#: A decoder, or anything else with its parts (as_stored returns the same type).
D = TypeVar("D", bound=DecoderParts)

#: The STM32 model store: flash sectors 4-7 (448 KiB) less the 64 bytes of its commit record.
MAX_IMAGE_BYTES = 458752 - 64
#: Where the section table ends and the first section may start.
TABLE_END = HEADER_SIZE + ENTRY.size * N_SECTIONS
_crc32c = crcmod.predefined.mkCrcFun("crc-32c")
COUNT_LO, COUNT_HI = -1.0, 65536.0  # beyond every 16-bit count: bounds clamp to these


class ModelImageError(DecoderError):
    """The decoder cannot run on the device, or bytes are not a valid model image."""


def decoder_hash(dec: DecoderParts) -> bytes:
    """SHA-256 of the decoder's content (what its .stac file holds), independent of how
    the file was zipped: the same decoder always hashes the same."""
    h = hashlib.sha256()
    meta = {
        "layout": dec.layout.to_dict(),
        "runtime": dec.runtime.header(),
        "guard": dec.guard.header(),
        "meta": dec.meta,
    }
    h.update(json.dumps(meta, sort_keys=True, default=str).encode())
    arrays = dict(dec.runtime.arrays())
    arrays.update({f"guard/{k}": v for k, v in dec.guard.arrays().items()})
    for key in sorted(arrays):
        a = np.ascontiguousarray(arrays[key])
        h.update(f"{key}:{a.dtype.str}:{a.shape}".encode())
        h.update(a.tobytes())
    return h.digest()


def decoder_model_id(dec: DecoderParts, weights: str = "f32") -> int:
    """The model_id `encode(dec, weights)` writes: from the content hash and the weight
    format (another format gives other numbers, so another id); never 0 (0 means none)."""
    digest = hashlib.sha256(decoder_hash(dec) + weights.encode()).digest()
    return int.from_bytes(digest[:4], "little") or 1


# ---------------------------------------------------------------------------- weights
def _quantise(w: NDArray[Any], weights: str) -> tuple[bytes, NDArray[np.float32], NDArray]:
    """(stored bytes, per-row scales (i8) or empty, the float32 values the device uses)."""
    w32 = np.asarray(w, np.float32)
    if weights == "f32":
        return w32.tobytes(), np.zeros(0, np.float32), w32
    if weights == "f16":
        h = w32.astype(np.float16)
        if not np.all(np.isfinite(h)):
            raise ModelImageError("a weight exceeds float16's range (65504): use weights='f32'")
        return h.tobytes(), np.zeros(0, np.float32), h.astype(np.float32)
    peak = np.max(np.abs(w32), axis=1)
    scale = np.where(peak > 0, peak / np.float32(127.0), np.float32(1.0)).astype(np.float32)
    q = np.clip(np.rint(w32 / scale[:, None]), -127, 127).astype(np.int8)
    return q.tobytes(), scale, q.astype(np.float32) * scale[:, None]


def _layers(dec: DecoderParts) -> list[tuple[str, int, int]]:
    rt = dec.runtime
    return layer_shapes(rt.arch, rt.features.n_features, rt.heads.n_out)


def as_stored(dec: D, weights: str = "f32") -> D:
    """A copy of `dec` whose network weights are the values an image in `weights` format
    holds (float16 or int8 rounding) and whose guard makes the checks the image carries
    (`Guard.on_device`): the reference its device estimates and flags must match."""
    _check_format(weights)
    w = dict(dec.runtime.weights)
    for name, _, _ in _layers(dec):
        w[name + ".weight"] = _quantise(w[name + ".weight"], weights)[2]
    runtime = replace(dec.runtime, weights=w)
    return replace(dec, runtime=runtime, guard=dec.guard.on_device())


def _check_format(weights: str) -> None:
    if weights not in WEIGHT_FORMATS:
        raise ModelImageError(f"weights={weights!r}: choose one of {', '.join(WEIGHT_FORMATS)}")


# ---------------------------------------------------------------------------- checks
def check_runnable(dec: DecoderParts) -> None:
    """Raise ModelImageError naming the first thing the firmware cannot run."""
    rt, lay, heads = dec.runtime, dec.layout, dec.runtime.heads
    kind, hidden, blocks = rt.arch
    fix = "train a smaller decoder (TrainSpec) or decode on the host"
    if tuple(lay.channels) != vocab.DECODED_INPUTS:
        raise ModelImageError(
            f"the device decodes the 12 SpectraTac inputs {', '.join(vocab.DECODED_INPUTS)}; "
            f"this decoder takes {', '.join(lay.channels)}: decode on the host"
        )
    if kind not in ARCHS:
        raise ModelImageError(f"architecture {kind!r} has no interpreter on the device")
    if SKIP in rt.weights:
        raise ModelImageError(
            "this decoder has a linear skip (TrainSpec.skip) and the model image "
            "(hardware/definitions/model_image.toml) does not carry one: decode it on the "
            "host, or export('c') for firmware you build, or train with skip=False"
        )
    if rt.features.M.shape[0]:
        raise ModelImageError(
            f"{rt.features.M.shape[0]} polynomial (monomial) features: the device computes "
            "linear and ratio features only; decode this ridge model on the host"
        )
    checks = (
        ("LED steps", lay.steps, LIMITS["MAX_STEPS"]),
        ("context lags", len(lay.lags), LIMITS["MAX_LAGS"]),
        ("longest context lag", max(lay.lags, default=0), LIMITS["MAX_HIST"] - 1),
        ("moving averages", len(lay.emas), LIMITS["MAX_EMAS"]),
        ("assembled inputs", rt.n_inputs, LIMITS["MAX_INPUTS"]),
        ("features", rt.features.n_features, LIMITS["MAX_FEATURES"]),
        ("hidden units", hidden if kind != "linear" else 0, LIMITS["MAX_HIDDEN"]),
        ("blocks", blocks if kind != "linear" else 0, LIMITS["MAX_BLOCKS"]),
        ("outputs", heads.n_out, LIMITS["MAX_OUTPUTS"]),
        ("dark-checked columns", len(dec.guard.dark_cols), LIMITS["MAX_DARK"]),
    )
    for what, have, limit in checks:
        if have > limit:
            raise ModelImageError(f"{have} {what}; the firmware runs at most {limit}: {fix}")
    if kind == "mlp" and blocks < 1:
        raise ModelImageError("an mlp without hidden layers: export it as a linear model")
    if kind == "resmlp" and hidden < 1:
        raise ModelImageError("a resmlp without hidden units cannot run")


# ---------------------------------------------------------------------------- encoding
def _csr(m: NDArray[Any]) -> tuple[bytes, bytes, bytes]:
    m = np.asarray(m, np.float64)
    rows, cols = np.nonzero(m)
    if rows.size > 0xFFFF:
        raise ModelImageError(f"{rows.size} non-zero feature weights; the device holds 65535")
    ptr = np.searchsorted(rows, np.arange(m.shape[0] + 1)).astype("<u2")
    return ptr.tobytes(), cols.astype("<u2").tobytes(), m[rows, cols].astype("<f4").tobytes()


def _f32(a: Any) -> bytes:
    return np.asarray(a, np.float64).astype("<f4").tobytes()


def _count_bounds(lo: NDArray[Any], hi: NDArray[Any]) -> tuple[bytes, bytes]:
    """Whole-count bounds: for an integer x, x < lo iff x < ceil(lo), x > hi iff x > floor(hi)."""
    lo = np.clip(np.ceil(np.asarray(lo, np.float64)), COUNT_LO, COUNT_HI)
    hi = np.clip(np.floor(np.asarray(hi, np.float64)), COUNT_LO, COUNT_HI)
    return _f32(lo), _f32(hi)


def _target_bounds(lo: NDArray[Any], hi: NDArray[Any]) -> tuple[bytes, bytes]:
    """For a float32 y: y < lo iff y < (the smallest float32 >= lo); likewise for hi."""
    lo64, hi64 = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    lo32, hi32 = lo64.astype(np.float32), hi64.astype(np.float32)
    with np.errstate(over="ignore"):
        lo32 = np.where(
            lo32.astype(np.float64) < lo64, np.nextafter(lo32, np.float32(np.inf)), lo32
        )
        hi32 = np.where(
            hi32.astype(np.float64) > hi64, np.nextafter(hi32, np.float32(-np.inf)), hi32
        )
    return lo32.astype("<f4").tobytes(), hi32.astype("<f4").tobytes()


def _sections(dec: DecoderParts, weights: str) -> dict[str, bytes]:
    rt, lay, heads, guard = dec.runtime, dec.layout, dec.runtime.heads, dec.guard
    fs = rt.features
    s: dict[str, bytes] = {}
    s["lags"] = np.asarray(lay.lags, "<u2").tobytes()
    s["ema_alpha"] = (1.0 / np.asarray(lay.emas, np.float64)).astype("<f8").tobytes()
    s["center"] = _f32(rt.center)
    s["lin_ptr"], s["lin_idx"], s["lin_val"] = _csr(fs.L)
    s["p_ptr"], s["p_idx"], s["p_val"] = _csr(fs.P)
    s["q_ptr"], s["q_idx"], s["q_val"] = _csr(fs.Q)
    s["f_mean"], s["f_std"] = _f32(rt.scaler.mean), _f32(rt.scaler.std)
    w, scales, bias = [], [], []
    for name, _, _ in _layers(dec):
        stored, scale, _ = _quantise(rt.weights[name + ".weight"], weights)
        w.append(stored)
        scales.append(scale.astype("<f4").tobytes())
        bias.append(_f32(rt.weights[name + ".bias"]))
    s["weights"], s["w_scale"], s["bias"] = b"".join(w), b"".join(scales), b"".join(bias)
    norms = [
        _f32(rt.weights[n + ".weight"]) + _f32(rt.weights[n + ".bias"]) for n in norm_names(rt.arch)
    ]
    s["norms"] = b"".join(norms)
    s["y_scale"] = _f32(rt.y_scale)
    # postprocess multiplies by (y_scale * std_scale) rounded once to float32
    s["std_mul"] = _f32(rt.y_scale * rt.std_scale) if heads.uncertainty else b""
    s["t_lo"], s["t_hi"] = _target_bounds(guard.t_lo, guard.t_hi)
    s["in_lo"], s["in_hi"] = _count_bounds(guard.in_lo, guard.in_hi)
    s["dark_cols"] = np.asarray(guard.dark_cols, "<u2").tobytes()
    rest = has_rest(dec)
    s["rest"] = np.asarray(lay.rest if rest else (), "<f8").tobytes()
    s["press"] = np.asarray(lay.press if rest else (), "<f8").tobytes()
    return s


def has_rest(dec: DecoderParts) -> bool:
    """True when the image carries the rest signature: a drift baseline that searches for
    rest before it adapts (decode/assemble._Baseline), on the device as on the host."""
    lay = dec.layout
    return bool(lay.drift and len(lay.rest) == lay.base and len(lay.press) == lay.base)


def encode(
    dec: DecoderParts, weights: str = "f32", *, limit: int | None = MAX_IMAGE_BYTES
) -> bytes:
    """The model image of `dec` with network weights in `weights` ("f32", "f16", "i8").

    Raises ModelImageError when the firmware cannot run the decoder or the image exceeds
    `limit` bytes (default: the model store; None for a model compiled into the firmware,
    where only the flash left by the firmware bounds it)."""
    _check_format(weights)
    check_runnable(dec)
    rt, lay, heads, guard = dec.runtime, dec.layout, dec.runtime.heads, dec.guard
    kind, hidden, blocks = rt.arch
    if kind == "linear":
        hidden, blocks = 0, 0
    sections = _sections(dec, weights)
    body, table, offset = bytearray(), [], TABLE_END
    for name in SECTIONS:
        data = sections[name]
        table.append((offset, len(data)))
        pad = (-len(data)) % ALIGN
        body += data + b"\0" * pad
        offset += len(data) + pad
    total = offset + CRC.size
    if limit is not None and total > limit:
        raise ModelImageError(
            f"the image takes {total} bytes; the model store holds {limit}: use "
            f"weights='f16' or 'i8', or train a smaller decoder"
        )
    targets = heads.regression
    n_linear, n_ratio = fs_rows(dec)
    header = _pack_header(
        {
            "magic": MAGIC,
            "version": VERSION,
            "header_size": HEADER_SIZE,
            "model_id": decoder_model_id(dec, weights),
            "size": total,
            "weight_format": WEIGHT_FORMATS.index(weights),
            "arch": ARCHS.index(kind),
            "steps": lay.steps,
            "channels": len(lay.channels),
            "n_lags": len(lay.lags),
            "n_emas": len(lay.emas),
            "drift": int(lay.drift),
            "flags": (FLAG_UNCERTAINTY if heads.uncertainty else 0)
            | (FLAG_CONTACT if heads.contact else 0)
            | (FLAG_REST if has_rest(dec) else 0),
            "n_inputs": rt.n_inputs,
            "n_features": rt.features.n_features,
            "n_linear": n_linear,
            "n_ratio": n_ratio,
            "hidden": hidden,
            "blocks": blocks,
            "n_outputs": heads.n_out,
            "n_regression": heads.n_reg,
            "n_classes": heads.n_classes,
            "n_dark": len(guard.dark_cols),
            "target_map": [targets.index(n) if n in targets else TARGET_ABSENT for n in TARGETS],
            "n_sections": N_SECTIONS,
            "saturation": float(guard.saturation or 0.0),
            "dark_counts": DARK_COUNTS,
            "base_tau": TAU,
            "base_gate": GATE,
            "base_stuck": STUCK,
            "contact_force": CONTACT_FORCE_N,
        }
    )
    table_bytes = b"".join(ENTRY.pack(o, n) for o, n in table)
    image = header + table_bytes + bytes(body)
    return image + CRC.pack(_crc32c(image))


def _pack_header(values: dict[str, Any]) -> bytes:
    """The header from its fields by name (arrays as sequences), in the definition's order."""
    flat: list[Any] = []
    for name, count in HEADER_FIELDS:
        flat += list(values[name]) if count > 1 else [values[name]]
    return HEADER.pack(*flat)


def _unpack_header(image: bytes) -> dict[str, Any]:
    """The header's fields by name (arrays as tuples)."""
    flat = iter(HEADER.unpack_from(image))
    return {
        name: tuple(itertools.islice(flat, count)) if count > 1 else next(flat)
        for name, count in HEADER_FIELDS
    }


def fs_rows(dec: DecoderParts) -> tuple[int, int]:
    """(linear feature rows, ratio feature rows)."""
    fs = dec.runtime.features
    return int(fs.L.shape[0]), int(fs.P.shape[0])


# ---------------------------------------------------------------------------- reading
def _parse_header(image: bytes) -> dict[str, Any]:
    if len(image) < TABLE_END + CRC.size or image[: len(MAGIC)] != MAGIC:
        raise ModelImageError("not a SpectraTac model image (no STMI header): re-export it")
    fields = _unpack_header(image)
    if fields["version"] != VERSION:
        raise ModelImageError(
            f"model image version {fields['version']}; this library writes {VERSION}"
        )
    if fields["size"] != len(image):
        raise ModelImageError(
            f"the image says {fields['size']} bytes but has {len(image)}: truncated?"
        )
    (crc,) = CRC.unpack_from(image, len(image) - CRC.size)
    if crc != _crc32c(image[: -CRC.size]):
        raise ModelImageError("model image CRC-32C mismatch: the image is damaged, re-export it")
    return fields


def model_id(image: bytes) -> int:
    """The u32 model_id in the image's header (after checking magic, version, size, CRC)."""
    return int(_parse_header(image)["model_id"])


def image_crc(image: bytes) -> int:
    """The image's own CRC-32C (its trailing u32: the CRC-32C of every byte before it), which
    a device reports as MODEL_INFO.image_crc: it tells models and weight formats apart,
    where the CRC-32C of a whole image is always the same residue."""
    (crc,) = CRC.unpack_from(image, len(image) - CRC.size)
    return int(crc)


def describe(image: bytes) -> dict[str, Any]:
    """What the image holds: format, sizes, dimensions, weight format, section sizes."""
    f = _parse_header(image)
    sections = {
        name: ENTRY.unpack_from(image, HEADER_SIZE + ENTRY.size * i)[1]
        for i, name in enumerate(SECTIONS)
    }
    (crc,) = CRC.unpack_from(image, len(image) - CRC.size)
    return {
        "format": f["magic"].decode(),
        "version": f["version"],
        "model_id": f["model_id"],
        "size": f["size"],
        "crc": crc,
        "weight_format": WEIGHT_FORMATS[f["weight_format"]],
        "arch": ARCHS[f["arch"]],
        "led_steps": f["steps"],
        "n_inputs": f["n_inputs"],
        "n_features": f["n_features"],
        "hidden": f["hidden"],
        "blocks": f["blocks"],
        "n_outputs": f["n_outputs"],
        "sections": sections,
    }
