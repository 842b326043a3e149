"""Markdown tables and the Pareto plot of the decoder benchmarks (variants; speed vs error).

>>> rows = [{"name": "paper", "flops": 10, "params": 5,
...          "blocked": {"mae": {"Fx": 0.2, "Fy": 0.2, "Fz": 0.4}, "r2_mean": 0.9,
...                      "r2_min": 0.8, "region_accuracy": 0.99, "contact_accuracy": 0.9,
...                      "improvement_pct": {"Fx": 0.0, "Fy": 0.0, "Fz": 0.0}}}]
>>> print(variants_markdown(rows, "blocked").splitlines()[2][:37])
| paper | 0.2 (+0.0 %) | 0.2 (+0.0 %)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from spectratac.hardware.generated import vocabulary as vocab
from spectratac.studies.bench.speed import pareto_front

LATENCY_TOL = 0.10  # latencies within 10 % are treated as equal on the latency front


def _f(v: Any, digits: int = 3) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{v:.{digits}g}" if isinstance(v, float) else str(v)


def _pct(v: Any) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{100 * v:.2f} %"


def _mae_cell(d: dict[str, Any], axis: str) -> str:
    """MAE (± its spread over training seeds) (change against the paper)."""
    sd = d.get("mae_std", {}) if d.get("seeds", 1) > 1 else {}
    imp = d.get("improvement_pct", {})
    v = _f(d["mae"].get(axis)) + (f" ± {sd[axis]:.2g}" if axis in sd else "")
    return f"{v} ({imp[axis]:+.1f} %)" if axis in imp else v


def variants_markdown(rows: Sequence[dict[str, Any]], kind: str) -> str:
    """One split's side-by-side table; MAE cells carry the change against the paper."""
    head = (
        "| variant | Fx MAE (N) | Fy MAE (N) | Fz MAE (N) | R² mean / min | region acc | "
        "contact acc | coverage 68 / 95 % | flops/sample | latency µs (x paper) | train s |"
    )
    lines = [head, "|" + "---|" * 11]
    for r in rows:
        d = r.get(kind)
        if d is None:
            continue
        cells = [_mae_cell(d, a) for a in vocab.FORCE_AXES]
        cov = d.get("coverage")
        cov_s = f"{_pct(cov['0.68'])} / {_pct(cov['0.95'])}" if cov else "–"
        lat = r.get("latency_us")
        lat_s = f"{lat:.0f} ({r.get('latency_ratio', float('nan')):.2f})" if lat else "–"
        lines.append(
            f"| {r['name']} | {' | '.join(cells)} | {_f(d['r2_mean'])} / {_f(d['r2_min'])} | "
            f"{_pct(d['region_accuracy'])} | {_pct(d['contact_accuracy'])} | {cov_s} | "
            f"{r['flops']:,} | {lat_s} | {_f(d.get('train_s'))} |"
        )
    return "\n".join(lines)


def grid_markdown(rows: Sequence[dict[str, Any]]) -> str:
    """Speed-versus-error table, one row per (acquisition, model)."""
    head = (
        "| IT ms | LEDs | model | obs/s | params | latency µs (p99) | x ref | train s (x ref) | "
        "Fx MAE | Fy MAE | Fz MAE | R² mean | region acc | Pareto rate / latency |"
    )
    front = set(pareto_front([(r["observations_per_s"], r["force_mae_mean"]) for r in rows]))
    fast = set(latency_front(rows))
    lines = [head, "|" + "---|" * 14]
    for i, r in enumerate(rows):
        lat = r.get("latency_us")
        lat_s = f"{lat:.0f} ({r['latency_p99_us']:.0f})" if lat else "–"
        lines.append(
            f"| {r['integration_ms']} | {r['sequence']} | {r['model']} | "
            f"{r['observations_per_s']:.3g} | {r['params']:,} | {lat_s} | "
            f"{_f(r.get('latency_ratio'))} | {_f(r['train_s'])} ({_f(r.get('train_ratio'))}) | "
            f"{_f(r['mae'].get('Fx'))} | {_f(r['mae'].get('Fy'))} | {_f(r['mae'].get('Fz'))} | "
            f"{_f(r['r2_mean'])} | {_pct(r['region_accuracy'])} | "
            f"{'*' if i in front else ''} / {'*' if i in fast else ''} |"
        )
    return "\n".join(lines)


def latency_front(rows: Sequence[dict[str, Any]], tol: float = LATENCY_TOL) -> list[int]:
    """Rows no other row beats on latency and error, where latencies within `tol` (relative)
    count as equal: timing noise between equal-sized models must not pick the front.

    >>> latency_front([{"latency_us": 10.0, "force_mae_mean": 1.0},
    ...                {"latency_us": 10.5, "force_mae_mean": 0.5},
    ...                {"latency_us": 30.0, "force_mae_mean": 0.4}])
    [1, 2]
    """
    out = []
    for i, r in enumerate(rows):
        li, ei = r.get("latency_us") or math.inf, r["force_mae_mean"]
        beaten = False
        for j, q in enumerate(rows):
            lj, ej = q.get("latency_us") or math.inf, q["force_mae_mean"]
            if j == i:
                continue
            no_slower = lj <= li * (1 + tol)
            if (no_slower and ej < ei) or (lj * (1 + tol) < li and ej <= ei):
                beaten = True
                break
        if not beaten and math.isfinite(ei):
            out.append(i)
    return out


def pareto_plot(rows: Sequence[dict[str, Any]], path: Path) -> Path:
    """Mean force MAE against full observations per second (left) and against single-sample
    latency (right); colour = model, marker = LED sequence, label = integration time; the
    rate/error Pareto front as a line."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    models = sorted({r["model"] for r in rows}, key=lambda m: [r["model"] for r in rows].index(m))
    seqs = ["white", "rgb", "per-led"]
    markers = dict(zip(seqs, ["o", "s", "^"], strict=True))
    colours = {m: f"C{i}" for i, m in enumerate(models)}
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    for r in rows:
        kw = {"color": colours[r["model"]], "marker": markers.get(r["sequence"], "x"), "s": 28}
        axes[0].scatter(r["observations_per_s"], r["force_mae_mean"], **kw)
        axes[0].annotate(
            str(r["integration_ms"]),
            (r["observations_per_s"], r["force_mae_mean"]),
            fontsize=6,
            xytext=(3, 2),
            textcoords="offset points",
        )
        if r.get("latency_us"):
            axes[1].scatter(r["latency_us"], r["force_mae_mean"], **kw)
    pts = [(r["observations_per_s"], r["force_mae_mean"]) for r in rows]
    lat = [(r.get("latency_us") or float("nan"), r["force_mae_mean"]) for r in rows]
    for ax, xy, idx in (
        (axes[0], pts, pareto_front(pts)),
        (axes[1], lat, latency_front(rows)),
    ):
        front = sorted((xy[i] for i in idx), key=lambda p: p[0])
        if front:
            ax.plot(*zip(*front, strict=True), "k--", lw=1)
            ax.scatter(
                *zip(*front, strict=True),
                s=90,
                facecolors="none",
                edgecolors="k",
                label="Pareto front",
            )
    plain = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")
    for ax in axes:
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(plain)
        ax.xaxis.set_minor_formatter(plain)
        ax.tick_params(axis="x", which="minor", labelsize=6)
    axes[0].set_xlabel("full observations per second (log)")
    axes[0].set_ylabel("mean force MAE, blocked split (N)")
    axes[1].set_xlabel("single-sample inference latency (µs, log)")
    for m in models:
        axes[1].scatter([], [], color=colours[m], marker="o", label=m)
    for s in seqs:
        axes[1].scatter([], [], color="gray", marker=markers[s], label=f"LEDs: {s}")
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=7, loc="best")
    fig.suptitle("Speed against error (labels: integration time, ms)", fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
