"""The exceptions and warnings of selfmanip: one base, :class:`SelfmanipError`, and a few
kinds chosen by *what went wrong*, never by the wording of a message.

================================  =============================  ===============================
class                             also a                         raised when
================================  =============================  ===============================
:class:`InvalidInputError`        ``ValueError``                 an input has a bad value: a
                                                                 wrong length, a NaN, a negative
                                                                 mass, an unknown name or label;
                                                                 ``field`` names it
:class:`InvalidTypeError`         ``TypeError``                  an input has the wrong type;
                                                                 ``field`` names it
:class:`SingularKktError`         ``ValueError``                 the KKT matrix of (5.2) is
                                                                 singular at the state given
                                                                 (Lemma 5.1): ``kind``,
                                                                 ``condition_estimate``
:class:`IllPosedError`            ``ValueError``                 a quasi-static problem has no
                                                                 unique answer (4.21)-(4.23)
:class:`EngineError`              ``RuntimeError``               the engine could not go on: a
                                                                 step size that vanished, a
                                                                 value it produced that is not
                                                                 finite, a solver that did not
                                                                 converge, an internal error
:class:`ControllerError`          ``RuntimeError``               a Python controller given to
                                                                 :func:`selfmanip.simulate`
                                                                 raised; the original exception
                                                                 is its ``__cause__``
================================  =============================  ===============================

The Rust engine's error enums (``CoreError``, ``HybridError``, ``RhexError``, ``MotorError``)
are mapped variant by variant in ``crates/pybind/src/errors.rs``. ``KeyboardInterrupt``
(Ctrl-C during a leap or a sweep) is Python's own and is not wrapped.

:class:`AllPointsFailedWarning` is warned by :func:`selfmanip.sweep` when no point of a sweep
reached ``ok``.
"""

from __future__ import annotations

__all__ = [
    "AllPointsFailedWarning",
    "ControllerError",
    "EngineError",
    "IllPosedError",
    "InvalidInputError",
    "InvalidTypeError",
    "SelfmanipError",
    "SingularKktError",
]


class SelfmanipError(Exception):
    """Base of every error selfmanip raises on purpose. ``field`` names the offending input
    when there is one (``None`` otherwise)."""

    field: str | None

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message)
        self.field = field


class InvalidInputError(SelfmanipError, ValueError):
    """An input has a bad value; ``field`` names it (``"m_b"``, ``"q"``, ``"terrain.distance_m"``,
    ``"--t2"``)."""


class InvalidTypeError(SelfmanipError, TypeError):
    """An input has the wrong type; ``field`` names it."""


class SingularKktError(SelfmanipError, ValueError):
    """The KKT matrix of (5.2) is singular (Lemma 5.1). ``kind`` is ``"RedundantConstraints"``
    (dependent constraint rows, e.g. RHex's ``1111``) or ``"UnconstrainedMasslessMotion"`` (a
    massless limb no contact pins down); ``condition_estimate`` the estimate behind the
    verdict."""

    kind: str | None
    condition_estimate: float | None

    def __init__(self, message: str, field: str | None = None, kind: str | None = None,
                 condition_estimate: float | None = None):
        super().__init__(message, field)
        self.kind = kind
        self.condition_estimate = condition_estimate


class IllPosedError(SelfmanipError, ValueError):
    """A quasi-static problem (4.21)-(4.23) has no unique solution: too few contact rows (flight
    or one contact), the wrong number of torque constraints, or a singular augmented grasp
    map."""


class EngineError(SelfmanipError, RuntimeError):
    """The engine could not go on (the inputs were valid): an integration step that fell below
    its floor, a non-finite value the engine itself produced (extreme but finite parameters can
    do this), a solver that did not converge, or an internal error (a bug: please report it)."""


class ControllerError(SelfmanipError, RuntimeError):
    """A Python controller (``selfmanip.simulate(..., controller=f)``) raised: the run was
    stopped at once and the original exception is ``__cause__``; ``field`` is
    ``"controller"``."""


class AllPointsFailedWarning(UserWarning):
    """No point of a sweep reached ``ok``: the table's ``status`` and ``error`` columns say why."""
