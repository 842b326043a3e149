"""Root of the typed error hierarchy: every error the library raises on purpose derives from it;
and `printable`, which makes text from outside (a device) safe to put in messages and on screens."""

import unicodedata


class SpectraTacError(Exception):
    """Base class for errors raised by spectratac; messages say what went wrong and what to do."""


def printable(text: str) -> str:
    r"""`text` safe to print on a terminal: control characters (C0, DEL, C1, and the
    Unicode format and line/paragraph separators) become visible escapes, so a string that
    came from a device cannot move the cursor, recolour or retitle the terminal.

    >>> printable("board\x1b[2J\r\n\x9b1m ok")
    'board\\x1b[2J\\r\\n\\x9b1m ok'
    """
    return "".join(_escape(c) if _is_control(c) else c for c in text)


def _is_control(c: str) -> bool:
    code = ord(c)
    return code < 0x20 or 0x7F <= code <= 0x9F or unicodedata.category(c) in ("Cf", "Zl", "Zp")


def _escape(c: str) -> str:
    code = ord(c)
    return {"\n": "\\n", "\r": "\\r", "\t": "\\t"}.get(c) or (
        f"\\x{code:02x}" if code <= 0xFF else f"\\u{code:04x}"
    )
