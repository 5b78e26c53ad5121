"""Input checks at the Python edge: wrong *types* become ``TypeError`` naming the field here;
wrong *values* (length, NaN, negative mass, unknown labels) are checked by the Rust engine and
raised as :class:`selfmanip.SelfmanipError` (a ``ValueError``) naming the field there."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np


def vector(field: str, value: Any) -> list[float]:
    """A 1-D sequence of real numbers as a list of floats."""
    if isinstance(value, (str, bytes, dict)) or value is None:
        raise TypeError(f"`{field}` must be a 1-D sequence of numbers, got {type(value).__name__}")
    try:
        arr = np.asarray(value)
    except Exception as e:  # pragma: no cover - numpy accepts almost anything
        raise TypeError(f"`{field}` must be a 1-D sequence of numbers: {e}") from e
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.number)):
        raise TypeError(f"`{field}` must hold real numbers, got dtype {arr.dtype}")
    if np.iscomplexobj(arr):
        raise TypeError(f"`{field}` must hold real numbers, got complex")
    if arr.ndim != 1:
        raise ValueError(f"`{field}` must be 1-D, got shape {arr.shape}")
    return [float(v) for v in arr]


def real(field: str, value: Any) -> float:
    """A real scalar (``bool`` is rejected: ``True`` is not a mass)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"`{field}` must be a real number, got {type(value).__name__}")
    return float(value)


def text(field: str, value: Any) -> str:
    if not isinstance(value, str):
        raise TypeError(f"`{field}` must be a string, got {type(value).__name__}")
    return value
