"""The errors weavecap raises for things a user can fix, and the one table of outcomes.

:data:`OUTCOMES` is the only place that decides how a command, or one photo of a batch, ends:
the error raised → the status written in ``report.json`` / ``summary.jsonl`` and the exit
status (docs/design.md, "Commands": 0 all done; 2 usage error, invalid input, or a missing requirement the message
names; 3 a photo was rejected; 1 anything unexpected). The command layer (``cli/main.py``) and the batch runner
(:mod:`weavecap.batch`) both look it up; nothing else maps errors to numbers.

The rule: one status per exit status. An input a user gave that does not fit a photo (a
``--pattern`` or ``--start-from`` of another repeat, a file type weavecap cannot read) is
``invalid`` (exit 2) in a batch as in a single run; like every usage error it writes nothing
into the photo's folder (``report.json``'s contract knows only ok, rejected and failed), and
its ``summary.jsonl`` line says why.
"""

from __future__ import annotations

from dataclasses import dataclass


class WeavecapError(Exception):
    """Base class: a message for a person; its exit status comes from :data:`OUTCOMES`."""

    @property
    def exit_code(self) -> int:
        """The exit status of a command that ends with this error (:func:`outcome`)."""
        return outcome(self).exit


class InputError(WeavecapError):
    """A usage error or an invalid input file (bad JSON, value out of range, missing file)."""


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


class BackendError(WeavecapError):
    """No usable rendering backend (libLLVM, Mitsuba variant); the message says what to install.

    Exit 2 like an invalid input: the user fixes it (installs a library, sets a variable) and
    runs again; nothing is written, and a batch tries the input again next run."""


@dataclass(frozen=True)
class Outcome:
    """How something ended.

    Attributes
    ----------
    status : the word in ``report.json``'s and ``summary.jsonl``'s ``status``
    exit : the exit status of the command (a batch: of its most severe outcome)
    severity : rank among outcomes; a batch exits with the most severe one
    """

    status: str
    exit: int
    severity: int


#: error raised (None: none) → Outcome. The first row whose class matches wins. A batch exits
#: with its most severe outcome (a rejected photo and an unexpected failure: 1). click's own
#: usage errors (unknown option or command) exit 2 like ``invalid``.
OUTCOMES: tuple[tuple[type[BaseException] | tuple[type[BaseException], ...] | None, Outcome], ...] = (
    (None, Outcome("ok", exit=0, severity=0)),
    ((InputError, BackendError), Outcome("invalid", exit=2, severity=1)),
    (PhotoError, Outcome("rejected", exit=3, severity=2)),
    (KeyboardInterrupt, Outcome("interrupted", exit=130, severity=4)),  # written nowhere: the batch stops
    (BaseException, Outcome("failed", exit=1, severity=3)),  # bugs, a worker that died
)

_BY_STATUS = {o.status: o for _, o in OUTCOMES}
_BY_EXIT = {o.exit: o for _, o in OUTCOMES}


def outcome(error: BaseException | None) -> Outcome:
    """The outcome of ending with ``error`` (None: success)."""
    for cls, result in OUTCOMES:
        if (error is None and cls is None) or (error is not None and cls is not None and isinstance(error, cls)):
            return result
    raise AssertionError("OUTCOMES ends with BaseException")  # pragma: no cover


def outcome_of_status(status: str) -> Outcome:
    """The outcome a written ``status`` stands for (``ok``, ``invalid``, ``rejected``, ``failed``)."""
    return _BY_STATUS[status]


def worst_exit(codes) -> int:
    """The exit status of a batch: its most severe outcome's (0 for none)."""
    return max((_BY_EXIT[c] for c in codes), key=lambda o: o.severity, default=_BY_STATUS["ok"]).exit
