"""What drives the RHex leap's legs: :class:`Saturated` (chapter 3's constant saturated torque
``tau_s`` of Table 4.2) or :class:`GearedMotor` (``motors_per_leg`` X-RHex motors, thesis
Table 2.1, behind a gearbox of ratio ``ratio`` with the controller current limit
``current_limit_a``: the torque-speed line clipped by the current limit, section 2.1.2).

:func:`selfmanip.leap`, :func:`selfmanip.sweep` (one actuator, or a list of them swept as an
axis), :func:`selfmanip.distributed.sweep` and the chapter-3 job take ``actuator=``; left out,
the leap runs the engine's default actuator (``selfmanip.leap.defaults()["config"]
["actuator"]``). :class:`GearedMotor`'s defaults are the engine's (read from Rust, not typed
here): ``GearedMotor()`` is the default geared motor.

``gear_ratio=`` is the shorthand kept from before the typed actuator: ``gear_ratio=G`` is a
geared motor of ratio ``G`` whose current limit and motor count are the ``current_limit_a``
/ ``motors_per_leg`` keywords when given, else the defaults — without them it is
``GearedMotor(ratio=G)``, the same leap bit for bit; ``gear_ratio=None`` is ``Saturated()``.
Giving both ``gear_ratio`` and ``actuator`` is refused (:class:`InvalidInputError` naming
``gear_ratio``), and so is ``current_limit_a``/``motors_per_leg`` next to an ``actuator``
(naming the keyword): an actuator carries all its fields.

>>> import selfmanip
>>> selfmanip.GearedMotor(ratio=20.0).current_limit_a == selfmanip.GearedMotor().current_limit_a
True
>>> selfmanip.leap("++", 0.0, actuator=selfmanip.Saturated(), dt=None).actuator
Saturated()
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, Mapping, Union

import numpy as np

from . import _checks, _native
from ._facade import DEFAULT, _Default
from .errors import InvalidInputError, InvalidTypeError

__all__ = ["Actuator", "GearedMotor", "Saturated", "from_config"]


def _default_geared_motor() -> Mapping[str, Any]:
    """The engine's default geared motor: the default leap configuration's actuator."""
    actuator = dict(_native.leap_defaults()["config"]["actuator"])
    if actuator.get("kind") != "geared_motor":
        raise RuntimeError(f"the engine's default actuator is {actuator!r}, not a geared motor: "
                           "GearedMotor has no defaults to read")
    return actuator


_GEARED = _default_geared_motor()
#: The largest motor count the engine holds (a ``u32``).
_MOTORS_MAX = 2**32 - 1


def _positive_real(field: str, value: Any) -> float:
    v = _checks.real(field, value)
    if not (math.isfinite(v) and v > 0):
        raise InvalidInputError(f"`{field}` must be finite and positive, got {v}", field)
    return v


@dataclass(frozen=True)
class Saturated:
    """Chapter 3's actuator: the constant saturated torque ``tau_s`` (Table 4.2) at either
    leg, whatever its speed."""


@dataclass(frozen=True)
class GearedMotor:
    """``motors_per_leg`` X-RHex motors per planar leg behind a gearbox of ratio ``ratio``,
    current-limited at ``current_limit_a`` (A). Defaults: the engine's default geared motor.
    Bad fields raise :class:`~selfmanip.errors.InvalidInputError` or
    :class:`~selfmanip.errors.InvalidTypeError` naming the field."""

    ratio: float = float(_GEARED["gear_ratio"])
    current_limit_a: float = float(_GEARED["current_limit_a"])
    motors_per_leg: int = int(_GEARED["motors_per_leg"])

    def __post_init__(self) -> None:
        object.__setattr__(self, "ratio", _positive_real("ratio", self.ratio))
        object.__setattr__(self, "current_limit_a", _positive_real("current_limit_a", self.current_limit_a))
        object.__setattr__(self, "motors_per_leg", _checks.integer("motors_per_leg", self.motors_per_leg, 1,
                                                                   _MOTORS_MAX))


#: A leap's actuator.
Actuator = Union[Saturated, GearedMotor]

#: The names that set a geared motor's fields by keyword (``current_limit_a=``), the engine's
#: own list.
MOTOR_FIELDS = frozenset(_native.leap_actuator_fields())


def from_config(actuator: Mapping[str, Any]) -> Actuator:
    """The actuator of a leap's configuration (``result.config["actuator"]``, a dict with
    ``kind``)."""
    kind = actuator.get("kind")
    if kind == "saturated_torque":
        return Saturated()
    if kind == "geared_motor":
        return GearedMotor(ratio=actuator["gear_ratio"], current_limit_a=actuator["current_limit_a"],
                           motors_per_leg=actuator["motors_per_leg"])
    raise InvalidInputError(f"`actuator.kind`: unknown actuator {kind!r}", "actuator.kind")


#: A point's actuator as the façade carries it: an :data:`Actuator`, a bare gear ratio (the
#: ``gear_ratio=G`` shorthand: the ratio only, the motor's other fields from the keywords or
#: the defaults), or ``DEFAULT`` (the engine's default actuator).
Choice = Union[Saturated, GearedMotor, float, _Default]


def _one(value: Any, field: str) -> Choice:
    """One ``actuator=`` value (``field`` names it in errors)."""
    if value is DEFAULT or isinstance(value, (Saturated, GearedMotor)):
        return value
    raise InvalidTypeError(f"`{field}` must be selfmanip.Saturated() or selfmanip.GearedMotor(...), got "
                           f"{type(value).__name__} {value!r}", field)


def _ratio(value: Any, field: str = "gear_ratio") -> Choice:
    """One ``gear_ratio=`` value: ``None`` the saturated torque, a number the ratio."""
    if value is DEFAULT:
        return DEFAULT
    if value is None:
        return Saturated()
    if isinstance(value, (Saturated, GearedMotor)):
        raise InvalidTypeError(f"`{field}`: an actuator goes in `actuator=`, got {value!r}", field)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InvalidTypeError(f"`{field}` must be a real number or None, got {type(value).__name__}", field)
    return _positive_real(field, value)


def choices(actuator: Any, gear_ratio: Any) -> list[Choice]:
    """The actuators of ``actuator=`` or of the ``gear_ratio=`` shorthand, each a scalar or a
    1-D sequence (a swept axis): typed, checked, with ``DEFAULT`` alone."""
    if actuator is not DEFAULT and gear_ratio is not DEFAULT:
        raise InvalidInputError("give `actuator` or its shorthand `gear_ratio`, not both", "gear_ratio")
    field, value, one = (("gear_ratio", gear_ratio, _ratio) if actuator is DEFAULT
                         else ("actuator", actuator, _one))
    if isinstance(value, np.ndarray) and value.ndim > 1:
        raise InvalidInputError(f"`{field}` must be a scalar or 1-D, got shape {value.shape}", field)
    if isinstance(value, np.ndarray) and value.ndim == 0:
        values = [value.item()]
    elif value is None or value is DEFAULT or isinstance(value, (Saturated, GearedMotor, numbers.Number, str)):
        values = [value]
    elif hasattr(value, "__iter__") and not isinstance(value, Mapping):
        values = list(value)
    else:
        values = [value]
    if not values:
        raise InvalidInputError(f"`{field}` is empty", field)
    out = [one(v, f"{field}[{i}]" if len(values) > 1 else field) for i, v in enumerate(values)]
    if len(out) > 1 and any(v is DEFAULT for v in out):
        raise InvalidInputError(f"`{field}`: DEFAULT cannot be mixed with other values", field)
    return out


def check_motor_fields(points: list[Choice], names: Any) -> None:
    """A geared motor's field by keyword (``current_limit_a=``) next to an actuator that
    carries it, or that has none (:class:`Saturated`), is ambiguous: refused naming the
    keyword. With the ``gear_ratio=G`` shorthand or the default actuator it sets that field."""
    given = sorted(set(names) & MOTOR_FIELDS)
    if not given:
        return
    if any(isinstance(p, Saturated) for p in points):
        raise InvalidInputError(
            f"`{given[0]}` sets the geared motor, but the actuator is chapter 3's saturated torque "
            "(Saturated(), or gear_ratio=None): give a gear ratio, or a GearedMotor(...) with this field",
            given[0])
    if any(isinstance(p, GearedMotor) for p in points):
        raise InvalidInputError(
            f"`{given[0]}` is a field of the GearedMotor given as `actuator`: set it there, "
            f"GearedMotor(..., {given[0]}=...)", given[0])


def native_args(point: Choice) -> tuple[float | None, dict[str, Any]]:
    """The binding's encoding of a point's actuator, the only place that knows it: the
    ``gear_ratio`` argument (``None`` the default actuator, NaN the saturated torque, a number
    the geared motor of that ratio) and the geared motor's fields as overrides by name."""
    if point is DEFAULT:
        return None, {}
    if isinstance(point, Saturated):
        return math.nan, {}
    if isinstance(point, GearedMotor):
        return point.ratio, {"current_limit_a": point.current_limit_a, "motors_per_leg": point.motors_per_leg}
    return float(point), {}
