"""Exports of a decoder's stateless part (assembled vector -> outputs)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from spectratac.decode.errors import DecoderError

FORMATS = ("onnx", "numpy", "torchscript", "c")


def export(dec: Any, fmt: str, path: str | Path) -> Path:
    """Write `dec` as `fmt` to `path`; returns the path written."""
    path = Path(path)
    if fmt == "numpy":
        return dec.runtime.save(path)
    if fmt == "onnx":
        from spectratac.decode.export.onnx_export import export_onnx

        return export_onnx(dec, path)
    if fmt == "torchscript":
        from spectratac.decode.export.torchscript import export_torchscript

        return export_torchscript(dec, path)
    if fmt == "c":
        from spectratac.decode.export.c_export import export_c

        return export_c(dec, path)
    raise DecoderError(f"unknown export format {fmt!r}: choose one of {', '.join(FORMATS)}")
