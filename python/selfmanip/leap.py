"""RHex leaps from rest to apex (thesis chapter 3.2) and batched sweeps over them (issue 5).

A leap starts with the robot sitting at rest on its body (cell ``1010``), both legs touching
the ground; the front leg's motor starts at ``t = 0`` and the rear leg's at ``t = t2``
(negative: the rear leg starts first). A strategy ``"++"``, ``"+-"``, ``"-+"`` or ``"--"``
gives each leg's push direction (front, rear): ``+`` turns the leg with increasing theta (a
forward lunge, rolling on the half circle), ``-`` the other way (a flip onto the toe).

The robot is the chapter-5 RHex (Table 4.2 with the middle and rear leg pairs, toe friction
1.8 / 2.5). The legs' ``actuator`` (:mod:`selfmanip.actuator`) is ``selfmanip.Saturated()``,
chapter 3's constant saturated torque ``tau_s``, or ``selfmanip.GearedMotor(ratio,
current_limit_a, motors_per_leg)``; left out, the engine's default actuator (:func:`defaults`:
two X-RHex motors per planar leg behind a gearbox of ratio 28 and a 20 A current limit, thesis
section 4.3.3 and Table 2.1). ``gear_ratio=G`` is the shorthand for a geared motor of ratio
``G`` (``gear_ratio=None`` for ``Saturated()``), see :mod:`selfmanip.actuator`.

``selfmanip.leap`` is both this module and, called, :func:`leap`.

Any parameter is set by name, for a single leap or swept over an array:

* Table 4.2 symbols: ``m_b, I_b, m_l, I_l, l1, l2, rho1, rho2, rho_b, tau_s, g, leg_shape,
  mu_front, mu_middle, mu_rear``; the toes' law once they slip, ``toe_sliding``
  (``"coulomb"``, the default, or ``"frictionless"``: Assumption 5.9); Coulomb friction of
  the body ends, ``mu_body``; whether the legs carry their motors' rotors as joint armature,
  ``leg_rotors`` (``n J G^2`` of the leap's motor; default: legs with mass do, massless legs
  do not; ``True`` puts them on massless links too), or that armature set by hand,
  ``leg_armature_kg_m2`` (not both);
* the leap configuration: ``pairs`` (the two pushing leg pairs, e.g. ``["middle", "rear"]``;
  default: chapter 3's choice for the strategy, the leading pair disabled — the leap's robot
  has exactly these two), ``delta_t_s`` (pseudo-impulse duration, thesis 0.03 s),
  ``swing_accel_rad_s2``, ``swing_speed_rad_s``, ``toe_stub_rad``, ``terrain``,
  ``t_final_s``, ``stop_at_apex``, ``event_tol_s``, ``zeno_window_s``, ``zeno_max_events``;
* the geared motor's fields, with the default actuator or the ``gear_ratio`` shorthand:
  ``current_limit_a``, ``motors_per_leg``.

Results are reported in a z-**up** frame whose origin is the body centre at the start: apex
height ``apex_z_m`` (of the body centre above the ground, positive up), forward displacement
``apex_x_m``, pitch ``apex_phi_rad`` (nose-up positive). The leap *word* is the sequence of
ground-reaction-complex cells visited (labels ``FB FL RB RL``), zero-time cells suppressed,
joined by ``-``, e.g. ``1010-0110-0101-0001-0000``. Trajectories keep the thesis's NED
coordinates (``q = [theta..., x, z, phi]``, z down), see ``docs/conventions.md``.

>>> import numpy as np, selfmanip
>>> table = selfmanip.sweep("++", t2=np.linspace(-0.1, 0.1, 5), actuator=selfmanip.GearedMotor(ratio=28.0))
>>> sorted(table)[:3], len(table["t2_s"])
(['apex_phi_rad', 'apex_phidot_rad_s', 'apex_t_s'], 5)
>>> same = selfmanip.sweep("++", t2=np.linspace(-0.1, 0.1, 5), gear_ratio=28.0, threads=1)
>>> all(np.array_equal(table[k], same[k], equal_nan=table[k].dtype.kind == "f") for k in table)
True
"""

from __future__ import annotations

import copy
import functools
import inspect
import math
import numbers
import os
import sys
import types
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from . import _checks, _facade, _native
from ._facade import DEFAULT, _Default, failure_summary
from .actuator import (MOTOR_FIELDS, Actuator, Choice, GearedMotor, check_motor_fields, choices, from_config,
                       native_args)
from .errors import InvalidInputError, InvalidTypeError

__all__ = ["Apex", "DEFAULT", "LeapResult", "Trajectory", "defaults", "leap", "sweep", "sweep_points",
           "sweepable_names", "failure_summary", "STRATEGIES", "SWEEP_COLUMNS"]

STRATEGIES = ("++", "+-", "-+", "--")

#: The columns every sweep returns, in order (override columns follow ``gear_ratio``; a swept
#: ``actuator`` whose geared motors differ in current limit or motor count adds
#: ``current_limit_a`` and ``motors_per_leg`` there too, NaN for the saturated torque).
SWEEP_COLUMNS = ("strategy", "t2_s", "gear_ratio", "apex_z_m", "apex_x_m", "apex_phi_rad",
                 "apex_xdot_m_s", "apex_phidot_rad_s", "apex_zdot_m_s", "apex_t_s", "word",
                 "status", "flew", "n_events", "error")


@functools.lru_cache(maxsize=1)
def _defaults() -> dict[str, Any]:
    return dict(_native.leap_defaults())


def defaults() -> dict[str, Any]:
    """The engine's defaults: ``{"params": ..., "config": ...}`` — the chapter-5 parameters
    (Table 4.2 with toe friction) and ``LeapConfig::default()``, including the default
    ``actuator``. Every argument of :func:`leap` that is not given takes its value from here."""
    return copy.deepcopy(_defaults())


@functools.lru_cache(maxsize=1)
def _sweepable_names() -> tuple[str, ...]:
    return tuple(_native.leap_sweepable_names())


def sweepable_names() -> list[str]:
    """Every parameter name :func:`leap` and :func:`sweep` accept besides strategy, t2 and
    gear ratio, each once."""
    return list(_sweepable_names())


def _actuator_fields() -> frozenset[str]:
    """The names that set the geared motor (not parameters, not configuration fields)."""
    return MOTOR_FIELDS


@functools.lru_cache(maxsize=1)
def _default_values() -> dict[str, Any]:
    """Each sweepable name's default value (the geared motor's for its fields), for the type
    check at the Python edge."""
    d = _defaults()
    out: dict[str, Any] = {}
    out.update(d["params"])
    out.update(d["config"])
    actuator = d["config"].get("actuator", {})
    out.update({k: v for k, v in actuator.items() if k != "kind"})
    return out


def _check_type(name: str, value: Any) -> None:
    """A value of the wrong kind for its name (``delta_t_s="soon"``) is an
    :class:`InvalidTypeError` here; ranges and the rest are checked in Rust."""
    default = _default_values().get(name)
    if default is None or value is None:
        return  # optional fields (friction, toe stub) and unknown defaults: the engine decides
    if isinstance(default, bool):
        ok = isinstance(value, (bool, np.bool_))
    elif isinstance(default, (int, float)):
        ok = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
    elif isinstance(default, str):
        ok = isinstance(value, str)
    elif isinstance(default, Mapping):
        ok = isinstance(value, Mapping)
    elif isinstance(default, list):
        ok = isinstance(value, (list, tuple, np.ndarray))
    else:
        ok = True
    if not ok:
        raise InvalidTypeError(f"RHex parameter `{name}`: expected {type(default).__name__}, got "
                               f"{type(value).__name__} {value!r}", name)


@dataclass(frozen=True)
class Apex:
    """Body state at the apex of flight (z up, origin at the body centre at the start)."""

    t_s: float
    x_m: float
    z_m: float
    phi_rad: float
    xdot_m_s: float
    zdot_m_s: float
    phidot_rad_s: float


@dataclass(frozen=True)
class Trajectory:
    """A leap sampled on a uniform grid. ``q``/``qd`` are ``(n, nq)`` in thesis coordinates
    (NED, z down); ``contact_points_m`` and ``contact_forces_n`` are ``(n, n_contacts, 2)``
    world ``(x, z)`` (NED) points and ground-on-robot forces, NaN where a contact is off."""

    t_s: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    mode: list[str]
    contacts: list[str]
    contact_points_m: np.ndarray
    contact_forces_n: np.ndarray


@dataclass(frozen=True)
class LeapResult:
    """One leap: ``status`` (the engine's run status: ``apex``, ``final_time``, ``zeno``,
    ``terrain_discontinuity``, ...), ``flew`` (it reached its apex, or, with
    ``stop_at_apex=False``, flew and ran on to its final time) and, when it did not fly, the
    ``reason`` in words; the ``apex`` (the first apex of flight, also when the leap ran on
    past it with ``stop_at_apex=False``; None without one), the leap ``word`` (cells joined by
    ``-``), the labelled ``events`` (dicts with ``t_s, kind, mode_before, mode_after,
    contacts, energy_loss_j, force_n, impulse_n_s``, as :class:`selfmanip.Execution`'s), the start ``q0`` and, unless disabled, the ``trajectory``.
    ``params``/``config`` are the full inputs used; ``actuator`` the one the leap ran with
    (:class:`~selfmanip.actuator.Saturated` or :class:`~selfmanip.actuator.GearedMotor`,
    read from ``config["actuator"]``) and ``gear_ratio`` its ratio (``None``: the saturated
    torque)."""

    strategy: str
    t2_s: float
    gear_ratio: float | None
    status: str
    flew: bool
    apex: Apex | None
    word: str
    cells: list[str]
    events: list[dict[str, Any]]
    q0: np.ndarray
    q_names: list[str]
    params: dict[str, Any]
    config: dict[str, Any]
    trajectory: Trajectory | None = None
    reason: str = ""
    #: With ``sensitivities=[...]``: ``{(apex column, parameter): d column / d parameter}``
    #: for every apex column (``apex_t_s, apex_x_m, apex_z_m, apex_phi_rad, apex_xdot_m_s,
    #: apex_zdot_m_s, apex_phidot_rad_s``) and parameter name as given; NaN where the
    #: derivative is undefined (``sensitivity_ok`` False, ``sensitivity_reason`` says why).
    sensitivity: dict[tuple[str, str], float] | None = None
    sensitivity_ok: bool | None = None
    sensitivity_reason: str = ""
    #: The rear motor's start after the front one's that the leap ran with (s): ``t2``
    #: itself, or what the search of a touchdown-timed leap (``t2_reference="touchdown"``)
    #: found; and the rear leg's first touchdown after the front leg's (None if one of them
    #: never touched down).
    motor_t2_s: float | None = None
    touchdown_t2_s: float | None = None
    actuator: Actuator | None = None

    def to_dict(self, trajectory: bool = True) -> dict[str, Any]:
        """Plain JSON-ready data (NaN becomes ``None``)."""
        def clean(v):
            if isinstance(v, np.ndarray):
                return clean(v.tolist())
            if isinstance(v, float):
                return v if math.isfinite(v) else None
            if isinstance(v, list):
                return [clean(x) for x in v]
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            return v

        d: dict[str, Any] = {
            "strategy": self.strategy, "t2_s": self.t2_s, "gear_ratio": self.gear_ratio,
            "status": self.status, "flew": self.flew, "reason": self.reason, "word": self.word, "cells": self.cells,
            "apex": None if self.apex is None else dict(self.apex.__dict__),
            "events": self.events, "q0": self.q0, "q_names": self.q_names,
            "params": self.params, "config": self.config,
        }
        if trajectory and self.trajectory is not None:
            d["trajectory"] = dict(self.trajectory.__dict__)
        if self.sensitivity is not None:
            # JSON keys are strings: "d_<column>/d_<parameter>", as in a sweep's columns
            d["sensitivity"] = {f"d_{c}/d_{p}": v for (c, p), v in self.sensitivity.items()}
            d["sensitivity_ok"] = self.sensitivity_ok
            d["sensitivity_reason"] = self.sensitivity_reason
        return clean(d)

    def write_mcap(self, path: str | os.PathLike, metadata: Mapping[str, str] | None = None) -> None:
        """Writes the trajectory as an MCAP log for Foxglove (atomically; topics in
        ``docs/sweeps.md``)."""
        import json

        if self.trajectory is None:
            raise InvalidInputError("this result has no trajectory: run leap(..., dt=...) to sample one", "dt")
        md = {"strategy": self.strategy, "t2_s": repr(self.t2_s),
              "gear_ratio": "saturated" if self.gear_ratio is None else repr(self.gear_ratio),
              "status": self.status, "word": self.word,
              "params": json.dumps(self.params), "config": json.dumps(self.config)}
        md.update({str(k): str(v) for k, v in (metadata or {}).items()})
        write_mcap(path, self.params, self.trajectory, self.events, md)


def write_mcap(path: str | os.PathLike, params: Mapping[str, Any], trajectory: Trajectory,
               events: Sequence[Mapping[str, Any]] = (), metadata: Mapping[str, str] | None = None) -> None:
    """Writes any leap trajectory (for instance a synthetic one) as an MCAP log."""
    t = trajectory
    if not isinstance(params, Mapping):
        raise InvalidTypeError(f"`params` must be a dict, got {type(params).__name__}", "params")
    _native.leap_write_mcap(
        os.fspath(path), {str(k): _plain_value(str(k), v) for k, v in params.items()}, list(t.contacts),
        [float(v) for v in t.t_s],
        np.ascontiguousarray(t.q, dtype=float), np.ascontiguousarray(t.qd, dtype=float), list(t.mode),
        np.ascontiguousarray(t.contact_points_m, dtype=float),
        np.ascontiguousarray(t.contact_forces_n, dtype=float),
        [dict(e) for e in events], {str(k): str(v) for k, v in (metadata or {}).items()})


# ---------------------------------------------------------------------------------------------
# input checks (types here; values in Rust, which names the field)

def _strategy(value: Any, field: str = "strategy") -> str:
    if not isinstance(value, str):
        raise InvalidTypeError(f"`{field}` must be a string such as '++', got {type(value).__name__}", field)
    s = value.replace("(", "").replace(")", "").replace(",", "").replace(" ", "")
    if s not in STRATEGIES:
        raise InvalidInputError(f"`{field}`: unknown strategy {value!r} (expected one of {', '.join(STRATEGIES)})",
                                field)
    return s


def _real(field: str, value: Any, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InvalidTypeError(f"`{field}` must be a real number, got {type(value).__name__}", field)
    v = float(value)
    if not math.isfinite(v):
        raise InvalidInputError(f"`{field}` must be finite, got {v}", field)
    if positive and not v > 0:
        raise InvalidInputError(f"`{field}` must be positive, got {v}", field)
    return v


def _plain_value(field: str, value: Any) -> Any:
    """A parameter value as plain Python data (numbers must be finite)."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, (str, bool)):
        return value
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        v = float(value)
        if not math.isfinite(v):
            raise InvalidInputError(f"RHex parameter `{field}`: must be finite, got {v}", field)
        return v
    if isinstance(value, Mapping):
        return {str(k): _plain_value(f"{field}.{k}", v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain_value(field, v) for v in value]
    raise InvalidTypeError(f"RHex parameter `{field}`: unsupported value of type {type(value).__name__}", field)


def _overrides(params: Mapping[str, Any] | None, config: Mapping[str, Any]) -> dict[str, Any]:
    if params is not None and not isinstance(params, Mapping):
        raise InvalidTypeError(f"`params` must be a dict, got {type(params).__name__}", "params")
    known = set(sweepable_names())
    out: dict[str, Any] = {}
    for source in (params or {}, config):
        for k, v in source.items():
            if not isinstance(k, str):
                raise InvalidTypeError(f"parameter names must be strings, got {k!r}", "params")
            if k not in known:
                raise InvalidInputError(f"unknown parameter `{k}` (known: {', '.join(sorted(known))})", k)
            if k in out:
                # `leap(params={"m_b": 5}, m_b=9)` ran with 9: one value per name
                raise InvalidInputError(f"`{k}` is given both in `params` and as a keyword: give it once", k)
            _check_type(k, v)
            out[k] = _plain_value(k, v)
    return out


# ---------------------------------------------------------------------------------------------

def _sensitivity_names(value: Any) -> list[str] | None:
    if value is None:
        return None
    if isinstance(value, str) or not isinstance(value, Iterable):
        raise InvalidTypeError(
            f"`sensitivities` must be a list of parameter names, got {value!r}", "sensitivities")
    names = list(value)
    for n in names:
        if not isinstance(n, str):
            raise InvalidTypeError(
                f"`sensitivities`: parameter names are strings, got {n!r}", "sensitivities")
    return names


def leap(strategy: str = "++", t2: float = 0.0, gear_ratio: float | None | _Default = DEFAULT,
         params: Mapping[str, Any] | None = None, *, actuator: Actuator | _Default = DEFAULT,
         dt: float | None = 0.002, sensitivities: Iterable[str] | None = None, **config: Any) -> LeapResult:
    """One leap from rest to the apex of flight.

    ``strategy``: ``"++"``, ``"+-"``, ``"-+"`` or ``"--"`` (front, rear); ``t2``: the rear
    leg's start relative to the front leg's (s); ``actuator``: ``selfmanip.Saturated()``
    (chapter 3's saturated torque) or ``selfmanip.GearedMotor(ratio, current_limit_a,
    motors_per_leg)``; left out, the engine's default actuator
    (``defaults()["config"]["actuator"]``: the geared X-RHex motor). ``gear_ratio``: the
    shorthand of :mod:`selfmanip.actuator` (a number: geared X-RHex motors of this ratio;
    ``None``: the saturated torque), not together with ``actuator``. ``params``: Table 4.2
    overrides (``{"m_b": 8.0, "leg_shape": "stick"}``); ``dt``: trajectory sample time
    (``None``: no trajectory); further keywords set the leap configuration or the motor by name
    (see the module documentation); ``compliant_leg={"stiffness_n_per_m": k_r,
    "damping_n_s_per_m": c_r}`` (or ``stiffness_n_m_per_rad``, ``damping_n_m_s_per_rad`` at the
    knee) gives stick legs with mass a knee spring–damper (``docs/leap-model.md``).
    ``sensitivities``: parameter names (``"t2"``,
    ``"gear_ratio"``, ``"m_b"``, ``"I_b"``, ``"leg_armature_kg_m2"`` for legs that have
    armature, ``"leg_stiffness"`` and ``"leg_damping"`` for compliant legs) whose derivatives of every apex column are
    returned in ``result.sensitivity[("apex_z_m", "t2")]``, exact (variational equations
    and saltation matrices, not finite differences), NaN with ``sensitivity_ok`` False where
    undefined (e.g. at a change of the leap's mode sequence); each event then also carries
    ``"saltation"``, its saltation matrix over ``(q, q̇)`` (an ``(n, n)`` array; None where
    undefined). With ``sensitivities`` the leap always runs with ``control_free_joints=True``
    (the legs' prescribed motions in the air under step-size control, so that their
    touchdowns are resolved to the tolerances; about 3× the integration of the default leap):
    the result is identical to ``leap(..., control_free_joints=True)`` without them, and may
    differ from the default leap by the tolerances. Bad input raises
    :class:`selfmanip.InvalidInputError` (a ``ValueError``) or
    :class:`selfmanip.InvalidTypeError` (a ``TypeError``) naming the field; Ctrl-C interrupts.

    >>> import selfmanip
    >>> r = selfmanip.leap("++", t2=0.0, actuator=selfmanip.GearedMotor(ratio=28.0))
    >>> r.word.startswith("1010"), r.trajectory.q.shape[1], r.actuator.current_limit_a
    (True, 5, 20.0)
    """
    s = _strategy(strategy)
    t2v = _real("t2", t2)
    point = _one_actuator(actuator, gear_ratio)
    if dt is not None:
        dt = _real("dt", dt, positive=True)
    ov = _overrides(params, config)
    check_motor_fields([point], ov)
    names = _sensitivity_names(sensitivities)
    gear, motor = native_args(point)
    d = _native.leap_run(s, t2v, gear, {**ov, **motor}, dt, names)
    apex = None if d["apex"] is None else Apex(**d["apex"])
    events = [dict(e) for e in d["events"]]
    sens, sens_ok, sens_reason = None, None, ""
    if "sensitivity" in d:
        sd = d["sensitivity"]
        values = np.asarray(sd["values"], dtype=float)
        sens = {(c, p): float(values[i, j]) for i, c in enumerate(sd["columns"])
                for j, p in enumerate(sd["parameters"])}
        sens_ok, sens_reason = bool(sd["ok"]), str(sd["reason"])
        for e, x in zip(events, sd["saltations"]):
            e["saltation"] = None if x is None else np.asarray(x, dtype=float)
    traj = None
    if "trajectory" in d:
        t = d["trajectory"]
        traj = Trajectory(t_s=np.asarray(t["t_s"]), q=np.asarray(t["q"]), qd=np.asarray(t["qd"]),
                          mode=list(t["mode"]), contacts=list(t["contacts"]),
                          contact_points_m=np.asarray(t["contact_points_m"]),
                          contact_forces_n=np.asarray(t["contact_forces_n"]))
    used = from_config(d["config"]["actuator"])
    return LeapResult(strategy=s, t2_s=t2v, gear_ratio=used.ratio if isinstance(used, GearedMotor) else None,
                      actuator=used, status=d["status"], flew=bool(d["flew"]), apex=apex,
                      word="-".join(d["word"]), cells=list(d["word"]), events=events,
                      q0=np.asarray(d["q0"], dtype=float), q_names=list(d["q_names"]),
                      params=d["params"], config=d["config"], trajectory=traj, reason=d["reason"],
                      sensitivity=sens, sensitivity_ok=sens_ok, sensitivity_reason=sens_reason,
                      motor_t2_s=float(d["motor_t2_s"]), touchdown_t2_s=d["touchdown_t2_s"])


def _one_actuator(actuator: Any, gear_ratio: Any) -> Choice:
    """The actuator of a single leap (``actuator=`` or the ``gear_ratio=`` shorthand)."""
    points = choices(actuator, gear_ratio)
    if len(points) != 1:
        field = "gear_ratio" if actuator is DEFAULT else "actuator"
        raise InvalidInputError(f"`{field}`: a single leap takes one actuator, got {len(points)}", field)
    return points[0]


def _axis(field: str, value: Any) -> list[Any]:
    """A swept axis: a scalar or a 1-D sequence/array."""
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__iter__"):
        return [value]
    if np.ndim(np.asarray(value, dtype=object)) > 1:
        raise InvalidInputError(f"`{field}` must be a scalar or 1-D, got shape {np.shape(value)}", field)
    arr = list(value) if isinstance(value, (list, tuple)) else list(np.asarray(value, dtype=object).ravel())
    if not arr:
        raise InvalidInputError(f"`{field}` is empty", field)
    return arr


def sweep_points(strategy: str | Iterable[str] = "++", t2: Any = 0.0, gear_ratio: Any = DEFAULT,
                 *, actuator: Any = DEFAULT, grid: bool = True, **overrides: Any) -> dict[str, list[Any]]:
    """The points of a sweep as columns (what :func:`sweep` runs), checked: ``strategy``,
    the overrides by name, ``actuator`` (each point's :class:`~selfmanip.actuator.Saturated`,
    :class:`~selfmanip.actuator.GearedMotor`, bare ratio of the ``gear_ratio`` shorthand, or
    ``DEFAULT``) and ``t2_s``.

    With ``grid=True`` (default) the Cartesian product strategy x overrides (in the order
    given) x actuator x t2, t2 varying fastest; with ``grid=False`` every axis is a column
    of the same length (scalars broadcast). A swept value that is itself a dict (``terrain``)
    is one value."""
    axes: dict[str, list[Any]] = {}
    strategies = [strategy] if isinstance(strategy, str) else _axis("strategy", strategy)
    axes["strategy"] = [_strategy(s) for s in strategies]
    known = set(sweepable_names())
    for k, v in overrides.items():
        if k not in known:
            raise InvalidInputError(f"unknown parameter `{k}` (known: {', '.join(sorted(known))})", k)
        values = _axis(k, v)
        for x in values:
            _check_type(k, x)
        axes[k] = [_plain_value(k, x) for x in values]
    axes["actuator"] = choices(actuator, gear_ratio)
    axes["t2_s"] = [_real("t2", t) for t in _axis("t2", t2)]
    names = list(axes)
    if grid:
        n = int(np.prod([len(a) for a in axes.values()]))
        cols: dict[str, list[Any]] = {}
        repeat = n
        tile = 1
        for k in names:
            a = axes[k]
            repeat //= len(a)
            cols[k] = [x for x in a for _ in range(repeat)] * tile
            tile *= len(a)
        return cols
    lengths = {len(a) for a in axes.values() if len(a) != 1}
    if len(lengths) > 1:
        raise InvalidInputError("with grid=False every swept column must have the same length or be a scalar, got "
                                + ", ".join(f"{k}: {len(a)}" for k, a in axes.items()), "grid")
    n = lengths.pop() if lengths else 1
    return {k: (a * n if len(a) == 1 else a) for k, a in axes.items()}


def run_points(cols: Mapping[str, Sequence[Any]], params: Mapping[str, Any] | None = None, *,
               threads: int | None = None, progress: bool | Callable[[int], None] = False,
               sensitivities: Iterable[str] | None = None, motor_columns: bool | None = None,
               **config: Any) -> dict[str, np.ndarray]:
    """Runs points given as columns (from :func:`sweep_points`); the engine of :func:`sweep`
    and of :func:`selfmanip.distributed.sweep`. ``progress`` (a callable) receives the number
    of points done as they finish; Ctrl-C stops the sweep promptly with ``KeyboardInterrupt``.
    ``motor_columns``: whether the table has ``current_limit_a`` and ``motors_per_leg``
    columns (``None``: when these points' geared motors differ in them,
    :func:`motors_differ`; a part of a sweep passes the whole sweep's answer)."""
    n_threads = _facade.threads(threads)
    base = _overrides(params, config)
    strategies = list(cols["strategy"])
    t2 = [float(v) for v in cols["t2_s"]]
    points = list(cols["actuator"])
    extra = {k: [_plain_value(k, x) for x in v] for k, v in cols.items() if k not in ("strategy", "t2_s", "actuator")}
    check_motor_fields(points, list(base) + list(extra))
    n = len(strategies)
    names = _sensitivity_names(sensitivities)
    part = _native_sweep(strategies, t2, points, base, extra, n_threads, _facade.progress(progress, n), names)
    asked = np.asarray([native_args(p)[0] for p in points], dtype=float)
    ran = np.asarray(part["gear_ratio"], dtype=float)
    out: dict[str, np.ndarray] = {
        "strategy": np.asarray(strategies, dtype=str),
        "t2_s": np.asarray(t2, dtype=float),
        # the gear ratio a point ran with; the one asked for when it failed before running
        "gear_ratio": np.where(np.isnan(ran), asked, ran) if n else np.asarray([], dtype=float),
    }
    if motor_columns or (motor_columns is None and motors_differ(points)):
        out.update(_motor_columns(points))
    for k, v in extra.items():
        out[k] = _facade.column(v)
    for k in ("apex_z_m", "apex_x_m", "apex_phi_rad", "apex_xdot_m_s", "apex_phidot_rad_s",
              "apex_zdot_m_s", "apex_t_s"):
        out[k] = np.asarray(part[k], dtype=float)
    out["word"] = np.asarray(part["word"], dtype=str) if n else np.asarray([], dtype=str)
    out["status"] = np.asarray(part["status"], dtype=str) if n else np.asarray([], dtype=str)
    out["flew"] = np.asarray(part["flew"], dtype=bool)
    out["n_events"] = np.asarray(part["n_events"], dtype=np.int64)
    out["error"] = np.asarray(part["error"], dtype=str) if n else np.asarray([], dtype=str)
    if names is not None:
        for k, v in part.items():
            if k.startswith("d_"):
                out[k] = np.asarray(v, dtype=float)
        out["sensitivity_ok"] = np.asarray(part["sensitivity_ok"], dtype=bool)
    return out


def _native_sweep(strategies: list[str], t2: list[float], points: list[Choice], base: dict[str, Any],
                  extra: dict[str, list[Any]], threads: int, progress: Callable[[int], None] | None,
                  names: list[str] | None) -> Mapping[str, Any]:
    """The binding's sweep of the points, in input order. A geared motor's fields reach the
    binding as overrides of the whole call (a per-point column would turn a saturated point
    of the same call into a geared one), so the points run in one call per set of motor
    fields: one call for every sweep but a swept ``actuator`` whose geared motors differ."""
    encoded = [native_args(p) for p in points]
    groups: dict[tuple[tuple[str, Any], ...], list[int]] = {}
    for i, (_, motor) in enumerate(encoded):
        groups.setdefault(tuple(sorted(motor.items())), []).append(i)
    if len(groups) <= 1:
        motor = dict(next(iter(groups), ()))
        return _native.leap_sweep(strategies, t2, [g for g, _ in encoded], {**base, **motor}, extra, threads,
                                  progress, names)
    parts, done = [], 0
    for motor, idx in groups.items():
        report = None if progress is None else (lambda k, before=done: progress(before + k))
        parts.append(_native.leap_sweep([strategies[i] for i in idx], [t2[i] for i in idx],
                                        [encoded[i][0] for i in idx], {**base, **dict(motor)},
                                        {k: [v[i] for i in idx] for k, v in extra.items()}, threads, report,
                                        names))
        done += len(idx)
    order = np.argsort(np.concatenate([np.asarray(idx) for idx in groups.values()]), kind="stable")
    return {k: np.concatenate([np.asarray(p[k]) for p in parts])[order] for k in parts[0]}


def motors_differ(points: Sequence[Choice]) -> bool:
    """Whether the geared motors among a sweep's actuators differ in current limit or motor
    count (then its table reports them)."""
    return len({(p.current_limit_a, p.motors_per_leg) for p in points if isinstance(p, GearedMotor)}) > 1


def _motor_columns(points: list[Choice]) -> dict[str, np.ndarray]:
    """``current_limit_a`` and ``motors_per_leg`` of each point (NaN where it has no geared
    motor of its own)."""
    return {k: np.asarray([float(getattr(p, k)) if isinstance(p, GearedMotor) else math.nan for p in points])
            for k in ("current_limit_a", "motors_per_leg")}


def sweep(strategy: str | Iterable[str] = "++", t2: Any = 0.0, gear_ratio: Any = DEFAULT,
          params: Mapping[str, Any] | None = None, threads: int | None = None,
          progress: bool | Callable[[int], None] = False, *, actuator: Any = DEFAULT, grid: bool = True,
          config: Mapping[str, Any] | None = None, sensitivities: Iterable[str] | None = None,
          **swept: Any) -> dict[str, np.ndarray]:
    """Many leaps at once, in parallel on ``threads`` threads (default: the CPUs this process
    may use), with the GIL released. Returns a dict of equal-length numpy arrays
    (``pandas.DataFrame(result)`` works): ``strategy, t2_s, gear_ratio`` (the ratio each point
    ran with, NaN for the saturated torque), any swept parameter, ``apex_z_m, apex_x_m,
    apex_phi_rad, apex_xdot_m_s, apex_phidot_rad_s, apex_zdot_m_s, apex_t_s`` (NaN without an
    apex), ``word``, ``status`` (the engine's run status such as ``apex``, ``final_time`` or
    ``zeno``, or the error kind of a failed point such as ``invalid_params``), ``flew`` (the leap
    reached its apex, or flew and ran on to its final time), ``n_events`` and ``error`` (why a
    point did not fly: the error's message, or the reason the leap ended). A failing point never
    loses the others, and the result is bit-identical for any ``threads``. When no point flies
    an :class:`selfmanip.errors.AllPointsFailedWarning` says so. Ctrl-C interrupts.

    ``strategy``: one strategy or several; ``t2``, ``actuator`` (``selfmanip.Saturated()``,
    ``selfmanip.GearedMotor(...)`` or a list of them; left out: the engine's default actuator;
    or its shorthand ``gear_ratio``: ratios, ``None`` the saturated torque) and any parameter
    given by name as a keyword
    (``m_b=[8, 9]``, ``leg_shape=["half_circle", "stick"]``, ``delta_t_s=...``): scalars or
    1-D arrays, combined as a grid (see :func:`sweep_points`; ``grid=False`` zips them
    instead). ``params`` (Table 4.2) and ``config`` (leap configuration) set fixed values for
    every point and are checked up front. ``progress=True`` draws a bar on stderr (or pass a
    callable receiving the number of points done). ``sensitivities=["t2", "gear_ratio"]``
    adds a float column ``"d_<apex column>/d_<name>"`` (e.g. ``d_apex_z_m/d_t2``) for every
    apex column and name — the derivatives of :func:`leap`'s ``sensitivity``, NaN where
    undefined — and a boolean column ``sensitivity_ok``; every point then runs with
    ``control_free_joints=True`` (as :func:`leap` with ``sensitivities``), and so do the
    table's other columns.

    >>> import selfmanip
    >>> r = selfmanip.sweep(["++", "--"], t2=[0.0, 0.05], gear_ratio=[20.0, 28.0], threads=2)
    >>> r["strategy"][:4].tolist(), r["gear_ratio"][:4].tolist(), r["t2_s"][:2].tolist()
    (['++', '++', '++', '++'], [20.0, 20.0, 28.0, 28.0], [0.0, 0.05])
    """
    cols = sweep_points(strategy, t2, gear_ratio, actuator=actuator, grid=grid, **swept)
    table = run_points(cols, params, threads=threads, progress=progress,
                       sensitivities=sensitivities, **_checks.mapping("config", config))
    _facade.warn_if_all_failed(table, stacklevel=2)
    return table


class _LeapModule(types.ModuleType):
    """``selfmanip.leap`` is this module *and* runs a leap when called: ``selfmanip.leap("++")``
    is :func:`leap`, while ``import selfmanip.leap`` and ``from selfmanip.leap import
    sweep_points`` reach the module."""

    def __call__(self, *args: Any, **kwargs: Any) -> LeapResult:
        return leap(*args, **kwargs)


sys.modules[__name__].__class__ = _LeapModule
__signature__ = inspect.signature(leap)
