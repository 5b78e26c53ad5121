"""What the Python robots that wrap a native model share: the check that they wrap the right
native class, and the structure every model has (its name and ``nq``)."""

from __future__ import annotations

from typing import Any

from .errors import InvalidTypeError


class WrappedModel:
    """Holds a native model in ``_native``. A subclass sets ``_native_class`` and
    ``_construct_with`` (the constructors to name when ``native`` is something else)."""

    _native_class: type
    _construct_with: str

    def __init__(self, native: Any):
        if not isinstance(native, self._native_class):
            raise InvalidTypeError(f"use {self._construct_with}", "native")
        self._native = native

    @property
    def name(self) -> str:
        return self._native.name

    @property
    def nq(self) -> int:
        """Number of generalized coordinates, ``len(q)``."""
        return self._native.nq
