"""Root of the typed error hierarchy: every error the library raises on purpose derives from it."""


class SpectraTacError(Exception):
    """Base class for errors raised by spectratac; messages say what went wrong and what to do."""
