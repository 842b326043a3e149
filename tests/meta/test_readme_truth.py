"""What the README states in structured form, checked against the code (issues 24 and 37): its
shape (length, line width), the verb table (one row per verb of the CLI parser, the defaults it
quotes are the parsers', the conformance count is the suite's), the Layout table (the
repository's top-level folders), ARCHITECTURE.md's parts (the layering test's), and that every
link of the README and the guides points at something that exists. Prose is free to change:
nothing here matches a sentence."""

from __future__ import annotations

import argparse
import fnmatch
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from spectratac.cli import build_parser
from spectratac.cli.options import shows_default
from spectratac.conformance.checks import CHECKS
from spectratac.conformance.model_checks import MODEL_CHECKS, applicable

from tests.meta.test_layering import BESIDE, DATA_FLOW

REPO = Path(__file__).resolve().parents[2]
README = REPO / "README.md"
ARCHITECTURE = REPO / "host/spectratac/ARCHITECTURE.md"
CLI_GUIDE = REPO / "host/spectratac/cli/README.md"
MAX_LINES = 250
MAX_WIDTH = 300
#: The user's guides held to the README's shape.
SHORT_GUIDES = ("README.md", "firmware/README.md")


def verbs(parser: argparse.ArgumentParser, path: str = "") -> Iterator[tuple[str, list]]:
    """(verb path, its actions) of every parser that runs something."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield path, parser._actions
    for sub in subs:
        for name, child in sub.choices.items():
            yield from verbs(child, f"{path} {name}".strip())


VERBS = dict(verbs(build_parser()))


def section(text: str, heading: str) -> str:
    """The body of the `## heading` section of a markdown text."""
    found = re.search(rf"^## {re.escape(heading)}\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    assert found, f"no section '## {heading}'"
    return found.group(1)


def table(text: str) -> list[list[str]]:
    """The rows (cells stripped, header and rule left out) of the first table in `text`."""
    rows = []
    for line in text.splitlines():
        if line.startswith("|") and not re.match(r"^\|[-| :]+\|$", line):
            cells = re.split(r"(?<!\\)\|", line.strip())[1:-1]
            rows.append([c.strip().replace("\\|", "|") for c in cells])
    assert rows, "no table"
    return rows[1:]


def code_spans(cell: str) -> list[str]:
    return re.findall(r"`([^`]+)`", cell)


def verb_table() -> dict[str, tuple[str, str]]:
    """README's verb table: verb path -> (what it does, defaults cell)."""
    rows = {}
    for usage, what, defaults in table(section(README.read_text(), "Verbs")):
        words = code_spans(usage)[0].split()
        assert words[0] == "spectratac", usage
        path = " ".join(w for w in words[1:3] if re.fullmatch(r"[a-z]+", w))
        while path not in VERBS and " " in path:  # `info URL`: one word, then an argument
            path = path.rsplit(" ", 1)[0]
        assert path not in rows, f"`{path}` has two rows"
        rows[path] = (what, defaults)
    return rows


@pytest.mark.parametrize("name", SHORT_GUIDES)
def test_the_guide_is_short_and_its_lines_are_readable(name: str) -> None:
    lines = (REPO / name).read_text().splitlines()
    assert len(lines) <= MAX_LINES, f"{name} has {len(lines)} lines (at most {MAX_LINES})"
    wide = [(n, len(line)) for n, line in enumerate(lines, 1) if len(line) > MAX_WIDTH]
    assert not wide, f"{name}: lines over {MAX_WIDTH} characters (line, length): {wide}"


def test_the_verb_table_has_one_row_per_verb() -> None:
    listed = set(verb_table())
    assert listed == set(VERBS), (
        f"not in the README's verb table: {sorted(set(VERBS) - listed)}; "
        f"in it but no verb: {sorted(listed - set(VERBS))}"
    )


def quoted_defaults() -> Iterator[tuple[str, str, str]]:
    for verb, (_, defaults) in verb_table().items():
        for span in code_spans(defaults):
            option, value = span.split(maxsplit=1)
            yield verb, option, value


@pytest.mark.parametrize(("verb", "option", "value"), list(quoted_defaults()))
def test_the_defaults_the_readme_quotes_are_the_parsers(verb: str, option: str, value: str) -> None:
    action = next((a for a in VERBS[verb] if option in a.option_strings), None)
    assert action is not None, f"`spectratac {verb}` has no option {option}"
    # An option that may stand alone (`--foxglove [PORT]`) is quoted with the value it then takes.
    default = action.const if action.nargs == "?" and action.default is None else action.default
    parsed = action.type(value) if callable(action.type) else value
    assert str(parsed) == str(default), (
        f"README: `spectratac {verb}` {option} defaults to {value}; the parser says {default!r}"
    )


def test_there_are_defaults_to_check() -> None:
    assert len(list(quoted_defaults())) >= 10


def test_the_conformance_count_is_the_suites() -> None:
    from spectratac.device import Sensor

    what, _ = verb_table()["conformance"]
    total, protocol, model = map(int, re.findall(r"\d+", what)[:3])
    with Sensor.open("sim://?scene=idle&speed=max") as sensor:  # a device that decodes
        runs = len(CHECKS) + len(applicable(sensor.info.capabilities))
    assert (total, protocol, model) == (runs, len(CHECKS), len(MODEL_CHECKS))


def test_the_verbs_that_stop_on_count_and_duration_are_the_cli_guides() -> None:
    stops = {
        tuple(code_spans(options)): code_spans(verbs_cell)
        for options, verbs_cell in table(section(CLI_GUIDE.read_text(), "When a verb stops"))
    }
    streaming, duration_only = stops[("--count N", "--duration S")], stops[("--duration S",)]
    for verb, actions in VERBS.items():
        options = {o for a in actions for o in a.option_strings}
        stops_on = {"--count", "--duration"} & options
        if verb == "ft info":  # --count sizes its rate check; it never stops a run
            stops_on.discard("--count")
        if verb in streaming:
            expected = {"--count", "--duration"}
        elif verb in duration_only:
            expected = {"--duration"}
        else:
            expected = set()
        assert stops_on == expected, (
            f"`{verb}` stops on {sorted(stops_on)}: the CLI guide says {sorted(expected)}"
        )


def test_the_layout_table_lists_the_top_level_folders() -> None:
    rows = table(section(README.read_text(), "Layout"))
    listed = {code_spans(row[0])[0].rstrip("/") for row in rows}
    ignored = [p.strip().rstrip("/") for p in (REPO / ".gitignore").read_text().splitlines()]
    folders = {
        d.name
        for d in REPO.iterdir()
        if d.is_dir() and not d.name.startswith(".")
        and not any(fnmatch.fnmatch(d.name, pattern) for pattern in ignored if pattern)
    }  # fmt: skip
    assert listed == folders


def test_the_architecture_lists_every_part_in_the_layering_order() -> None:
    parts = [code_spans(row[0])[0] for row in table(section(ARCHITECTURE.read_text(), "Parts"))]
    assert parts == [*DATA_FLOW, *BESIDE]
    on_disk = {p.parent.name for p in (REPO / "host/spectratac").glob("*/__init__.py")}
    assert set(parts) | {"hardware"} == on_disk  # `hardware` is shared, generated constants


def guides() -> list[Path]:
    """The README, the firmware's guide and every guide beside the code they describe."""
    found = [README, REPO / "firmware/README.md", REPO / "tools/bench/MEASUREMENTS.md"]
    for folder in ("host", "firmware/docs", "tests", "hardware", "protocol"):
        found += sorted((REPO / folder).rglob("*.md"))
    return sorted({p for p in found if "generated" not in p.parts})


def anchors(markdown: str) -> set[str]:
    """GitHub's anchors of a markdown text's headings."""
    out = set()
    for heading in re.findall(r"^#+ (.+)$", markdown, re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        out.add(slug)
    return out


@pytest.mark.parametrize("guide", guides(), ids=lambda p: str(p.relative_to(REPO)))
def test_every_link_points_at_something_that_exists(guide: Path) -> None:
    text = re.sub(r"```.*?```", "", guide.read_text(), flags=re.S)  # links, not code
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target):  # https://, mailto:
            continue
        path, _, anchor = target.partition("#")
        where = (guide.parent / path).resolve() if path else guide
        missing_anchor = (
            where.exists() and anchor and where.suffix == ".md"
            and anchor not in anchors(where.read_text())
        )  # fmt: skip
        if not where.exists() or missing_anchor:
            broken.append(target)
    assert not broken, f"{guide.relative_to(REPO)} links to what does not exist: {broken}"


@pytest.mark.parametrize("verb", sorted(VERBS))
def test_help_shows_every_default(verb: str) -> None:
    for action in VERBS[verb]:
        if shows_default(action):
            assert "default" in (action.help or ""), (
                f"spectratac {verb} --help: {'/'.join(action.option_strings) or action.dest} "
                f"hides its default {action.default!r}"
            )
