"""Terminal output shared by the verbs: aligned tables, and the rows of the streaming verbs
(`stream`, `ft stream`, `decode`) as a table, CSV or JSON lines."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from typing import Any


class Table:
    """Prints aligned rows, repeating the header every `every` rows."""

    def __init__(self, columns: Sequence[str], width: int = 8, every: int = 25) -> None:
        self.columns = list(columns)
        self.width = width
        self.every = every
        self._n = 0

    def line(self, values: Sequence[object]) -> str:
        return " ".join(f"{v!s:>{self.width}}" for v in values)

    def row(self, values: Sequence[object]) -> None:
        if self._n % self.every == 0:
            print(self.line(self.columns))
        print(self.line(values))
        self._n += 1


class RowWriter:
    """One row per sample in --format `fmt`: an aligned table, CSV with a header line, or one
    JSON object per line (the columns by name, unless the caller gives a richer record).

    >>> w = RowWriter(("seq", "Fz"), "csv")
    seq,Fz
    >>> w.row([7, 0.5]); RowWriter(("seq", "Fz"), "jsonl").row([7, 0.5])
    7,0.5
    {"seq": 7, "Fz": 0.5}
    """

    def __init__(
        self,
        columns: Sequence[str],
        fmt: str,
        width: int = 8,
        table_cell: Callable[[Any], object] = str,
    ) -> None:
        self.columns = tuple(columns)
        self.fmt = fmt
        self.table_cell = table_cell  # how the table (only) shows a cell, e.g. rounded
        self._table = Table(columns, width=width) if fmt == "table" else None
        if fmt == "csv":
            print(",".join(self.columns))

    def row(self, cells: Sequence[Any], record: Mapping[str, Any] | None = None) -> None:
        """`cells` for the table and CSV; `record` (default: cells by column) for JSON lines."""
        if self._table is not None:
            self._table.row([self.table_cell(c) for c in cells])
        elif self.fmt == "csv":
            print(",".join(map(str, cells)))
        else:
            by_name = dict(zip(self.columns, cells, strict=True)) if record is None else record
            print(json.dumps(dict(by_name)))


def reader_gone() -> None:
    """stdout's reader went away (`spectratac stream … | head`): that is fine. Point stdout at
    /dev/null so that the interpreter's final flush does not fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
