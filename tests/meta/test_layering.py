"""Each part of the package imports only parts below it in the data flow (DESIGN.md).

The table below is the one place the order is written down. Every import counts, also one
inside a function (a lazy import is still a dependency) or under TYPE_CHECKING.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

#: The host's data flow, bottom to top: a part may import the parts before it.
DATA_FLOW = (
    "protocol",
    "device",
    "conformance",
    "ft",
    "fusion",
    "record",
    "dataset",
    "decode",
    "train",
    "evaluate",
    "apps",
    "cli",
)
#: The simulation stands beside the data flow: `twin` (the physics model) imports no other
#: part; `sim` (simulated devices and sessions built on the twin) plugs into the data flow
#: up to SIM_BUILDS_ON through URL-scheme entry points, never the other way round.
SIM_BUILDS_ON = "dataset"
#: From this part on, the data flow may use the twin and the simulator (fidelity reports,
#: the twin oracle's floor, demos, the CLI).
SIM_USED_FROM = "decode"
#: Modules every part may import, and which import no part themselves: the shared errors, the
#: URL-scheme registry, and `hardware` (constants generated from the part and board definitions).
SHARED = frozenset({"errors", "url_schemes", "hardware"})


def allowed(part: str) -> frozenset[str]:
    """The parts `part` may import, besides itself and SHARED."""
    if part in SHARED or part == "twin":
        return frozenset()
    if part == "sim":
        return frozenset({"twin", *DATA_FLOW[: DATA_FLOW.index(SIM_BUILDS_ON) + 1]})
    i = DATA_FLOW.index(part)
    below = set(DATA_FLOW[:i])
    if i >= DATA_FLOW.index(SIM_USED_FROM):
        below |= {"twin", "sim"}
    return frozenset(below)


PARTS = frozenset({*DATA_FLOW, "twin", "sim", *SHARED})
ENTRY_MODULES = frozenset({"__init__", "__main__"})  # the package itself: runs the CLI


def imported_parts(path: Path, package: Path) -> list[tuple[int, str]]:
    """(line, part) of every spectratac import in `path`, relative imports resolved."""
    rel = path.relative_to(package).with_suffix("").parts
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ["spectratac", *rel[: len(rel) - node.level]]
                names = [".".join([*base, *([node.module] if node.module else [])])]
                if not node.module:  # "from . import x": x is a module of the package
                    names = [f"{names[0]}.{a.name}" for a in node.names]
            else:
                names = [node.module or ""]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "spectratac" and len(parts) > 1:
                out.append((node.lineno, parts[1]))
    return out


def part_of(path: Path, package: Path) -> str:
    rel = path.relative_to(package)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def test_every_part_has_a_place(repo: Path) -> None:
    package = repo / "host" / "spectratac"
    parts = {p.name for p in package.iterdir() if (p / "__init__.py").exists()}
    parts |= {p.stem for p in package.glob("*.py")} - ENTRY_MODULES
    assert parts == PARTS, f"place these in the layering table: {sorted(parts ^ PARTS)}"


def test_no_part_imports_a_part_above_it(repo: Path) -> None:
    package = repo / "host" / "spectratac"
    wrong = []
    for path in sorted(package.rglob("*.py")):
        part = part_of(path, package)
        if part in ENTRY_MODULES:
            continue
        ok = allowed(part) | SHARED | {part}
        for line, target in imported_parts(path, package):
            if target not in ok:
                wrong.append(
                    f"{path.relative_to(package)}:{line} imports spectratac.{target}; "
                    f"{part} may import {', '.join(sorted(ok - {part}))}"
                )
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize(
    ("part", "may", "may_not"),
    [
        ("device", "protocol", "sim"),
        ("ft", "device", "twin"),
        ("dataset", "record", "sim"),
        ("record", "ft", "dataset"),
        ("sim", "record", "decode"),
        ("twin", None, "protocol"),
        ("evaluate", "sim", "apps"),
    ],
)
def test_the_table_says_what_the_design_says(part: str, may: str | None, may_not: str) -> None:
    assert may is None or may in allowed(part)
    assert may_not not in allowed(part)


def test_the_checker_sees_lazy_and_relative_imports(tmp_path: Path) -> None:
    package = tmp_path / "spectratac"
    (package / "device").mkdir(parents=True)
    module = package / "device" / "transport.py"
    module.write_text(
        "from . import errors\n"
        "from ..protocol import framing\n"
        "def open_sim():\n"
        "    from spectratac.sim.transport import SimTransport\n"
    )
    assert imported_parts(module, package) == [(1, "device"), (2, "protocol"), (4, "sim")]
