"""Progress bars, made in this one place so that every verb shows them only on a terminal.

A bar redraws itself with carriage returns: on a terminal that is one line that moves, in a
log file or a pipe it is a line per redraw (`model upload` wrote ~1,700 of them). So a bar is
shown only when its stream (stderr) is a terminal, and never when the caller turned it off
(`--no-progress`, `--json`). The lines that say what will take how long
(`spectratac.cli.eta.announce`) are printed either way.

>>> import io
>>> bar(total=3, file=io.StringIO()).disable  # not a terminal: no bar
True
"""

from __future__ import annotations

import sys
from typing import IO, Any


def on_terminal(stream: IO[str] | None = None) -> bool:
    """True if `stream` (default: stderr) is a terminal."""
    stream = sys.stderr if stream is None else stream
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty is not None and isatty())
    except ValueError:  # closed
        return False


def bar(*, enabled: bool = True, **kwargs: Any) -> Any:
    """A tqdm bar on stderr (or `file=`), disabled unless `enabled` and that stream is a
    terminal; a disabled bar takes every call and draws nothing. tqdm is imported here, on
    first use, never at import."""
    from tqdm import tqdm

    kwargs.setdefault("file", sys.stderr)
    return tqdm(disable=not (enabled and on_terminal(kwargs["file"])), **kwargs)
