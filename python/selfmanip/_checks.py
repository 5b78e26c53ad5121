"""Input checks at the Python edge: wrong *types* become :class:`InvalidTypeError` (a
``TypeError``) naming the field here; wrong *values* (length, NaN, negative mass, unknown
labels) are checked by the Rust engine and raised as :class:`InvalidInputError` (a
``ValueError``) naming the field there. Both are :class:`selfmanip.SelfmanipError`."""

from __future__ import annotations

import argparse
import numbers
from typing import Any, Callable, Mapping

import numpy as np

from .errors import InvalidInputError, InvalidTypeError


def vector(field: str, value: Any) -> list[float]:
    """A 1-D sequence of real numbers as a list of floats."""
    if isinstance(value, (str, bytes, dict)) or value is None:
        raise InvalidTypeError(f"`{field}` must be a 1-D sequence of numbers, got {type(value).__name__}", field)
    try:
        arr = np.asarray(value)
    except Exception as e:  # pragma: no cover - numpy accepts almost anything
        raise InvalidTypeError(f"`{field}` must be a 1-D sequence of numbers: {e}", field) from e
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.number)):
        raise InvalidTypeError(f"`{field}` must hold real numbers, got dtype {arr.dtype}", field)
    if np.iscomplexobj(arr):
        raise InvalidTypeError(f"`{field}` must hold real numbers, got complex", field)
    if arr.ndim != 1:
        raise InvalidInputError(f"`{field}` must be 1-D, got shape {arr.shape}", field)
    return [float(v) for v in arr]


def real(field: str, value: Any) -> float:
    """A real scalar (``bool`` is rejected: ``True`` is not a mass)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InvalidTypeError(f"`{field}` must be a real number, got {type(value).__name__}", field)
    return float(value)


#: The largest integer any engine input holds (a signed 64-bit count, index or seed): a larger
#: Python int would otherwise fail in the conversion with an ``OverflowError`` naming nothing.
INT_MAX = 2**63 - 1


def integer(field: str, value: Any, lo: int | None = None, hi: int = INT_MAX) -> int:
    """An int (``bool`` rejected), at least ``lo`` when given and at most ``hi``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InvalidTypeError(f"`{field}` must be an int, got {type(value).__name__}", field)
    if lo is not None and value < lo:
        raise InvalidInputError(f"`{field}` must be >= {lo}, got {value}", field)
    if value > hi:
        raise InvalidInputError(f"`{field}` must be <= {hi}, got {value}", field)
    return int(value)


def text(field: str, value: Any) -> str:
    """A string the engine can read: UTF-8 (a lone surrogate such as ``"\\ud800"`` has no UTF-8
    form and failed in the conversion with a ``UnicodeEncodeError`` naming nothing)."""
    if not isinstance(value, str):
        raise InvalidTypeError(f"`{field}` must be a string, got {type(value).__name__}", field)
    try:
        value.encode("utf-8")
    except UnicodeEncodeError as e:
        raise InvalidInputError(f"`{field}` is not valid text: {e.reason} at position {e.start}", field) from None
    return value


def mapping(field: str, value: Any) -> dict[str, Any]:
    """A dict of named values (``None``: empty)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise InvalidTypeError(f"`{field}` must be a dict, got {type(value).__name__}", field)
    return dict(value)


def read_text_file(field: str, path: str) -> str:
    """The text of a UTF-8 file; a binary file is :class:`InvalidInputError` naming ``field``
    and the file, not a ``UnicodeDecodeError`` naming neither."""
    with open(path, "rb") as f:
        data = f.read()
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise InvalidInputError(f"`{field}`: {path} is not UTF-8 text ({e.reason} at byte {e.start})",
                                field) from None


def path_arg(text: str) -> str:
    """An ``argparse`` type for a path the command writes: an empty one names no file (``--out ""``
    wrote ``.png`` or fell back to stdout) and is refused with the option's name."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path names no file")
    return text
