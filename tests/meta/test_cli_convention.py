"""Every verb follows one command-line convention, checked on the argparse tree itself so that a
new verb cannot drift: -o/--output for what it writes, --force wherever it could overwrite
something (refused with exit code 3 otherwise), one spelling per setting across verbs,
URL + --timeout wherever a device is opened, exit codes from ExitCode, and one spelling per
option, the one --help shows (no hidden options, no old spellings, no prefixes)."""

from __future__ import annotations

import argparse
import ast
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path

import pytest
from spectratac.cli import build_parser, main
from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import ROW_FORMATS
from spectratac.cli.values import RANGES

CLI = Path(__file__).resolve().parents[2] / "host" / "spectratac" / "cli"
# Spellings that name an output path in other tools; here it is always -o/--output.
OUTPUT_SPELLINGS = {"--out", "--output", "--report", "--outdir", "--output-dir", "--dest"}
# Verbs whose output folder only ever gains new, uniquely named files (never overwrites).
NEVER_OVERWRITES = {"live"}
# Verbs that refuse an existing output: argv ({out}: the output) and what the output is: a
# file (refused when it exists) or a folder (refused when it holds anything).
WRITING_VERBS = {
    "record": (["record", "sim://?scene=idle", "-o", "{out}", "--no-progress"], "x.mcap"),
    "dataset build": (["dataset", "build", "missing.mcap", "-o", "{out}"], "x.npz"),
    "train": (["train", "missing.npz", "-o", "{out}"], "x.stac"),
    "evaluate": (["evaluate", "missing.stac", "missing.npz", "-o", "{out}"], "folder"),
    "twin generate": (["twin", "generate", "--scene", "idle", "-o", "{out}"], "x.npz"),
    "twin population": (
        [
            "twin",
            "population",
            "--units",
            "0",
            "--sessions",
            "1",
            "--duration",
            "5",
            "--scene",
            "idle",
            "--no-progress",
            "-o",
            "{out}",
        ],
        "x.npz",
    ),
    "demo": (["demo", "-o", "{out}", "--no-progress"], "folder"),
    "export rosbag": (["export", "rosbag", "missing.mcap", "-o", "{out}"], "folder"),
    "bringup": (["bringup", "/dev/ttyNOPE", "-o", "{out}"], "x.json"),
}
# Verb modules whose returns are checked for literal exit codes.
EXIT_CODE_MODULES = sorted(CLI.glob("*_cmd.py"))


def leaves(parser: argparse.ArgumentParser, path: str = "") -> Iterator[tuple[str, list]]:
    """(verb path, actions) of every parser that runs something."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if parser.get_default("func") is not None and not subs:
        yield path, parser._actions
    for sub in subs:
        for name, child in sub.choices.items():
            yield from leaves(child, f"{path} {name}".strip())


VERBS = dict(leaves(build_parser()))


def visible(actions: list) -> list[argparse.Action]:
    shown_always = (argparse._HelpAction, argparse._VersionAction)
    return [a for a in actions if not isinstance(a, shown_always)]


def parsers(
    parser: argparse.ArgumentParser, path: str = "spectratac"
) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """(prog, parser) of the whole tree: the top, every verb and every sub-verb."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield from parsers(child, f"{path} {name}")


PARSERS = dict(parsers(build_parser()))


def test_the_tree_has_every_documented_verb() -> None:
    for verb in (
        "info", "stream", "sim serve", "sim ft", "conformance", "twin report", "twin generate",
        "protocol show", "protocol decode", "ft info", "ft stream", "record", "dataset build",
        "dataset info", "train", "evaluate", "decode", "demo", "model info",
        "model upload", "model clear",
    ):  # fmt: skip
        assert verb in VERBS, f"{verb} is gone from the argparse tree"


@pytest.mark.parametrize("verb", sorted(VERBS))
def test_output_paths_are_spelled_o_output(verb: str) -> None:
    for action in visible(VERBS[verb]):
        names = set(action.option_strings)
        if action.dest in ("out", "output", "report") or names & OUTPUT_SPELLINGS:
            assert action.option_strings == ["-o", "--output"], (verb, action.option_strings)
            assert action.dest == "output"


@pytest.mark.parametrize("verb", sorted(VERBS))
def test_verbs_that_write_take_force(verb: str) -> None:
    dests = {a.dest: a for a in visible(VERBS[verb])}
    if not {"output", "out"} & set(dests) or verb in NEVER_OVERWRITES:
        return
    force = dests.get("force")
    assert force is not None, f"{verb} writes -o/--output: give it --force (add_output does)"
    assert force.option_strings == ["--force"] and force.const is True and force.default is False
    assert verb in WRITING_VERBS, f"{verb}: add it to WRITING_VERBS so its refusal is tested"


@pytest.mark.parametrize("verb", sorted(WRITING_VERBS))
def test_an_existing_output_is_refused_with_exit_3_and_kept(
    verb: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    argv, kind = WRITING_VERBS[verb]
    out = tmp_path / kind
    keep = out / "keep.txt" if kind == "folder" else out
    keep.parent.mkdir(exist_ok=True)
    keep.write_text("the user's work")
    assert main([a.replace("{out}", str(out)) for a in argv]) == ExitCode.ERROR
    assert "already exists; pass --force" in capsys.readouterr().err
    assert keep.read_text() == "the user's work"
    assert [p.name for p in out.parent.iterdir()] == [out.name]  # nothing else written


@pytest.mark.parametrize("verb", sorted(VERBS))
def test_verbs_that_open_a_device_take_url_and_timeout(verb: str) -> None:
    dests = {a.dest: a for a in visible(VERBS[verb])}
    if "url" in dests:
        assert not dests["url"].option_strings, f"{verb}: the URL is positional"
        timeout = dests.get("timeout")
        assert timeout is not None and timeout.option_strings == ["--timeout"], verb
        assert timeout.type is RANGES["--timeout"] and timeout.default > 0  # cli.values


def test_one_spelling_per_setting_across_verbs() -> None:
    spellings: dict[str, set[tuple[str, ...]]] = defaultdict(set)
    dests: dict[str, set[str]] = defaultdict(set)
    for actions in VERBS.values():
        for action in visible(actions):
            if not action.option_strings:
                continue
            spellings[action.dest].add(tuple(action.option_strings))
            for option in action.option_strings:
                dests[option].add(action.dest)
    assert {d: s for d, s in spellings.items() if len(s) > 1} == {}
    assert {o: d for o, d in dests.items() if len(d) > 1} == {}


@pytest.mark.parametrize("verb", sorted(VERBS))
def test_row_formats_are_alike(verb: str) -> None:
    for action in visible(VERBS[verb]):
        if action.dest == "format":
            assert tuple(action.choices) == ROW_FORMATS and action.default == "table"


@pytest.mark.parametrize("prog", sorted(PARSERS))
def test_every_option_has_one_long_spelling_shown_by_help(prog: str) -> None:
    """Every parser of the tree, sub-verbs included: each option has exactly one --long
    spelling (a -x short form beside it is fine), nothing is hidden from --help, and no
    prefix of a spelling is accepted as another name for it."""
    parser = PARSERS[prog]
    text = parser.format_help()
    assert not parser.allow_abbrev, f"{prog}: a prefix (--out for --output) is a second name"
    for action in parser._actions:
        assert action.help is not argparse.SUPPRESS, (prog, action.option_strings or action.dest)
        if not action.option_strings:
            continue
        longs = [o for o in action.option_strings if o.startswith("--")]
        shorts = [o for o in action.option_strings if not o.startswith("--")]
        assert len(longs) == 1 and len(shorts) <= 1, (prog, action.option_strings)
        assert longs[0] in text, f"{prog} --help does not show {longs[0]}"


def test_the_spelling_check_sees_hidden_and_second_spellings() -> None:
    """The check above on a parser that breaks it in each way: it fails."""
    for add in (
        lambda p: p.add_argument("--seconds", dest="duration", help=argparse.SUPPRESS),
        lambda p: p.add_argument("--duration", "--seconds", help="two names"),
    ):
        parser = argparse.ArgumentParser(prog="spectratac x", allow_abbrev=False)
        add(parser)
        PARSERS["spectratac x"] = parser
        try:
            with pytest.raises(AssertionError):
                test_every_option_has_one_long_spelling_shown_by_help("spectratac x")
        finally:
            del PARSERS["spectratac x"]


def is_number(node: ast.expr | None) -> bool:
    """An int literal, or a choice between expressions one of which is (`1 if x else 0`)."""
    if isinstance(node, ast.IfExp):
        return is_number(node.body) or is_number(node.orelse)
    return isinstance(node, ast.Constant) and type(node.value) is int


@pytest.mark.parametrize("path", EXIT_CODE_MODULES, ids=lambda p: p.name)
def test_verbs_return_exit_code_constants_not_numbers(path: Path) -> None:
    tree = ast.parse(path.read_text())
    literal = [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Return) and is_number(n.value)]
    literal += [  # func=lambda args: (p.print_help(), 2)[1]
        n.lineno
        for n in ast.walk(tree)
        if isinstance(n, ast.Lambda)
        and any(is_number(e) for t in ast.walk(n.body) if isinstance(t, ast.Tuple) for e in t.elts)
    ]
    assert literal == [], f"{path.name}: return ExitCode.<name>, not a number (lines {literal})"


@pytest.mark.parametrize(
    "argv",
    [
        ["info", "/dev/ttyNOPE"],
        ["stream", "/dev/ttyNOPE"],
        ["conformance", "/dev/ttyNOPE"],
        ["model", "info", "/dev/ttyNOPE"],
        ["model", "clear", "/dev/ttyNOPE"],
        ["record", "/dev/ttyNOPE", "-o", "never.mcap", "--no-progress"],
        ["ft", "info", "bota:///dev/ttyNOPE"],
        ["ft", "stream", "bota:///dev/ttyNOPE"],
    ],
    ids=" ".join,
)
def test_a_missing_device_exits_3_in_every_verb(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main([*argv, "--timeout", "0.5"]) == ExitCode.ERROR
    err = capsys.readouterr().err
    assert f"spectratac {' '.join(a for a in argv[:2] if '/' not in a)}: error:" in err
    assert "/dev/ttyNOPE" in err and not (tmp_path / "never.mcap").exists()


REMOVED = [
    # (argv with a spelling that is gone, the spelling): the options that replaced them are
    # -o/--output, --duration, --count, --digital-gain and --sensitivity low
    (["train", "d.npz", "-o", "m.stac", "--out", "m.stac"], "--out"),
    (["evaluate", "m", "d", "-o", "r", "--report", "r"], "--report"),
    (["demo", "--out", "x"], "--out"),
    (["demo", "--scene-seconds", "60"], "--scene-seconds"),
    (["demo", "--live", "--seconds", "3"], "--seconds"),
    (["decode", "m", "sim://", "--seconds", "2"], "--seconds"),
    (["record", "sim://", "-o", "s", "--samples", "9"], "--samples"),
    (["ft", "info", "csv://f", "--samples", "9"], "--samples"),
    (["twin", "generate", "s.npz"], "s.npz"),
    (["twin", "generate", "-o", "s", "--dg", "2"], "--dg"),
    (["twin", "generate", "-o", "s", "--sens-low"], "--sens-low"),
    (["record", "sim://", "-o", "s", "--dur", "9"], "--dur"),  # a prefix is no spelling
]  # fmt: skip


@pytest.mark.parametrize(("argv", "spelling"), REMOVED, ids=[" ".join(a) for a, _ in REMOVED])
def test_removed_spellings_are_usage_errors(
    argv: list[str], spelling: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args(argv)
    assert exit_.value.code == ExitCode.USAGE
    assert f"unrecognized arguments: {spelling}" in capsys.readouterr().err


def test_a_required_output_left_out_is_a_usage_error(
    capsys: pytest.CaptureFixture[str],
) -> None:
    for argv in (["train", "d.npz"], ["evaluate", "m.stac", "d.npz"]):
        with pytest.raises(SystemExit) as exit_:
            main(argv)  # stops at the usage check: nothing trains or evaluates
        assert exit_.value.code == ExitCode.USAGE
        assert "required: -o/--output" in capsys.readouterr().err
    assert main(["twin", "generate", "--scene", "idle"]) == ExitCode.USAGE  # --list needs none
    assert "required: -o/--output" in capsys.readouterr().err
