"""Write an evaluation as report.json, report.md and the Fig. 3 panels (PNG) into a folder.

Per evaluated section (random split, blocked split, or the whole held-out dataset) the
table puts our decoder, the paper's reported figures, the twin oracle's reference (simulated data)
and an optional baseline side by side.

>>> import numpy as np, tempfile, pathlib, json
>>> from spectratac.dataset import Dataset
>>> from spectratac.evaluate.predictions import Predictions
>>> from spectratac.evaluate.run import evaluate_model
>>> class Half:
...     meta = {}
...     def predict(self, dataset, rows):
...         return Predictions(["Fz"], 0.5 * dataset.targets[rows])
>>> ds = Dataset.generic(np.zeros((30, 1)), np.linspace(0, 3, 30), ["a"], ["Fz"])
>>> out = pathlib.Path(tempfile.mkdtemp())
>>> rep = write_report(evaluate_model(Half(), ds), out, {"path": "x.npz"})
>>> sorted(p.name for p in out.iterdir())
['all_abs_error.png', 'all_scatter.png', 'all_timeseries.png', 'report.json', 'report.md']
>>> round(json.loads((out / "report.json").read_text())["sections"]["all"]["decoder"]
...       ["components"]["Fz"]["mae"], 3)
0.75
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from spectratac.dataset.schema import Dataset
from spectratac.evaluate import plots
from spectratac.evaluate.paper import paper_figures, paper_mae
from spectratac.evaluate.run import Evaluation, Section

NO_CONTACT_LABELS = "no labels: the dataset has no contact column"
TITLES = {
    "random": "Random split (the paper's protocol; leaks near-duplicate neighbours)",
    "blocked": "Blocked split (whole presses / time blocks held out: measures generalisation)",
    "all": "Whole dataset",
    "training": "Training rows (NOT held out: the model's training error)",
    "sessions": "Held-out sessions",
}


def is_spectratac(dataset: Dataset | None) -> bool:
    """Whether the paper's figures apply: the dataset's sensor metadata says SpectraTac (a
    dataset built from SpectraTac recordings); other sensors' data get no paper column."""
    return dataset is not None and dataset.meta.get("kind") == "spectratac"


def report_dict(
    ev: Evaluation, dataset_info: dict[str, Any], model: dict[str, Any], paper: bool = True
) -> dict:
    """JSON-ready report; `paper`: include the paper's figures (SpectraTac data only)."""
    sections: dict[str, Any] = {}
    for name, s in ev.sections.items():
        d: dict[str, Any] = {"note": s.note, "available": s.available, "n_rows": int(s.rows.size)}
        if s.decoder is not None:
            d["decoder"] = s.decoder.scores
            d["model"] = s.model_info
            d["per_session"] = s.per_session
        if s.oracle is not None:
            d["oracle"] = s.oracle.scores
        if s.oracle_note:
            d["oracle_note"] = s.oracle_note
        if s.baseline is not None:
            d["baseline"] = s.baseline.scores
        if s.baseline_note:
            d["baseline_note"] = s.baseline_note
        sections[name] = d
    return _clean(
        {
            "format": "spectratac.evaluation",
            "version": 1,
            "model": model,
            "dataset": dataset_info,
            "notes": ev.notes,
            "paper": paper_figures() if paper else None,
            "sections": sections,
        }
    )


def _clean(v: Any) -> Any:
    """NaN/inf become null so that report.json is strict JSON."""
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_clean(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def _f(v: Any, digits: int = 4) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{v:.{digits}g}" if isinstance(v, float) else str(v)


def section_markdown(s: Section, paper: bool = True) -> list[str]:
    """Markdown lines for one section; `paper`: show the paper's figures (SpectraTac data)."""
    lines = [f"## {TITLES.get(s.name, s.name)}", "", s.note, ""]
    if s.decoder is None:
        return lines
    comp = s.decoder.scores["components"]
    head = "| component | MAE | RMSE | R² | p95 abs err |" + (" paper MAE |" if paper else "")
    rule = "|---|---:|---:|---:|---:|" + ("---:|" if paper else "")
    if s.oracle is not None:
        head += f" oracle MAE (n={s.oracle.scores['n']}) | oracle R² |"
        rule += "---:|---:|"
    if s.baseline is not None:
        head += " baseline MAE | change vs baseline |"
        rule += "---:|---:|"
    lines += [head, rule]
    for name, m in comp.items():
        row = (
            f"| {name} | {_f(m['mae'])} | {_f(m['rmse'])} | {_f(m['r2'], 3)} | "
            f"{_f(m.get('p95'))} |" + (f" {paper_mae(name) or '–'} |" if paper else "")
        )
        if s.oracle is not None:
            o = s.oracle.scores["components"].get(name, {})
            row += f" {_f(o.get('mae'))} | {_f(o.get('r2'), 3)} |"
        if s.baseline is not None:
            b = s.baseline.scores["components"].get(name, {})
            bm = b.get("mae")
            ch = 100 * (m["mae"] - bm) / bm if bm else float("nan")
            row += f" {_f(bm)} | {ch:+.1f} % |"
        lines.append(row)
    lines.append("")
    reg = s.decoder.scores.get("region")
    if reg is not None:
        refs = (["paper 99.9 %"] if paper else []) + (
            [f"oracle {_pct(s.oracle.scores['region']['accuracy'])}"] if s.oracle else []
        )
        lines.append(
            f"Region accuracy: **{_pct(reg['accuracy'])}** on {reg['n']} labelled rows"
            + (f" ({'; '.join(refs)})." if refs else ".")
        )
    con = s.decoder.scores.get("contact")
    if con is not None and con.get("labels") == "none":
        lines.append(f"Contact detection: not scored ({NO_CONTACT_LABELS}).")
    elif con is not None:
        lines.append(
            f"Contact detection: accuracy {_pct(con['accuracy'])}, precision "
            f"{_pct(con['precision'])}, recall {_pct(con['recall'])}."
        )
    cov = s.decoder.scores.get("coverage")
    if cov is not None:
        cells = ", ".join(
            f"{k} {_pct(v.get('0.68'))}/{_pct(v.get('0.95'))}" for k, v in cov.items()
        )
        lines.append(f"Interval coverage (nominal 68 %/95 %): {cells}.")
    if s.oracle_note:
        lines.append(f"Oracle: {s.oracle_note}.")
    if s.baseline_note:
        lines.append(f"Baseline: {s.baseline_note}.")
    lines.append("")
    lines += per_session_markdown(s)
    lines += [f"![{p}]({p})" for p in _panel_names(s)]
    lines.append("")
    return lines


def per_session_markdown(s: Section) -> list[str]:
    """A table of MAE per session (only when the section spans more than one session)."""
    if len(s.per_session) < 2 or s.decoder is None:
        return []
    names = s.decoder.names
    lines = [
        "| session | unit | rows | " + " | ".join(f"{n} MAE" for n in names) + " |",
        "|---:|---|---:|" + "---:|" * len(names),
    ]
    for sid, d in s.per_session.items():
        cells = " | ".join(_f(d["mae"].get(n)) for n in names)
        unit = d["unit"] if d["unit"] is not None else "–"
        lines.append(f"| {sid} | {unit} | {d['n']} | {cells} |")
    return [*lines, ""]


def _pct(v: Any) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{100 * v:.2f} %"


def _panel_names(s: Section) -> list[str]:
    names = [f"{s.name}_scatter.png", f"{s.name}_timeseries.png"]
    if s.decoder is not None and any(n.startswith("F") for n in s.decoder.names):
        names.append(f"{s.name}_abs_error.png")
    if s.decoder is not None and len(s.decoder.names) > 1:
        names.append(f"{s.name}_r2.png")
    if s.decoder is not None and "region" in s.decoder.scores:
        names.append(f"{s.name}_confusion.png")
    if s.history:
        names.append(f"{s.name}_loss.png")
    return names


def write_panels(s: Section, dataset: Dataset | None, out: Path, paper: bool = True) -> list[Path]:
    """The Fig. 3 panels of one section (the paper's marks only for SpectraTac data)."""
    if s.decoder is None:
        return []
    d = s.decoder
    paths = [plots.scatter_grid(d.y_true, d.y_pred, d.names, out / f"{s.name}_scatter.png")]
    forces = [i for i, n in enumerate(d.names) if n.startswith("F")]
    if forces:
        mae = paper_figures()["mae"].items()
        ref = {k: float(v) for k, v in mae if isinstance(v, float)} if paper else {}
        paths.append(
            plots.error_histograms(
                d.y_true[:, forces],
                d.y_pred[:, forces],
                [d.names[i] for i in forces],
                out / f"{s.name}_abs_error.png",
                ref,
            )
        )
    if len(d.names) > 1:
        r2 = {n: d.scores["components"][n]["r2"] for n in d.names}
        floor = paper_figures()["r2_min"] if paper else None
        paths.append(plots.r2_bars(r2, out / f"{s.name}_r2.png", floor))
    if "region" in d.scores:
        paths.append(
            plots.confusion(d.scores["region"]["confusion"], out / f"{s.name}_confusion.png")
        )
    t = (
        np.asarray(dataset.arrays["t_start"])[d.rows]
        if dataset is not None
        else np.arange(d.rows.size, dtype=np.float64)
    )
    idx = plots.excerpt(t)
    paths.append(
        plots.time_series(
            t[idx],
            d.y_true[idx],
            d.y_pred[idx],
            d.names,
            out / f"{s.name}_timeseries.png",
            f"{s.name}: {idx.size} consecutive evaluation rows",
        )
    )
    if s.history:
        paths.append(plots.loss_curve(s.history, out / f"{s.name}_loss.png"))
    return paths


def write_report(
    ev: Evaluation,
    out: str | Path,
    dataset_info: dict[str, Any],
    model: dict[str, Any] | None = None,
    dataset: Dataset | None = None,
) -> dict[str, Any]:
    """Write report.json, report.md and the panels into `out`; return the JSON dict."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paper = is_spectratac(dataset)
    rep = report_dict(ev, dataset_info, model or {}, paper)
    (out / "report.json").write_text(json.dumps(rep, indent=1) + "\n")
    lines = ["# SpectraTac decoder evaluation", ""]
    lines += [
        f"- model: `{(model or {}).get('path', '?')}`",
        f"- dataset: `{dataset_info.get('path', '?')}`",
    ]
    lines += [f"- {n}" for n in ev.notes if n]
    # The paper's figures describe SpectraTac; other sensors get no paper column.
    if paper:
        lines.append(
            "- paper (spectratac.tex): MAE 0.161 / 0.164 / 0.429 N (Fx, Fy, Fz), torques "
            "≤ 0.004 N·m, R² > 0.91 on all six, region accuracy 99.9 %; its test split is "
            "not described (read as random)"
        )
    lines.append("")
    for s in ev.sections.values():
        lines += section_markdown(s, paper)
        write_panels(s, dataset, out, paper)
    (out / "report.md").write_text("\n".join(lines))
    return rep
