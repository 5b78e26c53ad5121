"""What a sweep table says about its failures, for the RHex leap sweep and the sweep of any
robot alike (the façades pass ``_facade.COMPLETE_STATUSES`` as ``done``)."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np


def done_points(table: Mapping[str, Any], done: Sequence[str] | np.ndarray) -> np.ndarray:
    """Which points of a sweep table are done: ``done`` is the statuses that count as done,
    or the boolean mask itself (a leap sweep's ``flew`` column)."""
    status = np.asarray(table["status"]).astype(str)
    if isinstance(done, np.ndarray) and done.dtype == bool:
        return done
    return np.isin(status, list(done))


def failure_summary(table: Mapping[str, Any], done: Sequence[str] | np.ndarray) -> str | None:
    """``None`` when some point of a sweep table is done (:func:`done_points`); otherwise a
    one-line account: the count of each status and the first error."""
    status = np.asarray(table["status"]).astype(str)
    if len(status) == 0 or bool(done_points(table, done).any()):
        return None
    counts = ", ".join(f"{int(np.sum(status == s))} {s}" for s in sorted(set(status.tolist())))
    errors = [e for e in np.asarray(table.get("error", [])).astype(str) if e]
    first = f"; first error: {errors[0]}" if errors else ""
    return f"all {len(status)} points of the sweep failed ({counts}){first}"
