"""Design-insight analyses of thesis section 4.3, computed by the general machinery (Rust
``rhex_model::analysis``), with RHex as the worked example.

Units: SI and radians everywhere (pitch ``phi`` nose-up, ``theta`` clockwise from the body's
+z, z down). ``model`` is a :class:`selfmanip.rhex.Model` (default: Table 4.2), a dict of
Table 4.2 overrides, or any :class:`selfmanip.Robot`: the section-4.3 analyses are written for
RHex's two legs and its Table 4.2 symbols, so a robot that is not an ``rhex.Model`` gets an
:class:`~selfmanip.InvalidTypeError` that says so; :func:`tail_effect` works on any robot.

- 4.3.1 reactive standing: :func:`reactive_stand` (Results A.1-A.3);
- 4.3.2 sensor sweep: :func:`max_sensor_pitch` (Result B.1), :func:`sensor_pitch_range`,
  :func:`holding_torque` (B.2), :func:`pitch_rate_gain` (B.3, eq. 4.59), :func:`fig_4_8`;
- 4.3.3 leaping: :func:`splay_derivative` (4.61, C.2), :func:`single_leg_pitch_accel`
  (4.63, C.3), :func:`takeoff_speed` (4.64-4.66, C.4), :func:`fig_4_10`, :func:`fig_4_11`,
  :func:`optimal_gear_ratio`, :func:`fig_4_12`;
- legs as tails: :func:`leg_effectiveness` (4.67-4.68, C.5), :func:`tail_effect` (any robot).

The takeoff analyses use X-RHex's motor (catalog ``x-rhex``, gearbox efficiency 0.82, two motors
per planar leg) as the linear torque-speed line ``tau <= kP kG (1 - kG thetadot)``.
"""

from __future__ import annotations

import math
import os
from typing import Any, Mapping, Sequence

import numpy as np

from . import _checks
from . import _native as _n
from .errors import InvalidInputError, InvalidTypeError
from .robot import Robot

_DEG = math.pi / 180.0
_LEGS = ("stick", "half_circle", "rolling")


def _params(model: Any) -> dict[str, Any] | None:
    """The Table 4.2 values of ``model`` (``None``: the shipped table)."""
    from .rhex import Model

    if model is None:
        return None
    if isinstance(model, Model):
        return model.params
    if isinstance(model, Robot):
        raise InvalidTypeError(
            f"`model`: this analysis is RHex's (section 4.3: two legs, Table 4.2 symbols), and {model!r} is "
            "not an RHex model; pass selfmanip.rhex.Model(...) (tail_effect works on any robot)", "model")
    if isinstance(model, Mapping):
        return Model(model).params
    raise InvalidTypeError(f"`model` must be a selfmanip.rhex.Model, a dict of Table 4.2 values or None, got "
                           f"{type(model).__name__}", "model")


def _int(field: str, value: Any, lo: int) -> int:
    return _checks.integer(field, value, lo)


def _range(field: str, value: Any) -> list[float]:
    v = _checks.vector(field, value)
    if len(v) != 2 or not all(math.isfinite(x) for x in v) or not v[0] < v[1]:
        raise InvalidInputError(f"`{field}` must be (lo, hi) with lo < hi, got {value!r}", field)
    return v


def _leg(value: Any) -> str:
    v = _checks.text("leg", value)
    if v not in _LEGS:
        raise InvalidInputError(f"`leg` must be one of {_LEGS}, got {v!r}", "leg")
    return v


# --------------------------------------------------------------------------- 4.3.2


def sensor_pitch_range(model: Any = None, grid: int = 72) -> dict[str, Any]:
    """Extremes of the quasi-static pitch over every contact mode of Fig. 4.3 (grid search over
    the joint torus, then pattern-search refinement): ``max_phi``, ``argmax`` (theta1, theta2),
    ``argmax_label``, ``min_phi``, ``argmin``, ``rolling_max_phi`` (both legs rolling)."""
    return dict(_n.analysis_sensor_pitch_range(_params(model), _int("grid", grid, 8)))


def max_sensor_pitch(model: Any = None, grid: int = 72) -> float:
    """Result B.1: the largest sensor pitch (rad), found by search over all quasi-static modes.
    Thesis: ``arcsin((rho1 - rho_b)/(l1 + l2))`` = 17.0 deg for Table 4.2."""
    return float(sensor_pitch_range(model, grid)["max_phi"])


def holding_torque(theta1: float, theta2: float = -2.5, model: Any = None) -> dict[str, Any]:
    """Joint torques holding the quasi-static pose at ``(theta1, theta2)`` (4.21)-(4.23) in its own
    contact mode (Result B.2: ``theta2 = -2.5`` folds the rear leg so the rear body slides)."""
    return dict(_n.analysis_holding_torque(_params(model), _checks.real("theta1", theta1),
                                           _checks.real("theta2", theta2)))


def pitch_rate_gain(theta1: float, theta2: float = -2.5, model: Any = None) -> float:
    """Result B.3, eq. (4.59): ``dtheta1/dphi = 1/H_phi`` at the quasi-static pose; command
    ``theta1dot = gain * phidot_desired`` to sweep the pitch at an exact rate."""
    return float(_n.analysis_pitch_rate_gain(_params(model), _checks.real("theta1", theta1), _checks.real("theta2", theta2)))


def fig_4_8(n: int = 25, theta1_range: Sequence[float] = (-math.pi / 2, 0.0),
            theta2_range: Sequence[float] = (-math.pi, 0.0), model: Any = None) -> dict[str, np.ndarray]:
    """Fig. 4.8: largest leg speed ``|theta1dot|`` (rad/s) before a contact lifts, zero torque,
    on an ``n x n`` grid (a linear program in ``s = ydot^2`` solved with Clarabel). Arrays
    ``theta1, theta2, phi, max_leg_speed`` (NaN: no pose / no liftoff) and ``label``."""
    pts = _n.analysis_fig_4_8(_params(model), _range("theta1_range", theta1_range),
                              _range("theta2_range", theta2_range), _int("n", n, 2))
    return {
        "theta1": np.array([p["theta1"] for p in pts]),
        "theta2": np.array([p["theta2"] for p in pts]),
        "phi": np.array([p["phi"] for p in pts]),
        "max_leg_speed": np.array([np.nan if p["max_leg_speed"] is None else p["max_leg_speed"] for p in pts]),
        "label": np.array([p["label"] for p in pts], dtype=object),
    }


# --------------------------------------------------------------------------- 4.3.3


def takeoff_speed(theta2: float, phi: float, phi_dot: float = 0.0, gear_ratio: float = 23.0,
                  leg: str = "rolling", model: Any = None) -> dict[str, Any] | None:
    """(4.64)-(4.66): with only the rear leg down at ``(theta2, phi)``, pitch rate ``phi_dot``,
    and the motor at full torque, the first leg rate at which the normal force vanishes:
    ``leg_rate`` (rad/s), ``xdot`` (body forward speed, m/s), ``tau`` (N m). ``leg`` is
    ``"stick"``, ``"half_circle"`` (RHex's leg) or ``"rolling"`` (rolls at every angle, as
    (4.66)). ``None`` if the leg cannot keep contact even at rest."""
    out = _n.analysis_takeoff_speed(_params(model), _leg(leg), _checks.real("theta2", theta2),
                                    _checks.real("phi", phi), _checks.real("phi_dot", phi_dot),
                                    _checks.real("gear_ratio", gear_ratio))
    return out


def _grid2(pts: list[dict], xkey: str, xs: Sequence[float], ykey: str, ys: Sequence[float], legs=None):
    out = {}
    for leg in legs or [None]:
        arr = np.full((len(xs), len(ys)), np.nan)
        th = np.full((len(xs), len(ys)), np.nan)
        sel = [p for p in pts if leg is None or p["leg"] == leg]
        for k, p in enumerate(sel):
            i, j = divmod(k, len(ys))
            arr[i, j] = np.nan if p["xdot"] is None else p["xdot"]
            th[i, j] = p["theta2"]
        out[leg] = (arr, th)
    return out


def fig_4_10(n: int = 13, theta2_range: Sequence[float] = (-30 * _DEG, 30 * _DEG),
             phi_range: Sequence[float] = (-10 * _DEG, 10 * _DEG), gear_ratio: float = 23.0,
             model: Any = None) -> dict[str, np.ndarray]:
    """Fig. 4.10: ``|xdot|`` (m/s) at rear-leg takeoff over ``theta2 x phi`` (``n x n``),
    ``phi_dot = 0``: ``stick`` and ``rolling`` arrays indexed ``[theta2, phi]``."""
    t2 = _range("theta2_range", theta2_range)
    ph = _range("phi_range", phi_range)
    n = _int("n", n, 2)
    pts = _n.analysis_fig_4_10(_params(model), t2, ph, n, _checks.real("gear_ratio", gear_ratio))
    xs, ys = np.linspace(*t2, n), np.linspace(*ph, n)
    g = _grid2(pts, "theta2", xs, "phi", ys, legs=["Stick", "Rolling"])
    return {"theta2": xs, "phi": ys, "stick": g["Stick"][0], "rolling": g["Rolling"][0]}


def fig_4_11(ratios: Sequence[float] | None = None, phis: Sequence[float] | None = None,
             theta2_range: Sequence[float] = (-45 * _DEG, 45 * _DEG), model: Any = None) -> dict[str, np.ndarray]:
    """Fig. 4.11: best ``|xdot|`` over ``theta2`` for each gear ratio and pitch (rolling legs,
    ``phi_dot = 0``): ``xdot[ratio, phi]``, ``theta2_opt[ratio, phi]``, ``best_ratio[phi]`` (on
    the grid)."""
    ratios = np.arange(10.0, 60.1, 2.5) if ratios is None else np.asarray(_checks.vector("ratios", ratios))
    phis = np.linspace(-10 * _DEG, 10 * _DEG, 5) if phis is None else np.asarray(_checks.vector("phis", phis))
    pts = _n.analysis_fig_4_11(_params(model), [float(r) for r in ratios], [float(p) for p in phis],
                               _range("theta2_range", theta2_range))
    arr, th = _grid2(pts, "gear_ratio", ratios, "phi", phis)[None]
    return {"gear_ratio": ratios, "phi": phis, "xdot": arr, "theta2_opt": th,
            "best_ratio": ratios[np.nanargmax(arr, axis=0)]}


def optimal_gear_ratio(phi: float = 0.0, phi_dot: float = 0.0, theta2_range: Sequence[float] = (-45 * _DEG, 45 * _DEG),
                       ratio_range: Sequence[float] = (5.0, 80.0), model: Any = None) -> tuple[float, float]:
    """The gear ratio maximising the best takeoff speed at ``phi`` (grid + golden section; not
    convex) and that speed (m/s). Thesis: 25-30 vs X-RHex's 23."""
    g, v = _n.analysis_optimal_gear_ratio(_params(model), _checks.real("phi", phi), _checks.real("phi_dot", phi_dot),
                                          _range("theta2_range", theta2_range), _range("ratio_range", ratio_range))
    return float(g), float(v)


def fig_4_12(phi_dots: Sequence[float] | None = None, phis: Sequence[float] | None = None,
             theta2_range: Sequence[float] = (-45 * _DEG, 45 * _DEG), gear_ratio: float = 23.0,
             model: Any = None) -> dict[str, np.ndarray]:
    """Fig. 4.12: best ``|xdot|`` over ``theta2`` for each pitch rate and pitch (rolling legs):
    ``xdot[phidot, phi]`` (the pitch rates ``phi_dots`` under ``phidot``)."""
    phi_dots = np.linspace(-100 * _DEG, 100 * _DEG, 9) if phi_dots is None else np.asarray(_checks.vector("phi_dots", phi_dots))
    phis = np.linspace(-10 * _DEG, 10 * _DEG, 5) if phis is None else np.asarray(_checks.vector("phis", phis))
    pts = _n.analysis_fig_4_12(_params(model), [float(v) for v in phi_dots], [float(p) for p in phis],
                               _range("theta2_range", theta2_range), _checks.real("gear_ratio", gear_ratio))
    arr, th = _grid2(pts, "phidot", phi_dots, "phi", phis)[None]
    return {"phidot": phi_dots, "phi": phis, "xdot": arr, "theta2_opt": th}


def splay_derivative(theta_m: float, tau: float, theta_m_dot: float = 0.0, model: Any = None) -> float:
    """Result C.2, (4.61): ``d((U lam)_2n - (U lam)_1n)/d theta_d`` at ``theta_d = 0`` (N/rad) in
    double stance with equal hip torques ``tau``; negative = splay reduces the imbalance. The
    model's own leg shape is used (pass ``{"leg_shape": "stick", "I_b": 0}`` for (4.61)'s D.3)."""
    return float(_n.analysis_splay_derivative(_params(model), _checks.real("theta_m", theta_m),
                                              _checks.real("theta_m_dot", theta_m_dot), _checks.real("tau", tau)))


def single_leg_pitch_accel(theta2: float, phi: float, theta2_dot: float, phi_dot: float, tau2: float,
                           leg: str = "stick", model: Any = None) -> float:
    """Result C.3, (4.63): pitch acceleration (rad/s^2) with only the rear leg down."""
    return float(_n.analysis_single_leg_pitch_accel(
        _params(model), _leg(leg), _checks.real("theta2", theta2), _checks.real("phi", phi),
        _checks.real("theta2_dot", theta2_dot), _checks.real("phi_dot", phi_dot), _checks.real("tau2", tau2)))


# --------------------------------------------------------------------------- tails


def leg_effectiveness(model: Any = None, pairs: int = 3) -> float:
    """Result C.5: body rotation per full in-phase revolution of all legs in flight, divided by
    ``2 pi`` (magnitude; the body turns against the legs), from conservation of momentum with
    massive legs. Default legs: Table 4.2 doubled for contralateral pairs (0.126 kg,
    0.00092 kg m^2) with ``pairs`` planar legs at ``+l, 0, -l`` (3) or ``+-l`` (2). Thesis:
    0.035 predicted, 0.039 measured (14 deg per revolution)."""
    p = _int("pairs", pairs, 1)
    if p > 3:
        raise InvalidInputError(f"`pairs` must be 1, 2 or 3, got {p}", "pairs")
    return float(_n.analysis_leg_effectiveness(_params(model), p))


def tail_effect(robot: Robot | str | os.PathLike, q0: Sequence[float], joints: Sequence[int],
                period_s: float = 0.3, dt_s: float = 2e-4) -> dict[str, Any]:
    """Any robot (a :class:`selfmanip.Robot`, or the path of its TOML/JSON description): body
    rotation ``Delta phi`` (rad) for one full in-phase revolution of ``joints`` in flight, by
    the zero-momentum integral (``momentum_delta_phi``) and by simulating the flight dynamics
    with PD-tracked joints (``simulated``: ``delta_phi``, ``max_tracking_error``,
    ``joint_travel``)."""
    if not isinstance(robot, Robot):
        if not isinstance(robot, (str, os.PathLike)):
            raise InvalidTypeError(f"`robot` must be a selfmanip.Robot or a description path, got "
                                   f"{type(robot).__name__}", "robot")
        robot = Robot.from_file(robot)
    js = [_int("joints[]", j, 0) for j in joints]
    return dict(_n.analysis_tail_effect(robot._native, _checks.vector("q0", q0), js,
                                        _checks.real("period_s", period_s), _checks.real("dt_s", dt_s)))


# --------------------------------------------------------------------------- 4.3.1


def reactive_stand(seed: int = 0, leg_shape: str = "half_circle", max_slope: float = 15 * _DEG, tau_d0: float = 3.0,
                   dt_s: float = 0.01, steps: int = 2000, model: Any = None) -> dict[str, np.ndarray]:
    """Results A.1-A.3: the reactive standing controller (4.50)-(4.54) from a random D.1 stance
    on rough terrain (each leg on its own plane, slopes up to ``max_slope``), initial leg fight
    ``tau_d0`` (N m). Series ``t``, ``epsilon`` (external cost), ``delta`` (internal cost),
    ``tau`` (n_steps x 2), ``q``; ``max_gap_m`` (constraint drift)."""
    tr = _n.analysis_standing_rhex(_params(model), _checks.text("leg_shape", leg_shape),
                                   _int("seed", seed, 0), _checks.real("max_slope", max_slope),
                                   _checks.real("tau_d0", tau_d0), _checks.real("dt_s", dt_s),
                                   _int("steps", steps, 1))
    return {k: (np.asarray(v) if isinstance(v, list) else v) for k, v in tr.items()}
