"""The errors weavecap raises for things a user can fix, each with its exit status.

DESIGN.md: 0 all done; 2 usage error or invalid input file; 3 a photo was rejected; 1 anything
unexpected. The command layer turns these into a one-paragraph message, never a traceback.
"""

from __future__ import annotations


class WeavecapError(Exception):
    """Base class: a message for a person and the exit status the CLI should use."""

    exit_code = 1


class InputError(WeavecapError):
    """A usage error or an invalid input file (bad JSON, value out of range, missing file)."""

    exit_code = 2


class ParamsError(InputError):
    """A params file that does not describe a valid fabric.

    Attributes
    ----------
    field : str
        Dotted path of the offending field (``specular.ior``, ``pattern[2][3]``), or ``""``.
    """

    def __init__(self, message: str, *, field: str = "", path: str | None = None):
        self.field = field
        self.path = path
        where = f"{path}: " if path else ""
        what = f"{field}: " if field else ""
        super().__init__(f"{where}{what}{message}")


class PhotoError(WeavecapError):
    """A photo that cannot be read: corrupt, truncated, empty, oversized or not an image."""

    exit_code = 3


class BackendError(WeavecapError):
    """No usable rendering backend (libLLVM, Mitsuba variant); the message says what to install."""

    exit_code = 1
