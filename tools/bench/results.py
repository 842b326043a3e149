"""What a run of `python -m tools.bench` keeps: results per commit, their comparison, and rows
of the measurements log.

Results of commit C are kept in `build/bench/results/C.json` (`C-quick.json` for `--quick`
runs): per benchmark, its figures (benchlib.Figure as dicts), the command, when and where it
ran (date, 1-minute load average, Python, machine). A later run of some benchmarks at the same
commit replaces their entries and keeps the others. Two commits compare by ratio: each figure
is already a ratio to a reference measured in its own run, so the ratio of those ratios says
what changed between the commits without the machine's load in it.
"""

from __future__ import annotations

import datetime as dt
import json
import os
import platform
import subprocess
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
RESULTS = REPO / "build" / "bench" / "results"
MEASUREMENTS = Path(__file__).resolve().parent / "MEASUREMENTS.md"
LOG_COLUMNS = ("date", "commit", "what", "figure", "reference (same run)", "load", "command")
LOG_HEADER = (
    "# Measurements log\n\n"
    "One row per measurement; `python -m tools.bench --log` appends the figures of a run.\n\n"
    f"| {' | '.join(LOG_COLUMNS)} |\n|{'---|' * len(LOG_COLUMNS)}\n"
)


def git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, check=False)
    except OSError:
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def head() -> tuple[str, bool]:
    """(the checked-out commit, whether the tree has uncommitted changes to tracked files)."""
    commit = git("rev-parse", "HEAD") or "unknown"
    dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    return commit, dirty


def machine() -> dict[str, Any]:
    """Where a benchmark ran, and how busy the machine was as it ended."""
    return {
        "date": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "loadavg": [round(v, 2) for v in os.getloadavg()],
        "python": platform.python_version(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, {platform.system()} "
        f"{platform.release()}",
    }


def results_path(folder: Path, commit: str, quick: bool) -> Path:
    return folder / f"{commit}{'-quick' if quick else ''}.json"


def save(folder: Path, commit: str, dirty: bool, quick: bool, runs: Mapping[str, Any]) -> Path:
    """Merge `runs` (benchmark name -> its entry) into the commit's results file."""
    path = results_path(folder, commit, quick)
    kept = json.loads(path.read_text()) if path.exists() else {"benchmarks": {}}
    kept.update(commit=commit, dirty=dirty or kept.get("dirty", False), quick=quick)
    kept["benchmarks"].update(runs)
    folder.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(kept, indent=1) + "\n")
    tmp.replace(path)
    return path


def find(ref: str, folder: Path, quick: bool) -> Path:
    """The results file of `ref`: a path to one, or a commit (any name git knows)."""
    if ref.endswith(".json") and Path(ref).exists():
        return Path(ref)
    commit = git("rev-parse", "--verify", "--quiet", f"{ref}^{{commit}}") or ref
    path = results_path(folder, commit, quick)
    if not path.exists():
        run = "python -m tools.bench" + (" --quick" if quick else "")
        raise SystemExit(f"no kept results of {ref} ({path}): check it out and run `{run}`")
    return path


@dataclass(frozen=True)
class Change:
    bench: str
    figure: str
    ratio_a: float
    ratio_b: float
    headline: bool

    @property
    def change(self) -> float:
        """B's ratio over A's: above 1 the figure grew against its reference."""
        return self.ratio_b / self.ratio_a if self.ratio_a else float("nan")


def compare(a: Mapping[str, Any], b: Mapping[str, Any]) -> list[Change]:
    """Figures present in both results, benchmark by benchmark (headline first)."""
    out = []
    for bench, run_a in a["benchmarks"].items():
        run_b = b["benchmarks"].get(bench)
        if run_b is None:
            continue
        ratios_b = {f["name"]: f["ratio"] for f in run_b.get("figures", [])}
        figures = sorted(
            run_a.get("figures", []), key=lambda f: f["name"] != run_a.get("headline")
        )
        out += [
            Change(bench, f["name"], f["ratio"], ratios_b[f["name"]],
                   f["name"] == run_a.get("headline"))
            for f in figures
            if f["name"] in ratios_b
        ]  # fmt: skip
    return out


def number(v: Any) -> str:
    if isinstance(v, bool) or not isinstance(v, int | float):
        return str(v)
    if abs(v) >= 1000:
        return f"{v:,.0f}"
    return f"{v:.4g}"


def cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def log_rows(
    bench: str, run: Mapping[str, Any], commit: str, dirty: bool
) -> list[str]:
    """One measurements-log row per figure of one benchmark's run."""
    short = commit[:7] + ("-dirty" if dirty else "")
    load = f"{run['loadavg'][0]:.1f}"
    command = f"`{' '.join(['python', *run['command']])}`"
    rows = []
    for f in run["figures"]:
        figure = f"{number(f['value'])} {f['unit']} ({number(f['ratio'])}×)"
        reference = f"{f['reference_name']}: {number(f['reference_value'])}"
        cells = (run["date"][:10], short, f"{bench}: {f['name']}", figure, reference, load,
                 command)  # fmt: skip
        rows.append("| " + " | ".join(cell(c) for c in cells) + " |")
    return rows


def append_log(path: Path, rows: Iterable[str]) -> int:
    """Append rows to the log's table (the last table of the file), creating the file with its
    header if there is none; returns how many were appended."""
    rows = list(rows)
    text = path.read_text(encoding="utf-8") if path.exists() else LOG_HEADER
    lines = text.splitlines()
    last = max((i for i, line in enumerate(lines) if line.startswith("|")), default=None)
    if last is None:
        lines += ["", LOG_HEADER.split("\n\n")[-1].rstrip("\n")]
        last = len(lines) - 1
    lines[last + 1 : last + 1] = rows
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return len(rows)
