"""C export: one header with the weights and a C11 inference function (no heap).

The code is `c_template.TEMPLATE`; this module only writes the sizes and the arrays. Values
are written with 17 significant digits (exact for float64; a float build rounds them once).

>>> fmt_values([1.5, float("inf"), -float("inf")])
'1.5, HUGE_VAL, -HUGE_VAL'
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from spectratac.decode.assemble import DROP, GATE, HOLD, JOIN, STILL, STUCK, TAU
from spectratac.decode.export.c_template import TEMPLATE
from spectratac.decode.guard import DARK_COUNTS
from spectratac.decode.networks import SKIP
from spectratac.decode.rest_signature import log_counts


def fmt_values(values: Iterable[float]) -> str:
    out = []
    for v in values:
        v = float(v)
        if np.isnan(v):
            out.append("NAN")
        elif np.isinf(v):
            out.append("HUGE_VAL" if v > 0 else "-HUGE_VAL")
        else:
            out.append(repr(v) if v != int(v) or abs(v) > 1e15 else f"{v:.1f}")
    return ", ".join(out)


def _array(name: str, a: Any) -> str:
    a = np.asarray(a, dtype=np.float64)
    dims = "".join(f"[{d}]" for d in a.shape)
    body = _nested(a)
    return f"static const stac_real {name}{dims} = {body};"


def _nested(a: np.ndarray) -> str:
    if a.ndim == 1:
        vals = fmt_values(a)
        return "{" + vals + "}"
    return "{" + ",\n  ".join(_nested(x) for x in a) + "}"


def _ints(values: Iterable[int]) -> str:
    return ", ".join(str(int(v)) for v in values)


def _comment(text: str) -> str:
    return text.replace("*/", "* /").replace("\n", " ")


def render(dec: Any) -> str:
    rt = dec.runtime
    fs, w, heads, guard = rt.features, rt.weights, rt.heads, dec.guard
    kind, hidden, blocks = rt.arch
    lay = dec.layout
    n_lin, n_rat = fs.L.shape[0], fs.P.shape[0]
    rest = bool(lay.drift and len(lay.rest) == lay.base and len(lay.press) == lay.base)
    defines = {
        "STAC_N_IN": rt.n_inputs,
        "STAC_N_BASE": dec.layout.base,
        "STAC_HAS_DIST": int(guard.center is not None),
        "STAC_N_LIN": n_lin,
        "STAC_N_RAT": n_rat,
        "STAC_N_MON": int(fs.M.shape[0]),
        "STAC_N_FEAT": fs.n_features,
        "STAC_HIDDEN": hidden,
        "STAC_BLOCKS": blocks,
        "STAC_N_OUT": heads.n_out,
        "STAC_N_REG": heads.n_reg,
        "STAC_N_STD": heads.n_reg if heads.uncertainty else 0,
        "STAC_N_CLASSES": heads.n_classes,
        "STAC_HAS_CONTACT": int(heads.contact),
        "STAC_ARCH_LINEAR": int(kind == "linear"),
        "STAC_ARCH_MLP": int(kind == "mlp"),
        "STAC_HAS_SKIP": int(SKIP in w),
        "STAC_SATURATION": int(guard.saturation) if guard.saturation else 0,
        "STAC_N_DARK": len(guard.dark_cols),
        "STAC_DARK_COUNTS": f"{DARK_COUNTS:.1f}",
        # assembly of live samples (decode/assemble.py)
        "STAC_N_CH": len(lay.channels),
        "STAC_STEPS": lay.steps,
        "STAC_N_LAGS": len(lay.lags),
        "STAC_HIST": max(lay.lags, default=0) + 1,
        "STAC_N_EMA": len(lay.emas),
        "STAC_DRIFT": int(lay.drift),
        "STAC_BASE_TAU": repr(float(TAU)),
        "STAC_BASE_GATE": repr(float(GATE)),
        "STAC_BASE_STUCK": f"{int(STUCK)}L",
        # the search for rest before the baseline adapts (a layout with a rest signature)
        "STAC_HAS_REST": int(rest),
        "STAC_REST_JOIN": repr(float(JOIN)),
        "STAC_REST_DROP": repr(float(DROP)),
        "STAC_REST_STILL": f"{int(STILL)}L",
        "STAC_REST_HOLD": f"{int(HOLD)}L",
    }
    data = [_array("stac_center", rt.center)]
    if n_lin:
        data.append(_array("stac_L", fs.L))
    if n_rat:
        data += [_array("stac_P", fs.P), _array("stac_Q", fs.Q)]
    if fs.M.shape[0]:
        rows = ",\n  ".join("{" + ", ".join(str(int(i)) for i in m) + "}" for m in fs.M)
        data.append(f"static const int stac_M[{fs.M.shape[0]}][3] = {{{rows}}};")
    data += [
        _array("stac_f_mean", rt.scaler.mean),
        _array("stac_f_inv_std", 1.0 / rt.scaler.std),
    ]
    if kind == "mlp":
        data += [
            _array("stac_layer0_w", w["layers.0.weight"]),
            _array("stac_layer0_b", w["layers.0.bias"]),
        ]
        if blocks > 1:
            data += [
                _array(
                    "stac_layers_w", np.stack([w[f"layers.{i}.weight"] for i in range(1, blocks)])
                ),
                _array(
                    "stac_layers_b", np.stack([w[f"layers.{i}.bias"] for i in range(1, blocks)])
                ),
            ]
    elif kind == "resmlp":
        data += [_array("stac_stem_w", w["stem.weight"]), _array("stac_stem_b", w["stem.bias"])]
        for key, cname in (
            ("norm.weight", "stac_norm_g"),
            ("norm.bias", "stac_norm_b"),
            ("fc1.weight", "stac_fc1_w"),
            ("fc1.bias", "stac_fc1_b"),
            ("fc2.weight", "stac_fc2_w"),
            ("fc2.bias", "stac_fc2_b"),
        ):
            data.append(_array(cname, np.stack([w[f"blocks.{i}.{key}"] for i in range(blocks)])))
        data += [_array("stac_final_g", w["norm.weight"]), _array("stac_final_b", w["norm.bias"])]
    data += [_array("stac_head_w", w["head.weight"]), _array("stac_head_b", w["head.bias"])]
    if SKIP in w:
        data.append(_array("stac_skip_w", w[SKIP]))
    if heads.n_reg:
        data += [
            _array("stac_y_scale", rt.y_scale),
            _array("stac_t_lo", guard.t_lo),
            _array("stac_t_hi", guard.t_hi),
            _array("stac_edge_lo", guard.edge_bounds()[0]),
            _array("stac_edge_hi", guard.edge_bounds()[1]),
        ]
    if heads.uncertainty and heads.n_reg:
        data.append(_array("stac_std_mul", rt.y_scale * rt.std_scale))
    data += [_array("stac_in_lo", guard.in_lo), _array("stac_in_hi", guard.in_hi)]
    if guard.center is not None and guard.whiten is not None and guard.dist_max is not None:
        data += [
            _array("stac_dist_center", guard.center),
            _array("stac_dist_whiten", guard.whiten),
            f"#define STAC_DIST_MAX {float(guard.dist_max[0])!r}",
        ]
    if guard.dark_cols:
        cols = _ints(guard.dark_cols)
        data.append(f"static const int stac_dark_cols[{len(guard.dark_cols)}] = {{{cols}}};")
    if lay.lags:
        data.append(f"static const int stac_lags[{len(lay.lags)}] = {{{_ints(lay.lags)}}};")
    if lay.emas:
        alpha = fmt_values(1.0 / np.asarray(lay.emas, dtype=np.float64))
        data.append(f"static const double stac_ema_alpha[{len(lay.emas)}] = {{{alpha}}};")
    if rest:  # double, as the host's search computes (decode/rest_signature.py)
        press = np.asarray(lay.press, np.float64)
        score = float(np.dot(press, log_counts(np.asarray(lay.rest, np.float64))))
        data += [
            f"static const double stac_rest[{lay.base}] = {{{fmt_values(lay.rest)}}};",
            f"static const double stac_press[{lay.base}] = {{{fmt_values(press)}}};",
            f"#define STAC_REST_SCORE {score!r}",
        ]
    banner = (
        f"decoder {dec.meta.get('spec', {}).get('model', '?')} on features "
        f"{fs.kind}; unit {dec.unit_id}; config {json.dumps(dec.config)}"
    )
    text = TEMPLATE
    for key, value in (
        ("@BANNER@", _comment(banner)),
        ("@LAYOUT@", _comment(", ".join(dec.layout.names()))),
        ("@OUTPUTS@", _comment(", ".join(heads.output_names()))),
        ("@DEFINES@", "\n".join(f"#define {k} {v}" for k, v in defines.items())),
        ("@DATA@", "\n".join(data)),
    ):
        text = text.replace(key, value)
    return text


def export_c(dec: Any, path: Path) -> Path:
    path.write_text(render(dec), encoding="utf-8")
    return path
