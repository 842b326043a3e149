"""URL scheme -> opener registries, the plug-in point for links and sensors.

A part that opens things by URL (``spectratac.device`` for optical transports,
``spectratac.ft`` for reference F/T sensors) keeps one `SchemeRegistry`. It knows its
built-in schemes by import path, and finds the others among the installed packages' entry
points of its group (as python-can finds interface plug-ins), loading a plug-in only when its
scheme is first opened; code may also add a scheme at run time with `register`. So a part
never imports the packages that plug into it: ``spectratac.sim`` registers ``sim://`` through
``pyproject.toml``'s entry points, and the device layer stays below the simulator.

>>> registry: SchemeRegistry[str] = SchemeRegistry("example", "spectratac.examples")
>>> registry.register("demo", "opened by demo")
>>> registry.lookup("demo"), registry.lookup("nope"), registry.schemes()
('opened by demo', None, ['demo'])
>>> try:
...     registry.register("demo", "another")
... except SchemeConflictError as exc:
...     print(exc)
example scheme 'demo' is registered already; pass replace=True to replace it
"""

from __future__ import annotations

import importlib
import threading
from collections.abc import Mapping
from importlib.metadata import entry_points
from typing import Generic, TypeVar

from spectratac.errors import SpectraTacError

Opener = TypeVar("Opener")


class SchemeConflictError(SpectraTacError):
    """A scheme was registered twice; the message names the scheme."""


class SchemeRegistry(Generic[Opener]):
    """Openers by URL scheme: registered ones, built-ins ("module:attribute" or
    "module:Class.method", imported on first use) and the entry points of `group` (loaded
    on first use of their name)."""

    def __init__(self, kind: str, group: str, builtin: Mapping[str, str] | None = None) -> None:
        self.kind = kind
        self.group = group
        self._builtin = dict(builtin or {})
        self._openers: dict[str, Opener] = {}
        self._lock = threading.Lock()

    def register(self, scheme: str, opener: Opener, *, replace: bool = False) -> None:
        """Open `scheme`:// URLs with `opener` from now on (SchemeConflictError if the scheme
        is taken and `replace` is False)."""
        with self._lock:
            if not replace and (scheme in self._openers or scheme in self._builtin):
                raise SchemeConflictError(
                    f"{self.kind} scheme {scheme!r} is registered already; "
                    f"pass replace=True to replace it"
                )
            self._builtin.pop(scheme, None)
            self._openers[scheme] = opener

    def lookup(self, scheme: str) -> Opener | None:
        """The opener of `scheme`, importing a built-in or loading a plug-in the first time;
        None when nobody provides the scheme."""
        with self._lock:
            opener = self._openers.get(scheme)
            if opener is not None:
                return opener
            target = self._builtin.get(scheme)
            if target is not None:
                module, _, path = target.partition(":")
                opener = importlib.import_module(module)
                for attr in path.split("."):  # "module:Class.method" names a class method
                    opener = getattr(opener, attr)
            else:
                found = entry_points(group=self.group, name=scheme)
                if not found:
                    return None
                opener = next(iter(found)).load()
            self._openers[scheme] = opener
            return opener

    def schemes(self) -> list[str]:
        """Every scheme this registry can open, without loading any plug-in."""
        with self._lock:
            names = set(self._openers) | set(self._builtin)
        names |= {ep.name for ep in entry_points(group=self.group)}
        return sorted(names)
