"""What the two sweeps of the package share — the RHex leap preset (:mod:`selfmanip.leap`) and
any robot's (:mod:`selfmanip.simulation`): the :data:`DEFAULT` marker, the thread count, the
progress callback, the typing of swept columns, the statuses that count as done and the
warning when no point got there. Each lives here once; the two façades differ only in what
they run."""

from __future__ import annotations

import os
import sys
import warnings
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from . import _checks
from ._sweep_report import failure_summary as _summary
from .errors import AllPointsFailedWarning, InvalidTypeError

#: Statuses of a run that reached its end: the final time, or the apex it was asked to stop
#: at; every other status is the engine stopping it (Zeno, a budget, no contact solution, …)
#: or, in a sweep, the error kind of a point that could not run. A leap is done when it flew
#: (its ``flew`` column: a leap that never left the ground also ends at ``final_time``).
COMPLETE_STATUSES = ("final_time", "apex")


class _Default:
    """An argument left out: the Rust default is used (the argument is not sent)."""

    _instance: "_Default | None" = None

    def __new__(cls) -> "_Default":
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "DEFAULT"

    def __reduce__(self):
        return (_Default, ())


#: An argument left at ``DEFAULT`` takes the Rust crate's default (chosen in Rust, once).
DEFAULT = _Default()


def threads(value: Any) -> int:
    """The worker threads of a sweep: ``None`` is every CPU this process may use; otherwise
    a positive int (:class:`~selfmanip.errors.InvalidInputError` /
    :class:`~selfmanip.errors.InvalidTypeError` naming ``threads``)."""
    if value is None:
        return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return _checks.integer("threads", value, 1)


def progress_bar(total: int, stream=None) -> Callable[[int], None]:
    """A text bar on ``stream`` (stderr) redrawn with the number of points done."""
    stream = stream or sys.stderr
    width = 30

    def update(done: int) -> None:
        filled = int(width * done / max(total, 1))
        stream.write(f"\rsweep [{'#' * filled}{'.' * (width - filled)}] {done}/{total}")
        if done >= total:
            stream.write("\n")
        stream.flush()

    return update


def progress(value: Any, total: int) -> Callable[[int], None] | None:
    """``progress=`` of a sweep as the callback the engine calls with the number of points
    done: ``True`` a bar on stderr, a callable itself, ``False``/``None`` none."""
    if value is True:
        return progress_bar(total)
    if value is None or value is False:
        return None
    if not callable(value):
        raise InvalidTypeError(f"`progress` must be True, False or a callable, got {type(value).__name__}",
                               "progress")
    return value


def column(values: Sequence[Any]) -> np.ndarray:
    """A swept column: floats when every value is a number, strings when every value is a
    string, else objects (dicts such as a terrain, lists, mixed values)."""
    values = list(values)
    if values and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.asarray(values, dtype=float)
    if values and all(isinstance(v, str) for v in values):
        return np.asarray(values, dtype=str)
    return np.asarray(values, dtype=object)


def done(table: Mapping[str, Any]) -> Any:
    """What counts as done in a sweep table: a leap table's ``flew`` column, else the
    :data:`COMPLETE_STATUSES`."""
    if "flew" in table:
        return np.asarray(table["flew"], dtype=bool)
    return COMPLETE_STATUSES


def failure_summary(table: Mapping[str, Any]) -> str | None:
    """``None`` when some point of a sweep table is done (:func:`done`); otherwise a
    one-line account: the count of each status and the first error."""
    return _summary(table, done(table))


def warn_if_all_failed(table: Mapping[str, Any], stacklevel: int = 3) -> None:
    """An :class:`~selfmanip.errors.AllPointsFailedWarning` when no point reached its end."""
    msg = failure_summary(table)
    if msg is not None:
        warnings.warn(msg, AllPointsFailedWarning, stacklevel=stacklevel + 1)
