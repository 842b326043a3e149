"""Small terminal helpers shared by the CLI verbs."""

from __future__ import annotations

from collections.abc import Sequence


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


def pass_fail_table(rows: Sequence[tuple[str, bool, str]]) -> str:
    width = max(len(name) for name, _, _ in rows)
    return "\n".join(
        f"{'PASS' if ok else 'FAIL'}  {name:<{width}}  {detail}" for name, ok, detail in rows
    )
