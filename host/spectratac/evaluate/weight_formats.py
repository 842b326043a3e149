"""What float16 or int8 weights on the device cost in accuracy, measured on data.

`spectratac model upload URL m.stac --weights i8 --data D.npz` reports this before it
uploads. The device runs the network on the rounded weights (`model_image.as_stored`), so
its estimates are the Python decoder's on those weights; both are scored here on every row
with a valid target.

>>> from spectratac.sim.generic_skin import generic_skin
>>> from spectratac.train import TrainSpec, train
>>> ds = generic_skin(sessions=2, session_s=4.0, seed=1)
>>> dec = train(ds, TrainSpec(model="mlp", hidden=16, blocks=1, epochs=2,
...                           features="generic", targets=("Fz",)), progress=False)
>>> e = weight_format_error(dec, ds, "i8")
>>> e["weights"], sorted(e["targets"]["Fz"])
('i8', ['extra_mae', 'mae', 'mae_f32', 'max_abs_change'])
>>> e["targets"]["Fz"]["max_abs_change"] > 0.0
True
"""

from __future__ import annotations

from typing import Any

import numpy as np

from spectratac.dataset.schema import Dataset
from spectratac.decode.decoder import Decoder
from spectratac.decode.export.model_image import as_stored


def weight_format_error(dec: Decoder, ds: Dataset, weights: str) -> dict[str, Any]:
    """Per regression target: MAE with float32 weights, with `weights`, their difference
    (`extra_mae`, N or N·m) and the largest change of one estimate; and the share of rows
    whose region changes."""
    ref = dec.predict(ds)
    got = as_stored(dec, weights).predict(ds)
    truth = np.asarray(ds.targets, np.float64)
    ok_rows = np.asarray(ds.target_valid, bool)
    out: dict[str, Any] = {"weights": weights, "rows": int(ds.n), "targets": {}}
    for j, name in enumerate(ref.target_names):
        if name not in ds.target_names:
            continue
        y = truth[:, ds.target_names.index(name)]
        a, b = ref.targets[:, j], got.targets[:, j]
        ok = ok_rows & np.isfinite(y) & np.isfinite(a) & np.isfinite(b)
        if not ok.any():
            continue
        mae32 = float(np.mean(np.abs(a[ok] - y[ok])))
        mae = float(np.mean(np.abs(b[ok] - y[ok])))
        out["targets"][name] = {
            "mae_f32": mae32,
            "mae": mae,
            "extra_mae": mae - mae32,
            "max_abs_change": float(np.max(np.abs(b[ok] - a[ok]))),
        }
    decided = (ref.region > 0) | (got.region > 0)
    out["region_changed"] = float(np.mean(ref.region[decided] != got.region[decided])) if (
        decided.any()) else 0.0  # fmt: skip
    return out


def render(e: dict[str, Any]) -> str:
    """Human lines: one per target, then the region changes."""
    lines = [f"  {e['weights']} weights against f32 on {e['rows']} rows of the data:"]
    for name, t in e["targets"].items():
        lines.append(
            f"    {name:<4} MAE {t['mae']:.4g} (f32 {t['mae_f32']:.4g}, "
            f"extra {t['extra_mae']:+.3g}), largest change of one estimate "
            f"{t['max_abs_change']:.3g}"
        )
    lines.append(f"    region changed on {100 * e['region_changed']:.2f} % of decided rows")
    return "\n".join(lines)
