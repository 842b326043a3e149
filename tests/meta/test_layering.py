"""The package's layering, machine-checked: the rule host/spectratac/ARCHITECTURE.md states.

The data flow, bottom to top (DATA_FLOW): each part imports only parts below it. Beside it:
`twin` (the physics model) imports no other part; `sim` (simulated devices and F/T sensors)
builds on the twin and the data flow up to `dataset`, and plugs into the data flow only through
URL-scheme entry points (`host/spectratac/url_schemes.py`, `pyproject.toml`); `studies`
(evaluation that needs the twin: the oracle's floor, twin fidelity, the benchmark library)
builds on twin, sim and the data flow up to `apps`. No part of the data flow imports twin, sim
or studies, except `cli`, the top, which composes everything. SHARED modules are importable by
every part and import no part.

Every import counts, also one inside a function (a lazy import is still a dependency) or under
TYPE_CHECKING (a type a module names is a module it knows): for the layering, and for cycles.
No modules import each other in a cycle, within a part or across parts, whatever kind of
import closes it: two modules that name each other's types share a type that belongs below
both (a protocol of what one needs of the other), or one hands the other values.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
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
    "ros2",
    "train",
    "evaluate",
    "apps",
    "cli",
)
#: `sim` builds on the twin and on the data flow up to this part.
SIM_BUILDS_ON = "dataset"
#: `studies` builds on twin, sim and the data flow up to this part.
STUDIES_BUILD_ON = "apps"
#: The one data-flow part that may import twin, sim and studies: the CLI composes everything.
COMPOSER = "cli"
#: Beside the data flow: the physics model, the simulated devices, twin-only evaluation.
BESIDE = ("twin", "sim", "studies")
#: Modules every part may import, and which import no part themselves: the shared errors, the
#: URL-scheme registry, `hardware` (constants generated from the part and board definitions), and
#: `threads` (the thread policy every process applies), `host_clock` (Unix minus monotonic,
#: read tightly), `bounds` (the size and depth limits of every reader of users' files) and
#: `progress` (the progress bars, on a terminal only).
SHARED = frozenset(
    {"errors", "url_schemes", "hardware", "threads", "host_clock", "bounds", "progress"}
)


def _up_to(part: str) -> set[str]:
    return set(DATA_FLOW[: DATA_FLOW.index(part) + 1])


def allowed(part: str) -> frozenset[str]:
    """The parts `part` may import, besides itself and SHARED."""
    if part in SHARED or part == "twin":
        return frozenset()
    if part == "sim":
        return frozenset({"twin", *_up_to(SIM_BUILDS_ON)})
    if part == "studies":
        return frozenset({"twin", "sim", *_up_to(STUDIES_BUILD_ON)})
    below = set(DATA_FLOW[: DATA_FLOW.index(part)])
    if part == COMPOSER:
        below |= set(BESIDE)
    return frozenset(below)


PARTS = frozenset({*DATA_FLOW, *BESIDE, *SHARED})
ENTRY_MODULES = frozenset({"__init__", "__main__"})  # the package itself: runs the CLI


@dataclass(frozen=True)
class Import:
    line: int
    module: str  # dotted name, relative imports resolved ("spectratac.decode.stac_file")
    names: tuple[str, ...]  # for "from module import a, b": ("a", "b"); else ()
    type_checking: bool  # only under `if TYPE_CHECKING:`


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _walk(node: ast.AST, type_checking: bool = False) -> Iterator[tuple[ast.AST, bool]]:
    """Every node below `node`, with whether it sits under `if TYPE_CHECKING:`."""
    for child in ast.iter_child_nodes(node):
        yield child, type_checking
        if isinstance(child, ast.If) and _is_type_checking(child.test):
            for stmt in child.body:
                yield stmt, True
                yield from _walk(stmt, True)
            for stmt in child.orelse:
                yield stmt, type_checking
                yield from _walk(stmt, type_checking)
        else:
            yield from _walk(child, type_checking)


def imports(path: Path, package: Path) -> list[Import]:
    """Every spectratac import in `path` (module level, lazy or TYPE_CHECKING)."""
    rel = path.relative_to(package).with_suffix("").parts
    if rel[-1] == "__init__":  # a package's own module: relative imports start from it
        rel = (*rel[:-1], "")
    out = []
    for node, tc in _walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [Import(node.lineno, a.name, (), tc) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ["spectratac", *rel[: len(rel) - node.level]]
                module = ".".join([*base, *([node.module] if node.module else [])])
            else:
                module = node.module or ""
            out.append(Import(node.lineno, module, tuple(a.name for a in node.names), tc))
    return [i for i in out if i.module.split(".")[0] == "spectratac"]


def imported_parts(path: Path, package: Path) -> list[tuple[int, str]]:
    """(line, part) of every spectratac import in `path`, relative imports resolved."""
    out = []
    for imp in imports(path, package):
        parts = imp.module.split(".")
        if len(parts) > 1:
            out.append((imp.line, parts[1]))
        else:  # "from spectratac import x": x is a part, or the package's own __version__
            out += [(imp.line, name) for name in imp.names if not name.startswith("__")]
    return out


def part_of(path: Path, package: Path) -> str:
    rel = path.relative_to(package)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def module_name(path: Path, package: Path) -> str:
    rel = path.relative_to(package).with_suffix("").parts
    return ".".join(["spectratac", *(rel[:-1] if rel[-1] == "__init__" else rel)])


def module_graph(package: Path) -> dict[str, set[str]]:
    """Module -> the package's modules it imports (module level, lazy or TYPE_CHECKING).

    `from pkg import name` is an edge to `pkg.name` when that is a module, else to `pkg`
    (its __init__). The implicit import of a module's parent packages is not an edge: it is
    how every package works, and counting it would make every __init__ part of a cycle.
    """
    modules = {module_name(p, package): p for p in package.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        edges = graph.setdefault(name, set())
        for imp in imports(path, package):
            targets = [f"{imp.module}.{n}" for n in imp.names if f"{imp.module}.{n}" in modules]
            if len(targets) < len(imp.names) or not imp.names:
                targets.append(imp.module)
            edges |= {t for t in targets if t in modules and t != name}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


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
                    f"{part} may import {', '.join(sorted(ok - {part})) or 'no other part'}"
                )
    assert not wrong, "\n".join(wrong)


def test_no_import_cycle(repo: Path) -> None:
    found = cycles(module_graph(repo / "host" / "spectratac"))
    assert not found, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in found)


@pytest.mark.parametrize(
    ("part", "may", "may_not"),
    [
        ("device", "protocol", "sim"),
        ("ft", "device", "twin"),
        ("dataset", "record", "sim"),
        ("record", "ft", "dataset"),
        ("sim", "record", "decode"),
        ("twin", None, "protocol"),
        ("decode", "dataset", "train"),
        ("ros2", "decode", "train"),
        ("ros2", "ft", "sim"),
        ("train", "decode", "evaluate"),
        ("evaluate", "train", "sim"),
        ("evaluate", "decode", "twin"),
        ("apps", "evaluate", "studies"),
        ("apps", "decode", "sim"),
        ("studies", "sim", "cli"),
        ("studies", "apps", "cli"),
        ("cli", "studies", "nothing above cli"),
        ("cli", "twin", "nothing above cli"),
        ("errors", None, "protocol"),
        ("hardware", None, "twin"),
    ],
)
def test_the_table_says_what_the_readme_says(part: str, may: str | None, may_not: str) -> None:
    assert may is None or may in allowed(part)
    assert may_not not in allowed(part)


def test_only_the_composer_of_the_data_flow_uses_the_simulation() -> None:
    users = {p for p in DATA_FLOW if allowed(p) & set(BESIDE)}
    assert users == {COMPOSER}
    assert not any(p in allowed(q) for p in ("studies",) for q in ("twin", "sim"))


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


def test_the_checker_sees_type_checking_imports_and_parts_named_from_the_package(
    tmp_path: Path,
) -> None:
    package = tmp_path / "spectratac"
    (package / "apps").mkdir(parents=True)
    module = package / "apps" / "page.py"
    module.write_text(
        "from typing import TYPE_CHECKING\n"
        "from spectratac import twin\n"
        "if TYPE_CHECKING:\n"
        "    from spectratac.sim.world import SimWorld\n"
    )
    assert imported_parts(module, package) == [(2, "twin"), (4, "sim")]
    assert [i.type_checking for i in imports(module, package)] == [False, True]


def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    package = tmp_path / "spectratac"
    for name, text in files.items():
        path = package / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return package


def test_the_cycle_check_sees_a_lazy_cycle_inside_a_part(tmp_path: Path) -> None:
    package = _package(
        tmp_path,
        {
            "__init__.py": "",
            "cli/__init__.py": "",
            "cli/live_cmd.py": "from .snake_cmd import run\n",
            "cli/snake_cmd.py": "def run():\n    from spectratac.cli import live_cmd\n",
            "cli/other.py": "from . import live_cmd\n",
        },
    )
    assert cycles(module_graph(package)) == [
        ["spectratac.cli.live_cmd", "spectratac.cli.snake_cmd"]
    ]


def test_the_cycle_check_sees_a_cycle_through_a_package_init(tmp_path: Path) -> None:
    package = _package(
        tmp_path,
        {
            "decode/__init__.py": "from .decoder import Decoder\n",
            "decode/decoder.py": "from . import stac_file\nclass Decoder: ...\n",
            "decode/stac_file.py": "def load():\n    from spectratac.decode import Decoder\n",
        },
    )
    assert cycles(module_graph(package)) == [
        ["spectratac.decode", "spectratac.decode.decoder", "spectratac.decode.stac_file"]
    ]


def test_the_cycle_check_sees_a_type_checking_cycle(tmp_path: Path) -> None:
    """A back edge that only names a type closes a cycle too (decode/stac_file named the
    Decoder that imports it, until the file took the decoder's parts as a protocol)."""
    package = _package(
        tmp_path,
        {
            "decode/__init__.py": "",
            "decode/decoder.py": "from . import stac_file\n",
            "decode/stac_file.py": (
                "from typing import TYPE_CHECKING\n"
                "if TYPE_CHECKING:\n"
                "    from .decoder import Decoder\n"
            ),
            "apps/__init__.py": "",
            "apps/page.py": "from spectratac.decode import decoder\n",
        },
    )
    assert cycles(module_graph(package)) == [
        ["spectratac.decode.decoder", "spectratac.decode.stac_file"]
    ]


def test_the_cycle_check_sees_a_registry_importing_its_base_back(tmp_path: Path) -> None:
    """The shape ft/base and ft/open had: the base dispatches to the registry at run time,
    the registry names the base class it returns."""
    package = _package(
        tmp_path,
        {
            "ft/__init__.py": "from .base import FTSensor\nfrom . import open\n",
            "ft/base.py": "from spectratac.ft.open import open_url\nclass FTSensor: ...\n",
            "ft/open.py": (
                "import typing\n"
                "if typing.TYPE_CHECKING:\n"
                "    from spectratac.ft.base import FTSensor\n"
            ),
        },
    )
    assert cycles(module_graph(package)) == [["spectratac.ft.base", "spectratac.ft.open"]]


def test_the_cycle_check_sees_a_cycle_across_parts(tmp_path: Path) -> None:
    """Shared modules may import each other (the layering allows it): never in a cycle."""
    package = _package(
        tmp_path,
        {
            "errors.py": "def printable():\n    from spectratac.url_schemes import Registry\n",
            "url_schemes.py": "from spectratac.errors import printable\n",
            "device/__init__.py": "",
            "device/link.py": "from spectratac import errors\n",
        },
    )
    assert cycles(module_graph(package)) == [["spectratac.errors", "spectratac.url_schemes"]]


def test_the_cycle_check_passes_one_way_imports(tmp_path: Path) -> None:
    package = _package(
        tmp_path,
        {
            "decode/__init__.py": "from .decoder import Decoder\n",
            "decode/parts.py": "from typing import Protocol\nclass DecoderParts(Protocol): ...\n",
            "decode/decoder.py": "from . import parts, stac_file\n",
            "decode/stac_file.py": (
                "from typing import TYPE_CHECKING\n"
                "if TYPE_CHECKING:\n"
                "    from .parts import DecoderParts\n"
            ),
            "cli/__init__.py": "",
            "cli/run.py": "from spectratac.decode import Decoder\n",
        },
    )
    assert cycles(module_graph(package)) == []
