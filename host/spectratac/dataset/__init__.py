"""Datasets: aligned optical samples, reference F/T targets and labels in one `.npz`.

The file format is defined in `spectratac.dataset.schema`.
"""

from __future__ import annotations

from spectratac.dataset.schema import (
    FT_NAMES,
    SPECTRATAC_INPUTS,
    Dataset,
    DatasetError,
    concat,
    split_by_config,
)

__all__ = [
    "FT_NAMES",
    "SPECTRATAC_INPUTS",
    "Dataset",
    "DatasetError",
    "concat",
    "split_by_config",
]
