"""What the README says about every verb, checked against the verbs themselves (issue 24):
the number of conformance checks, which verbs stop on --count/--duration, and that --help
shows every option's default."""

from __future__ import annotations

import argparse
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from spectratac.cli import build_parser
from spectratac.cli.options import shows_default
from spectratac.conformance.checks import CHECKS
from spectratac.conformance.model_checks import MODEL_CHECKS, applicable

README = " ".join((Path(__file__).resolve().parents[2] / "README.md").read_text().split())
# `ft info --count N` sizes its check (records read to measure the rate); it never stops a run.
COUNT_IS_NOT_A_STOP = {"ft info"}


def verbs(parser: argparse.ArgumentParser, path: str = "") -> Iterator[tuple[str, list]]:
    """(verb path, its actions) of every parser that runs something."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield path, parser._actions
    for sub in subs:
        for name, child in sub.choices.items():
            yield from verbs(child, f"{path} {name}".strip())


VERBS = {path: {o for a in actions for o in a.option_strings} for path, actions in verbs(
    build_parser())}  # fmt: skip


def claimed(pattern: str) -> list[str]:
    """The backticked verbs of the README's list that `pattern` (one group) captures."""
    found = re.search(pattern, README)
    assert found, f"the README no longer says: {pattern}"
    return re.findall(r"`([a-z ]+)`", found.group(1))


def test_the_conformance_count_is_the_suites() -> None:
    from spectratac.device import Sensor

    found = re.search(
        r"`spectratac conformance` runs (\d+) checks on a device that decodes on board "
        r"\((\d+) of the link protocol, and (\d+) of on-device decoding.*?for each of the "
        r"(\d+) protocol checks",
        README,
    )
    assert found, "the README's sentence on the conformance suite changed: update this test"
    total, protocol, model, faulted = map(int, found.groups())
    with Sensor.open("sim://?scene=idle&speed=max") as sensor:  # a device that decodes
        runs = len(CHECKS) + len(applicable(sensor.info.capabilities))
    assert (total, protocol, model, faulted) == (runs, len(CHECKS), len(MODEL_CHECKS), protocol)
    assert total == protocol + model


def test_the_verbs_that_stop_on_count_and_duration_are_the_readmes() -> None:
    streaming = claimed(r"`--duration S` for when to stop \(the verbs that stream: (.*?);")
    duration_only = claimed(r"`--duration S` alone where a scene, a page or a game runs: (.*?)\)")
    assert streaming and duration_only
    for verb in streaming:
        assert {"--count", "--duration"} <= VERBS[verb], f"`{verb}` lacks --count or --duration"
    for verb in duration_only:
        assert "--duration" in VERBS[verb], f"`{verb}` has no --duration"
    for verb, options in VERBS.items():
        if "--duration" in options:
            assert verb in streaming + duration_only, f"the README does not list `{verb}`"
        if "--count" in options and verb not in COUNT_IS_NOT_A_STOP:
            assert verb in streaming, f"`{verb}` stops on --count; the README does not say so"


@pytest.mark.parametrize("verb", sorted(dict(verbs(build_parser()))))
def test_help_shows_every_default(verb: str) -> None:
    parser = build_parser()
    actions = dict(verbs(parser))[verb]
    for action in actions:
        if shows_default(action):
            assert "default" in (action.help or ""), (
                f"spectratac {verb} --help: {'/'.join(action.option_strings) or action.dest} "
                f"hides its default {action.default!r}"
            )
