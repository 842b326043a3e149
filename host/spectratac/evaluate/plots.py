"""The panels of the paper's Fig. 3 as PNG files (matplotlib, Agg backend, no display).

(c) training loss, (d) R² per component, (e) absolute-error distributions of the forces,
(f) 9x9 region confusion matrix, (g) predicted versus true per component, plus a
predicted-versus-true time series excerpt (the paper's Fig. 4 style) on held-out rows.

>>> import numpy as np, tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> y = np.random.default_rng(0).normal(size=(50, 2))
>>> scatter_grid(y, y + 0.1, ["Fx", "Fz"], d / "s.png").exists()
True
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.hardware.generated import vocabulary as vocab

F64 = NDArray[np.float64]
DPI = 110
MAX_SCATTER = 20_000  # points per panel; more only slows the PNG down


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _unit(name: str) -> str:
    return vocab.AXIS_UNITS.get(name, "N" if name.startswith("F") else "N·m")


def _save(fig: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    _plt().close(fig)
    return path


def _grid(n: int) -> tuple[int, int]:
    cols = min(3, n)
    return -(-n // cols), cols


def scatter_grid(
    y_true: F64, y_pred: F64, names: Sequence[str], path: Path, title: str = ""
) -> Path:
    """Predicted versus true, one panel per component, with the identity line."""
    plt = _plt()
    r, c = _grid(len(names))
    fig, axes = plt.subplots(r, c, figsize=(3.4 * c, 3.2 * r), squeeze=False)
    step = max(1, y_true.shape[0] // MAX_SCATTER)
    for j, name in enumerate(names):
        ax = axes.flat[j]
        ok = np.isfinite(y_true[:, j]) & np.isfinite(y_pred[:, j])
        yt, yp = y_true[ok, j][::step], y_pred[ok, j][::step]
        ax.scatter(yt, yp, s=2, alpha=0.3, color="tab:blue", rasterized=True)
        if yt.size:
            lo, hi = float(min(yt.min(), yp.min())), float(max(yt.max(), yp.max()))
            ax.plot([lo, hi], [lo, hi], "r--", lw=1)
        ax.set_xlabel(f"true {name} ({_unit(name)})")
        ax.set_ylabel(f"predicted {name}")
    for ax in list(axes.flat)[len(names) :]:
        ax.axis("off")
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def error_histograms(
    y_true: F64,
    y_pred: F64,
    names: Sequence[str],
    path: Path,
    reference_mae: dict[str, float] | None = None,
) -> Path:
    """Absolute-error distributions with our MAE (and the paper's, dashed) marked."""
    plt = _plt()
    r, c = _grid(len(names))
    fig, axes = plt.subplots(r, c, figsize=(3.4 * c, 2.8 * r), squeeze=False)
    for j, name in enumerate(names):
        ax = axes.flat[j]
        e = np.abs(y_pred[:, j] - y_true[:, j])
        e = e[np.isfinite(e)]
        if e.size:
            ax.hist(e, bins=60, range=(0, float(np.percentile(e, 99.5)) or 1.0), color="tab:blue")
            ax.axvline(float(e.mean()), color="k", lw=1, label=f"MAE {e.mean():.3g}")
        ref = (reference_mae or {}).get(name)
        if ref is not None:
            ax.axvline(ref, color="r", ls="--", lw=1, label=f"paper {ref:.3g}")
        ax.set_xlabel(f"|error| {name} ({_unit(name)})")
        ax.set_ylabel("samples")
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(names) :]:
        ax.axis("off")
    return _save(fig, path)


def r2_bars(r2: dict[str, float], path: Path, floor: float | None = None) -> Path:
    """R² per component; the paper's lower bound as a dashed line."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5, 3))
    names = list(r2)
    vals = [r2[n] if np.isfinite(r2[n]) else 0.0 for n in names]
    ax.bar(names, vals, color="tab:blue")
    for i, v in enumerate(vals):
        ax.text(i, v, f"{v:.3f}", ha="center", va="bottom", fontsize=7)
    if floor is not None:
        ax.axhline(floor, color="r", ls="--", lw=1, label=f"paper: R² > {floor}")
        ax.legend(fontsize=7, loc="lower right")
    ax.set_ylim(min(0.0, min(vals, default=0.0)), 1.05)
    ax.set_ylabel("R²")
    return _save(fig, path)


def confusion(matrix: Sequence[Sequence[int]], path: Path) -> Path:
    """Row-normalised 9x9 confusion matrix with counts written in each cell."""
    plt = _plt()
    m = np.asarray(matrix, dtype=np.float64)
    norm = m / np.maximum(m.sum(axis=1, keepdims=True), 1)
    fig, ax = plt.subplots(figsize=(4.6, 4))
    im = ax.imshow(norm, cmap="Blues", vmin=0, vmax=1)
    k = m.shape[0]
    for i in range(k):
        for j in range(k):
            if m[i, j]:
                color = "white" if norm[i, j] > 0.5 else "black"
                ax.text(j, i, f"{int(m[i, j])}", ha="center", va="center", fontsize=6, color=color)
    ax.set_xticks(range(k), [str(i + 1) for i in range(k)])
    ax.set_yticks(range(k), [str(i + 1) for i in range(k)])
    ax.set_xlabel("predicted region")
    ax.set_ylabel("true region")
    fig.colorbar(im, ax=ax, fraction=0.046)
    return _save(fig, path)


def time_series(
    t: F64, y_true: F64, y_pred: F64, names: Sequence[str], path: Path, title: str = ""
) -> Path:
    """Predicted (solid blue) versus true (dashed red) over time, one row per component."""
    plt = _plt()
    fig, axes = plt.subplots(len(names), 1, figsize=(8, 1.5 * len(names) + 0.5), sharex=True)
    axes = np.atleast_1d(axes)
    t = t - t[0] if t.size else t
    for j, name in enumerate(names):
        ax = axes[j]
        ax.plot(t, y_true[:, j], "r--", lw=1, label="true")
        ax.plot(t, y_pred[:, j], "b-", lw=0.8, label="predicted")
        ax.set_ylabel(f"{name} ({_unit(name)})", fontsize=8)
    axes[0].legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("time (s)")
    if title:
        fig.suptitle(title, fontsize=9)
    return _save(fig, path)


def loss_curve(history: Sequence[float], path: Path) -> Path:
    """Training loss per epoch."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5, 3))
    ax.plot(np.arange(1, len(history) + 1), history, "o-", ms=3)
    ax.set_xlabel("epoch")
    ax.set_ylabel("training loss")
    ax.set_yscale("log")
    return _save(fig, path)


def excerpt(t: F64, max_s: float = 40.0) -> NDArray[np.int64]:
    """Indices of a contiguous stretch of sorted times `t` (the longest run without a gap
    over 3 sample periods), at most `max_s` long: the time-series panel shows real dynamics.

    >>> excerpt(np.array([0.0, 0.05, 0.1, 5.0, 5.05, 5.1, 5.15]))
    array([3, 4, 5, 6])
    """
    if t.size < 2:
        return np.arange(t.size)
    dt = np.diff(t)
    period = float(np.median(dt))
    breaks = np.flatnonzero(dt > 3 * period)
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks + 1, [t.size]])
    k = int(np.argmax(ends - starts))
    idx = np.arange(starts[k], ends[k])
    return idx[t[idx] - t[idx[0]] <= max_s]
