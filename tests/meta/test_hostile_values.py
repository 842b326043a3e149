"""Every option and positional of every verb, and every parameter of every URL scheme, given
hostile values (nan, inf, -1, 0, 1e300, 1e-300, a 100 KB string, undecodable bytes): each is
a usage error (exit code 2) or a typed error (exit code 3) with a one-line message, never a
traceback, within a hang guard, and leaves no file behind.

The walk runs in-process (`spectratac.cli.main`) against inputs that fail fast (a missing
device, a missing file, an output that exists), so a value the parser accepts cannot start a
long run; verbs that have no such input (servers, the demo's generation) are walked through
the parser only, their accepted values listed as accepted (WALK). A sample runs as real
processes (test_a_sample_in_real_processes)."""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from spectratac import cli
from spectratac.cli import build_parser, main
from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.values import RANGES
from spectratac.device import DeviceError, Sensor
from spectratac.ft import FTError, FTSensor, bota, csvfile, netft, rosbag
from spectratac.ft.errors import FTURLError
from spectratac.ft.open import ft_schemes
from spectratac.ft.options import Options, Param
from spectratac.sim.url import SIM_PARAMS, parse_sim_url
from spectratac.url_schemes import MAX_URL_CHARS

from tests.meta.test_cli_convention import leaves

pytestmark = pytest.mark.subprocess  # the sample of real processes

HOSTILE: dict[str, str] = {
    "nan": "nan",
    "inf": "inf",
    "-1": "-1",
    "0": "0",
    "1e300": "1e300",
    "1e-300": "1e-300",
    "100KB": "x" * 100_000,
    "non-UTF-8": os.fsdecode(b"\xff\xfe-not-utf8"),  # surrogate escapes, as argv gets them
}
DEV = "/dev/ttyNOPE"
CASE_GUARD_S = 30  # per case: a hang fails it instead of the whole run
# Verb -> argv that ends fast with exit code 3 (nothing to open or an output that exists);
# None: the verb has no such input (it serves, or generates data): walked by the parser only.
BASES: dict[str, list[str] | None] = {
    "bringup": [DEV],
    "conformance": [DEV],
    "dataset build": ["missing.mcap", "-o", "out.npz"],
    "dataset info": ["missing.npz"],
    "decode": ["missing.stac", DEV],
    "demo": ["-o", "full", "--no-progress"],
    "evaluate": ["missing.stac", "missing.npz", "-o", "report"],
    "flash": ["missing.bin"],
    "export rosbag": ["missing.mcap", "-o", "bag"],
    "ft info": ["bota://" + DEV],
    "ft stream": ["bota://" + DEV],
    "info": [DEV],
    "live": ["missing.stac", DEV, "--no-browser"],
    "model clear": [DEV],
    "model info": [DEV],
    "model upload": [DEV, "missing.stac"],
    "protocol decode": ["zz"],
    "protocol show": None,
    "record": [DEV, "-o", "r.mcap", "--no-progress"],
    "sim ft": None,
    "sim serve": None,
    "snake": ["missing.stac", DEV, "--json"],
    "stream": [DEV],
    "train": ["missing.npz", "-o", "m.stac"],
    "twin generate": ["-o", "exists.npz"],
    "twin population": ["-o", "exists.npz", "--units", "0", "--sessions", "1"],
    "twin report": None,
}
# Second walk: values the parser accepts, run against a simulated device that answers (the
# values then reach the code that uses them: a timeout, a count, a stall timeout).
SIM = "sim://?scene=idle&speed=max"
LIVE_BASES: dict[str, list[str]] = {
    "info": [SIM],
    "stream": [SIM, "--count", "1"],
    "ft stream": [SIM + "&ft=bota", "--count", "1"],
    "record": [SIM, "-o", "r.mcap", "--count", "1", "--no-progress"],
}
# Accepted values that ask for a run without end (Ctrl-C ends it): valid, not run.
ENDLESS = {("stream", "--count", "0"), ("ft stream", "--count", "0"), ("record", "--count", "0")}
# Options whose accepted value replaces the input that fails fast (another output folder
# would let the demo run for real): walked by the parser only.
PARSE_ONLY = {("demo", "--output"), ("twin generate", "--output"), ("twin population", "--output")}
PARSER = build_parser()  # built once: main() builds the same tree on every call (~50 ms)
VERBS = dict(leaves(PARSER))


class Hang(Exception):
    pass


@dataclass
class Walk:
    """What the walk saw (the figures of the report)."""

    options: set[tuple[str, str]] = field(default_factory=set)
    cases: int = 0
    usage: int = 0  # refused by the parser (exit 2)
    typed: int = 0  # accepted by the parser, then a typed error (exit 3) or a usage error
    parsed_only: int = 0  # accepted by a verb walked through the parser only
    problems: list[str] = field(default_factory=list)


def _arguments(verb: str) -> Iterator[tuple[str, argparse.Action]]:
    """(spelling or positional dest, action) of every argument taking a value."""
    for action in VERBS[verb]:
        if isinstance(action, argparse._HelpAction) or action.nargs == 0:
            continue
        if action.option_strings:
            yield action.option_strings[-1], action
        else:
            yield action.dest, action


def _refused(argv: list[str]) -> bool:
    with contextlib.redirect_stderr(io.StringIO()):
        try:
            PARSER.parse_args(argv)
        except SystemExit:
            return True
    return False


def _argv(
    verb: str, name: str, action: argparse.Action, value: str, bases: dict[str, Any] = BASES
) -> list[str]:
    base = list(bases[verb] or [])
    if action.option_strings:
        return [*verb.split(), *base, name, value]
    positionals = [a for a in VERBS[verb] if not a.option_strings and a.nargs != 0]
    index = positionals.index(action)
    if index < len(base) and not base[index].startswith("-"):
        base[index] = value
    else:
        base.insert(0 if not positionals[:index] else index, value)
    return [*verb.split(), *base]


@contextlib.contextmanager
def _guard(seconds: int) -> Iterator[None]:
    """SIGALRM raises Hang in the main thread after `seconds` (in-process runs must end)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def fire(*_: object) -> None:
        raise Hang

    old = signal.signal(signal.SIGALRM, fire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _run(argv: list[str], parse_only: bool) -> tuple[int | None, str]:
    """The exit code of `spectratac argv` in-process (None: parsed, not run) and its stderr."""
    err = io.StringIO()
    code: int | None
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            with _guard(CASE_GUARD_S):
                if parse_only:
                    PARSER.parse_args(argv)
                    code = None
                else:
                    code = main(argv)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else ExitCode.USAGE
        except Hang:
            return -1, "hung"
        except BaseException as exc:
            return -2, f"{type(exc).__name__}: {exc}"
    return code, err.getvalue()


def _fixtures(folder: Path) -> set[Path]:
    (folder / "full").mkdir()
    (folder / "full" / "keep.txt").write_text("a user's file")
    (folder / "exists.npz").write_bytes(b"a user's file")
    return set(folder.rglob("*"))


def walk_verbs(
    tmp_path: Path, verbs: list[str], bases: dict[str, list[str] | None] = BASES
) -> Walk:
    """Every argument of `verbs` with every hostile value, on top of `bases`; with
    LIVE_BASES only the values the parser accepts are run (the others are the first walk's)."""
    seen = Walk()
    live = bases is not BASES
    for verb in verbs:
        for name, action in _arguments(verb):
            seen.options.add((verb, name))
            for label, value in HOSTILE.items():
                folder = tmp_path / f"{verb.replace(' ', '_')}{len(seen.options)}{label}"
                folder.mkdir()
                before = _fixtures(folder)
                argv = _argv(verb, name, action, value, bases)
                old = Path.cwd()
                os.chdir(folder)
                parse_only = bases[verb] is None or (verb, name) in PARSE_ONLY
                try:
                    if live and (_refused(argv) or (verb, name, label) in ENDLESS):
                        continue
                    code, err = _run(argv, parse_only)
                finally:
                    os.chdir(old)
                seen.cases += 1
                where = f"{verb} {name}={label}"
                if live and code in (ExitCode.OK, ExitCode.FAILURE):
                    seen.parsed_only += 1  # a valid value: the run ended
                    continue
                if code is None:
                    seen.parsed_only += 1
                elif code == ExitCode.USAGE and "error:" in err:
                    seen.usage += 1
                elif code == ExitCode.ERROR and "error:" in err:
                    seen.typed += 1
                else:
                    seen.problems.append(f"{where}: exit {code}: {err[-300:]!r}")
                if "Traceback" in err:
                    seen.problems.append(f"{where}: a traceback: {err[-300:]!r}")
                left = set(folder.rglob("*")) - before
                if left:
                    seen.problems.append(f"{where}: left {sorted(p.name for p in left)}")
    return seen


@pytest.mark.parametrize("verb", sorted(VERBS))
def test_every_option_of_every_verb_refuses_hostile_values(
    verb: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(cli, "build_parser", lambda: PARSER)
    seen = walk_verbs(tmp_path, [verb])
    assert not seen.problems, "\n".join(seen.problems)
    assert seen.cases == len(seen.options) * len(HOSTILE)


@pytest.mark.parametrize("verb", sorted(LIVE_BASES))
def test_accepted_values_end_against_a_device_that_answers(
    verb: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(cli, "build_parser", lambda: PARSER)
    seen = walk_verbs(tmp_path, [verb], LIVE_BASES)  # type: ignore[arg-type]
    assert not seen.problems, "\n".join(seen.problems)


def test_every_verb_is_walked() -> None:
    assert set(BASES) == set(VERBS)


def test_every_numeric_option_has_a_documented_range() -> None:
    for verb, actions in VERBS.items():
        for action in actions:
            if action.type in (float, int):
                pytest.fail(f"{verb} {action.option_strings}: no range (cli.values.RANGES)")
            if action.type in RANGES.values() and action.help and not action.choices:
                assert "range" in action.help, f"{verb} {action.option_strings}"


# ------------------------------------------------------------------ URL parameters
def _sim_cases() -> Iterator[tuple[str, str, str]]:
    for key in sorted(SIM_PARAMS):
        for label, value in HOSTILE.items():
            yield key, label, value


def _in_range(param: Param, value: str) -> bool:
    """Whether the guide's range admits `value` (an oracle apart from the parser's code)."""
    if len(value) > MAX_URL_CHARS or (not value.isascii() and "\udcff" in value):
        return False
    if param.kind == "text":
        return True
    if param.kind == "choice":
        return value in param.choices
    if param.kind == "flag":
        return value.lower() in ("1", "0", "true", "false", "yes", "no", "on", "off")
    try:
        number = int(value) if param.kind == "integer" else float(value)
    except ValueError:
        return False
    lo = -math.inf if param.lo is None else param.lo
    hi = math.inf if param.hi is None else param.hi
    return math.isfinite(number) and lo <= number <= hi


@pytest.mark.parametrize(("key", "label", "value"), list(_sim_cases()))
def test_every_sim_parameter_refuses_hostile_values(key: str, label: str, value: str) -> None:
    url = f"sim://?{key}={value}"
    try:
        parse_sim_url(url)
    except DeviceError as exc:
        message = str(exc)
        assert "\n" not in message and len(message) < 2 * MAX_URL_CHARS
        assert "ValueError" not in message  # no internal exception leaks into it
        assert not _in_range(SIM_PARAMS[key], value), f"{key}={label} is in its range, yet refused"
        return
    assert _in_range(SIM_PARAMS[key], value), f"sim://?{key}={label} accepted outside its range"


#: Every F/T driver's option table (spectratac.ft.options); sim:// is walked above.
FT_URL_PARAMS = {m.__name__.rsplit(".", 1)[1]: m.URL_PARAMS for m in (bota, netft, rosbag)}
FT_URL_PARAMS["csv"] = csvfile.URL_PARAMS


def test_every_ft_scheme_has_its_table_walked() -> None:
    assert set(ft_schemes()) <= {*FT_URL_PARAMS, "sim"}, "a new F/T driver: walk its table"


def _ft_cases() -> Iterator[tuple[str, str, str, str]]:
    for scheme, table in FT_URL_PARAMS.items():
        for key in sorted(table):
            for label, value in HOSTILE.items():
                yield scheme, key, label, value


@pytest.mark.parametrize(("scheme", "key", "label", "value"), list(_ft_cases()))
def test_every_ft_url_parameter_refuses_hostile_values(
    scheme: str, key: str, label: str, value: str
) -> None:
    """The F/T drivers' options go through the same checker as sim://'s (one place)."""
    table = FT_URL_PARAMS[scheme]
    url = f"{scheme}://x?{key}={value}"
    try:
        Options(url, {key: value}, table)
    except FTURLError as exc:
        message = str(exc)
        assert "\n" not in message and len(message) < 2 * MAX_URL_CHARS
        assert "ValueError" not in message
        assert not _in_range(table[key], value), f"{key}={label} is in its range, yet refused"
        return
    assert _in_range(table[key], value), f"{url[:60]} accepted outside its range"


@pytest.mark.parametrize("url", ["sim://?colour=red", "sim://?scene=idle&speed=1e-300",
                                 "sim://?fault_rate=nan", "sim://?fault_stall=nan",
                                 "sim://?fault_unplug=nan", "sim://?speed=nan"])  # fmt: skip
def test_the_issues_sim_urls_are_refused_with_what_is_known(url: str) -> None:
    with pytest.raises(DeviceError) as refused:
        Sensor.open(url, timeout=5.0)
    message = str(refused.value)
    assert "ValueError" not in message and "could not convert" not in message
    if "colour" in url:
        assert "unknown parameter colour; known: absent, duration, fault" in message
    else:
        assert "must be a finite number in [" in message


@pytest.mark.parametrize(
    "url",
    [
        "rosbag://" + "b" * 100_000,
        "netft://" + "h" * 100_000,
        "csv://" + "c" * 100_000,
        "bota://" + os.fsdecode(b"/dev/\xff"),
        "sim://?ft=bota&ft_rate=nan",
        "netft://127.0.0.1?cpf=nan",
        "netft://127.0.0.1?cpf=1&cpt=1&colour=red",
    ],
    ids=lambda u: u[:30],
)
def test_ft_urls_refuse_hostile_values_typed(url: str) -> None:
    with pytest.raises(FTError) as refused:
        FTSensor.open(url, timeout=2.0)
    assert len(str(refused.value)) < 2 * MAX_URL_CHARS


@pytest.mark.parametrize(
    "url",
    [
        "socket://" + "h" * 100_000 + ":5",
        "socket://127.0.0.1:70000",
        "socket://127.0.0.1:-1",
        os.fsdecode(b"/dev/tty\xff"),
    ],
    ids=lambda u: u[:30],
)
def test_device_urls_refuse_hostile_values_typed(url: str) -> None:
    with pytest.raises(DeviceError) as refused:
        Sensor.open(url, timeout=2.0)
    assert len(str(refused.value)) < 2 * MAX_URL_CHARS


# ------------------------------------------------------------------ real processes
SAMPLE = [
    ["stream", "sim://?scene=idle", "--timeout", "inf"],
    ["stream", "sim://?scene=idle&speed=1e-300", "--count", "1", "--timeout", "5"],
    ["live", "sim://?scene=idle", "--port", "70000", "--no-browser"],
    ["live", "sim://?scene=idle", "--foxglove", "-1", "--no-browser"],
    ["decode", "missing.stac", "sim://?scene=idle", "--duration", "nan"],
    ["record", "sim://?scene=idle", "-o", "r.mcap", "--timeout", "nan"],
    ["stream", "sim://?scene=idle&colour=red", "--count", "1"],
    ["ft", "stream", "rosbag://" + "b" * 100_000],
]


@pytest.mark.parametrize("argv", SAMPLE, ids=lambda a: " ".join(a)[:60])
def test_a_sample_in_real_processes(argv: list[str], tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "spectratac", *argv],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=120,  # a hang guard: each ends in about a second
    )
    assert done.returncode in (ExitCode.USAGE, ExitCode.ERROR), done.stderr
    assert "Traceback" not in done.stderr and "error:" in done.stderr
    assert not list(tmp_path.iterdir()), "a file was left behind"
