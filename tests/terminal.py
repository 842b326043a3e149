"""What a person sees of a verb's stderr: the bytes played through a terminal emulator
(pyte), so carriage returns redraw a progress bar in place as they do on screen; and the
checks that an estimate is said before any work shows progress (issue 26)."""

from __future__ import annotations

import re
import subprocess

import pyte

#: tqdm's time column while it runs: [elapsed<remaining], e.g. [00:03<00:12].
ETA = re.compile(r"\[\d\d:\d\d<\d\d:\d\d")


def screen(text: str, columns: int = 400, lines: int = 1000) -> list[str]:
    """The terminal's lines after `text` was written to it (trailing blanks stripped)."""
    scr = pyte.Screen(columns, lines)
    stream = pyte.Stream(scr)
    stream.feed(text.replace("\n", "\r\n"))
    return [line.rstrip() for line in scr.display if line.strip()]


def assert_estimate_first(stderr: str, what: str) -> str:
    """The line '<what>: estimated …' comes before any progress bar, and a bar later shows
    the time left; returns the estimate line."""
    found = re.search(rf"^{re.escape(what)}: estimated [^\n]+", stderr, re.M)
    assert found, f"no estimate line for {what!r} in:\n{stderr[:2000]}"
    first_bar = re.search(r"\d+%\|", stderr)
    assert first_bar is None or found.start() < first_bar.start(), "a bar came before the ETA"
    assert ETA.search(stderr[found.end() :]), f"no bar with the time left after:\n{stderr}"
    assert found.group(0) in screen(stderr), "the estimate line is not left on the screen"
    return found.group(0)


def run_in_terminal(argv: list[str], timeout: float) -> subprocess.CompletedProcess[str]:
    """Run a verb and keep its output as a terminal receives it: bytes decoded without
    universal newlines, so a progress bar's carriage returns redraw in place in `screen`
    (text=True would turn each redraw into a line, and a bar that redraws for longer on a
    busy machine would scroll the estimate off the screen)."""
    run = subprocess.run(argv, capture_output=True, timeout=timeout)
    return subprocess.CompletedProcess(
        run.args,
        run.returncode,
        run.stdout.decode(errors="replace"),
        run.stderr.decode(errors="replace"),
    )
