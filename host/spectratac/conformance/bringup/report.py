"""The bring-up report: one row per check (pass, fail or skipped with its reason) with the
values it measured, as text for a person and as JSON to file with the board.

>>> r = Report(url="sim://", device={})
>>> r.add(Row("clock", SKIPPED, "no cycle counter"))
>>> r.passed, r.counts()
(True, {'pass': 0, 'fail': 0, 'skipped': 1})
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

PASS, FAIL, SKIPPED = "pass", "fail", "skipped"
VERDICTS = (PASS, FAIL, SKIPPED)
#: what a report file says it is: `-o` with --force replaces only a file that says so
KIND = "spectratac bringup report"
#: the first bytes read to recognise a report file (its "kind" comes first)
RECOGNISE_BYTES = 4096


@dataclass
class Row:
    """One check's outcome: `detail` says what was measured or why it was skipped, and what to
    do when it failed; `values` holds the measured figures (JSON-able)."""

    name: str
    verdict: str
    detail: str
    values: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict {self.verdict!r}: one of {VERDICTS}")


@dataclass
class Report:
    url: str
    device: dict[str, Any]
    rows: list[Row] = field(default_factory=list)
    started_utc: str = ""
    interrupted: bool = False

    def add(self, row: Row) -> None:
        self.rows.append(row)

    @property
    def passed(self) -> bool:
        """No check failed (skipped checks say why, and do not fail the board)."""
        return not self.interrupted and all(r.verdict != FAIL for r in self.rows)

    def counts(self) -> dict[str, int]:
        return {v: sum(r.verdict == v for r in self.rows) for v in VERDICTS}

    def as_dict(self) -> dict[str, Any]:
        return {
            "kind": KIND,
            "url": self.url,
            "started_utc": self.started_utc,
            "passed": self.passed,
            "interrupted": self.interrupted,
            "counts": self.counts(),
            "device": self.device,
            "checks": [
                {
                    "name": r.name,
                    "verdict": r.verdict,
                    "detail": r.detail,
                    "seconds": round(r.seconds, 3),
                    "values": r.values,
                }
                for r in self.rows
            ],
        }

    def text(self) -> str:
        """The report for a person: a line per check, then the LED response matrix."""
        lines = [f"bring-up of {self.url} ({self.started_utc})"]
        width = max((len(r.name) for r in self.rows), default=0)
        for r in self.rows:
            lines.append(f"{r.verdict.upper():<7} {r.name:<{width}}  {r.detail}")
        matrix = next((r.values for r in self.rows if "matrix" in r.values), None)
        if matrix:
            lines += ["", *matrix_lines(matrix)]
        trig = next(
            (r.values for r in self.rows if "histogram" in r.values and r.verdict != SKIPPED),
            None,
        )
        if trig:
            lines += ["", *histogram_lines(trig)]
        c = self.counts()
        tail = " (interrupted)" if self.interrupted else ""
        lines += [
            "",
            f"{c[PASS]} passed, {c[FAIL]} failed, {c[SKIPPED]} skipped{tail}: "
            f"{'PASS' if self.passed else 'FAIL'}",
        ]
        return "\n".join(lines)


def matrix_lines(values: dict[str, Any]) -> list[str]:
    """The 9 x 15 LED response matrix as a table: a row per LED channel, a column per count."""
    columns, rows = values["columns"], values["channels"]
    head = "LED channel " + " ".join(f"{c:>6}" for c in columns)
    out = ["LED response (counts, dark subtracted):", head]
    for name, counts in zip(rows, values["matrix"], strict=True):
        out.append(f"{name:<11} " + " ".join(f"{v:>6}" for v in counts))
    out.append(f"{'dark':<11} " + " ".join(f"{v:>6}" for v in values["dark"]))
    return out


def histogram_lines(values: dict[str, Any]) -> list[str]:
    """The TRIG latency histogram: a row per sensor, a column per bin (from its lower edge)."""
    edges = values["bin_edges_us"]
    head = "sensor  " + " ".join(f"{'>=' + format(e / 1000, 'g') + 'ms':>8}" for e in edges)
    out = [f"TRIG latency ({values['polls']} polls at {values['integration_ms']} ms):", head]
    for sensor, counts in values["histogram"].items():
        out.append(f"{sensor:<7} " + " ".join(f"{c:>8}" for c in counts))
    return out


def is_report(path: Path) -> bool:
    """A bring-up report file (what `-o --force` may replace)."""
    try:
        with open(path, encoding="utf-8") as f:
            head = f.read(RECOGNISE_BYTES)
    except (OSError, UnicodeDecodeError):
        return False
    return head.lstrip().startswith("{") and f'"kind": {json.dumps(KIND)}' in head
