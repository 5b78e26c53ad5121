"""Calibration: identify a model's physical parameters from measured runs, with the engine's
exact Jacobians (issue 33; the method and its checks: ``docs/calibration.md``).

``calibrate(model, data, parameters={name: (lo, hi)})`` fits the named parameters of
``model`` (``"leap"``: the RHex leap preset of :mod:`selfmanip.leap`) and a **measurement
model** — a constant offset per measured channel, ``"offset:apex_z_m"`` — to a table of
measured outcomes by bounded trust-region least squares (``scipy.optimize.least_squares``,
``method="trf"``), with the Jacobian the engine computes exactly through the leap's events
(``selfmanip.leap(..., sensitivities=[...])``), per-channel scales, an optional robust loss and
deterministic multi-start. The result carries the parameters, their covariance and 95 %
intervals, the residuals per row, an identifiability report and :meth:`Calibration.predict`.

>>> import selfmanip
>>> data = {"strategy": ["++"] * 2, "t2_s": [-0.05, 0.05], "apex_z_m": [0.28, 0.43]}
>>> fit = selfmanip.calibrate("leap", data, parameters={"m_b": (6.0, 9.0)})
>>> 6.0 <= fit.params["m_b"] <= 9.0, fit.n_model_runs > 0
(True, True)
"""

from __future__ import annotations

import csv
import math
import numbers
import os
import re
import time
from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from . import leap as _leap
from .errors import InvalidInputError, InvalidTypeError

__all__ = ["CHANNELS", "DEFAULT_CHANNEL_SCALES", "Calibration", "LeapModel", "MeasuredTable", "calibrate",
           "default_parameters", "read_table"]

#: The outcome columns a table may measure (SI), in the order the leap reports them.
CHANNELS = ("apex_t_s", "apex_x_m", "apex_z_m", "apex_phi_rad", "apex_xdot_m_s", "apex_zdot_m_s",
            "apex_phidot_rad_s")

#: Per-channel scales (the size of a motion-capture system's error on the apex state: 2 mm,
#: 0.5°, 20 mm/s, 5°/s, 2 ms): the residual of a channel is divided by its scale.
DEFAULT_CHANNEL_SCALES = {"apex_t_s": 2e-3, "apex_x_m": 2e-3, "apex_z_m": 2e-3,
                          "apex_phi_rad": math.radians(0.5), "apex_xdot_m_s": 0.02, "apex_zdot_m_s": 0.02,
                          "apex_phidot_rad_s": math.radians(5.0)}

OFFSET = "offset:"

# ---------------------------------------------------------------------------------------------
# reading a table

_UNITS = {  # dimension -> unit -> factor to SI
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
    "angle": {"rad": 1.0, "deg": math.pi / 180, "°": math.pi / 180},
    "velocity": {"m/s": 1.0, "cm/s": 1e-2, "mm/s": 1e-3},
    "rate": {"rad/s": 1.0, "deg/s": math.pi / 180, "°/s": math.pi / 180},
    "time": {"s": 1.0, "ms": 1e-3},
}
_QUANTITIES = {  # alias -> (column, dimension)
    "t2": ("t2_s", "time"), "t": ("apex_t_s", "time"),
    "x": ("apex_x_m", "length"), "z": ("apex_z_m", "length"), "phi": ("apex_phi_rad", "angle"),
    "xdot": ("apex_xdot_m_s", "velocity"), "zdot": ("apex_zdot_m_s", "velocity"),
    "phidot": ("apex_phidot_rad_s", "rate"),
}
_SYMBOLS = {"φ": "phi", "ẋ": "xdot", "ż": "zdot", "φ̇": "phidot", "ϕ": "phi", "pitch": "phi",
            "x_dot": "xdot", "z_dot": "zdot", "phi_dot": "phidot"}
_MISSING = {"", "*", "nan", "-", "—"}


def _quantity(name: str) -> str | None:
    """The quantity alias of a column name without its unit (``apex_z`` -> ``z``)."""
    s = name.strip().lower()
    s = _SYMBOLS.get(s, s)
    if s.startswith("apex_"):
        s = _SYMBOLS.get(s[5:], s[5:])
    return s if s in _QUANTITIES else None


def _column_unit(header: str) -> tuple[str, str, float] | None:
    """``(column, dimension, factor to SI)`` of an outcome or ``t2`` header, ``None`` for a
    column that is not one. Units by header (``z [mm]``, ``phi (deg)``) or by name
    (``apex_z_mm``, ``t2_s``); an outcome with no or an unknown unit is an error naming it."""
    h = header.strip()
    m = re.fullmatch(r"(.+?)\s*[\[(]\s*([^\])]*)\s*[\])]", h)
    if m:
        q, unit = _quantity(m.group(1)), m.group(2).strip().lower().replace("°", "deg").replace("sec", "s")
        if q is None:
            return None
    else:
        q, unit = _quantity(h), None
        if q is None:  # a unit in the name: apex_z_mm, phidot_deg_s
            for alias in sorted(_QUANTITIES, key=len, reverse=True):
                for prefix in (f"apex_{alias}_", f"{alias}_"):
                    if h.lower().startswith(prefix) and _quantity(alias):
                        q, unit = alias, h.lower()[len(prefix):].replace("_", "/")
                        break
                if q:
                    break
        if q is None:
            return None
    column, dim = _QUANTITIES[q]
    if unit is None:
        if h.lower() == column:
            return column, dim, 1.0
        raise InvalidInputError(f"column `{header}`: no unit (write `{q} [unit]`, e.g. "
                                f"`{q} [{next(iter(_UNITS[dim]))}]`, or the SI name `{column}`)", header)
    factor = _UNITS[dim].get(unit.replace("°", "deg"))
    if factor is None:
        raise InvalidInputError(f"column `{header}`: unknown unit `{unit}` for {dim} (known: "
                                f"{', '.join(_UNITS[dim])})", header)
    return column, dim, factor


def _numbers(header: str, values: Sequence[Any]) -> np.ndarray:
    out = np.empty(len(values))
    for i, v in enumerate(values):
        if v is None or (isinstance(v, str) and v.strip().lower() in _MISSING):
            out[i] = math.nan
            continue
        try:
            out[i] = float(v)
        except (TypeError, ValueError):
            raise InvalidInputError(f"column `{header}`, row {i}: not a number: {v!r}", header) from None
    return out


def _input_value(v: Any) -> Any:
    """A per-row input: a number where it reads as one (a CSV gives strings), else as is."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, str):
        try:
            return float(v)
        except ValueError:
            return v
    return v


@dataclass
class MeasuredTable:
    """A table in SI: ``inputs`` (``strategy``, ``t2_s`` and any leap parameter set per row),
    ``outcomes`` (channel -> values, NaN where missing) and the columns read as neither."""

    inputs: dict[str, list[Any]]
    outcomes: dict[str, np.ndarray]
    ignored: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.inputs["t2_s"])


def _columns(data: Any) -> dict[str, list[Any]]:
    """Columns of a DataFrame, a dict of columns or a CSV file (path)."""
    if isinstance(data, (str, os.PathLike)):
        with open(data, newline="", encoding="utf-8") as f:
            rows = [r for r in csv.reader(f) if r and not r[0].lstrip().startswith("#")]
        if not rows:
            raise InvalidInputError(f"`data`: {os.fspath(data)} has no header", "data")
        header, body = [h.strip() for h in rows[0]], rows[1:]
        return {h: [r[j].strip() if j < len(r) else "" for r in body] for j, h in enumerate(header)}
    if hasattr(data, "to_dict") and hasattr(data, "columns"):
        return {str(k): list(v) for k, v in data.to_dict("list").items()}
    if isinstance(data, Mapping):
        return {str(k): list(np.atleast_1d(np.asarray(v, dtype=object))) for k, v in data.items()}
    raise InvalidTypeError(f"`data` must be a DataFrame, a dict of columns or a CSV path, got "
                           f"{type(data).__name__}", "data")


def read_table(data: Any, strategy: str | None = None, *, outcomes_required: bool = True) -> MeasuredTable:
    """Reads measured runs: SI columns (``t2_s``, ``apex_z_m``, ...) or the thesis's §3.5
    layout (``t2 [s]``, ``z [mm]``, ``x [mm]``, ``phi [deg]``, ``xdot [mm/s]``,
    ``phidot [deg/s]``; ``*`` for a missing entry), units by header or by name
    (``apex_z_mm``). ``strategy``: the strategy of every row when the table has no
    ``strategy`` column (a §3.5 table is one strategy's series). Columns that are leap
    parameters (``m_b``, ``gear_ratio``, ...) are per-row inputs; others are ignored (listed).
    Errors name the column: unknown units, an outcome column with every entry missing, a
    non-number."""
    cols = _columns(data)
    lengths = {len(v) for v in cols.values()}
    if len(lengths) > 1:
        raise InvalidInputError(f"`data`: columns of different lengths {sorted(lengths)}", "data")
    n = lengths.pop() if lengths else 0
    if n == 0:
        raise InvalidInputError("`data` has no rows", "data")
    inputs: dict[str, list[Any]] = {}
    outcomes: dict[str, np.ndarray] = {}
    ignored: list[str] = []
    known = set(_leap.sweepable_names()) | {"gear_ratio"}
    for header, values in cols.items():
        if header.strip().lower() == "strategy":
            inputs["strategy"] = [_leap._strategy(str(v), header) for v in values]
            continue
        if header.strip() in known:  # before the units: `t_final_s` is a parameter, not a time
            inputs[header.strip()] = [_input_value(v) for v in values]
            continue
        unit = _column_unit(header)
        if unit is None:
            ignored.append(header)
            continue
        column, _, factor = unit
        x = _numbers(header, values) * factor
        target = inputs if column == "t2_s" else outcomes
        if column in target:
            raise InvalidInputError(f"column `{header}`: `{column}` is given twice", header)
        if np.all(np.isnan(x)):
            raise InvalidInputError(f"column `{header}`: every entry is missing", header)
        target[column] = list(x) if column == "t2_s" else x
    if "t2_s" not in inputs:
        raise InvalidInputError("`data` has no `t2_s` column (or `t2 [s]`)", "t2_s")
    if any(math.isnan(t) for t in inputs["t2_s"]):
        raise InvalidInputError("column `t2_s`: an input may not be missing", "t2_s")
    if "strategy" not in inputs:
        if strategy is None:
            raise InvalidInputError("`data` has no `strategy` column: give `strategy=`", "strategy")
        inputs["strategy"] = [_leap._strategy(strategy)] * n
    if outcomes_required and not outcomes:
        raise InvalidInputError(f"`data` has no outcome column (any of {', '.join(CHANNELS)})", "data")
    return MeasuredTable(inputs, outcomes, ignored)


# ---------------------------------------------------------------------------------------------
# models


@dataclass
class ModelRun:
    """Outcomes of rows at one parameter point: ``values[i, c]`` (channels of
    :data:`CHANNELS`, NaN without an apex), ``d[i, c, k]`` (d channel / d parameter k, when
    asked; NaN where undefined), ``ok[i]`` (an apex), ``d_ok[i]`` (its derivative defined)."""

    values: np.ndarray
    d: np.ndarray | None
    ok: np.ndarray
    d_ok: np.ndarray
    status: list[str]


def _leg_gearbox_efficiency() -> float:
    """The efficiency of the leap's gearbox (``x-rhex-28``) in the thesis catalog."""
    import tomllib

    from .motor import thesis_catalog_toml

    boxes = tomllib.loads(thesis_catalog_toml())["gearbox"]
    return float(next(g["efficiency"] for g in boxes if g["name"] == "x-rhex-28"))


#: The compliant leg's parameters (``docs/leap-model.md``) and the fields of the
#: ``compliant_leg`` option that hold each (radial, angular).
_SPRING = {"leg_stiffness": ("stiffness_n_per_m", "stiffness_n_m_per_rad"),
           "leg_damping": ("damping_n_s_per_m", "damping_n_m_s_per_rad")}


def _with_spring(leg: Mapping[str, Any] | None, values: Mapping[str, float]) -> dict[str, Any]:
    """The ``compliant_leg`` option with the fitted spring numbers written into the fields it
    uses (radial if it gives a radial stiffness, else angular)."""
    if not leg:
        raise InvalidInputError("leg_stiffness and leg_damping need the compliant_leg option", "compliant_leg")
    out = dict(leg)
    radial = out.get("stiffness_n_per_m") is not None
    for name, (r, a) in _SPRING.items():
        if name in values:
            out[r if radial else a] = float(values[name])
    return out


@dataclass(init=False)
class LeapModel:
    """The RHex leap preset (:func:`selfmanip.leap`) as a model to calibrate: every
    :func:`selfmanip.leap.sweepable_names` number and ``gear_ratio`` is a parameter;
    ``exact`` lists those with exact derivatives (the leap's ``sensitivities``). ``options``:
    fixed leap keywords for every run (``{"mu_rear": 2.0}``). Every run uses
    ``control_free_joints=True``, as the sensitivities do, so that the values of a run with and
    without derivatives are the same."""

    name: ClassVar[str] = "leap"
    exact: ClassVar[tuple[str, ...]] = ("m_b", "I_b", "gear_ratio", "leg_armature_kg_m2",
                                        "gearbox_efficiency", "battery_resistance_ohm",
                                        "mu_front", "mu_middle", "mu_rear", "delta_t_s",
                                        *_SPRING)
    options: dict[str, Any]
    threads: int | None

    def __init__(self, options: Mapping[str, Any] | None = None, threads: int | None = None):
        self.options = dict(options or {})
        self.options.setdefault("control_free_joints", True)
        self.threads = threads

    def parameters(self) -> dict[str, float]:
        """Every numeric parameter and its current value (defaults, with ``options``)."""
        d = _leap.defaults()
        values = {**d["params"], **d["config"], **d["config"]["actuator"], **self.options}
        out = {k: float(v) for k, v in values.items()
               if k in set(_leap.sweepable_names()) | {"gear_ratio"} and isinstance(v, numbers.Real)
               and not isinstance(v, bool)}
        out.setdefault("leg_armature_kg_m2", 0.0)
        # the geared motor's loss options, unset by default: the catalog gearbox's η and an
        # ideal supply
        out.setdefault("gearbox_efficiency", _leg_gearbox_efficiency())
        out.setdefault("battery_resistance_ohm", 0.0)
        leg = self.options.get("compliant_leg")
        if leg:
            # the spring's two numbers in the units the leg gives them (radial or angular)
            for name, fields in _SPRING.items():
                out[name] = float(next((leg[f] for f in fields if leg.get(f) is not None), 0.0))
        return out

    def run(self, inputs: Mapping[str, Sequence[Any]], values: Mapping[str, float],
            derivatives: Sequence[str] | None) -> ModelRun:
        swept = {k: v for k, v in inputs.items() if k not in ("strategy", "t2_s")}
        kw = {**self.options, **{k: v for k, v in values.items() if k != "gear_ratio" and k not in _SPRING}}
        if any(k in _SPRING for k in values):
            kw["compliant_leg"] = _with_spring(kw.get("compliant_leg"), values)
        ratio = values.get("gear_ratio", swept.pop("gear_ratio", _leap.DEFAULT))
        fixed = {k: v for k, v in kw.items() if k not in swept}
        table = _leap.sweep(list(inputs["strategy"]), t2=list(inputs["t2_s"]), gear_ratio=ratio, grid=False,
                            threads=self.threads, sensitivities=list(derivatives) if derivatives else None,
                            config=fixed, **swept)
        n = len(inputs["t2_s"])
        y = np.column_stack([table[c] for c in CHANNELS])
        ok = np.asarray(table["flew"], dtype=bool)
        d = None
        d_ok = np.zeros(n, dtype=bool)
        if derivatives:
            d = np.stack([np.column_stack([table[f"d_{c}/d_{p}"] for p in derivatives]) for c in CHANNELS], axis=1)
            d_ok = ok & table["sensitivity_ok"] & np.all(np.isfinite(d), axis=(1, 2))
        return ModelRun(y, d, ok, d_ok, [str(s) for s in table["status"]])


#: The leap's default parameter set and bounds (``parameters=None``): the body's mass and
#: pitch inertia (Table 4.2: 7.15 kg, 0.15 kg m²; ±30 % and a factor 2 for payload and
#: cabling) and the gear ratio (28, thesis §4.3.3; the X-RHex gearheads' range 20–40), and a
#: constant offset for each measured position channel (a marker is within a few cm of the
#: body's centre: ±0.1 m, ±0.2 rad).
def default_parameters(channels: Sequence[str] = ()) -> dict[str, tuple[float, float]]:
    out = {"m_b": (5.0, 9.5), "I_b": (0.075, 0.3), "gear_ratio": (20.0, 40.0)}
    for c, bound in (("apex_x_m", 0.1), ("apex_z_m", 0.1), ("apex_phi_rad", 0.2)):
        if c in channels:
            out[OFFSET + c] = (-bound, bound)
    return out


# ---------------------------------------------------------------------------------------------
# the least-squares problem


class _Problem:
    """Residuals ``r = (model + offset - measured) / scale`` over the measured entries, and
    their Jacobian: exact from the engine's sensitivities (the offsets' columns are
    ``1/scale``), by central differences of that row only where the engine flags the
    derivative (``flagged="finite_difference"``), or by scipy's forward differences of whole
    runs (``jacobian="finite_difference"``)."""

    def __init__(self, model: Any, table: MeasuredTable, names: list[str], scales: Mapping[str, float],
                 keep: np.ndarray, flagged: str, fd_step: np.ndarray):
        self.model, self.names = model, names
        self.physical = [p for p in names if not p.startswith(OFFSET)]
        self.channels = [c for c in CHANNELS if c in table.outcomes]
        self.inputs = {k: [v[i] for i in np.flatnonzero(keep)] for k, v in table.inputs.items()}
        self.rows = np.flatnonzero(keep)
        self.measured = np.column_stack([table.outcomes[c][keep] for c in self.channels])
        self.mask = np.isfinite(self.measured)
        self.scale = np.asarray([float(scales[c]) for c in self.channels])
        self.flagged, self.fd_step = flagged, fd_step
        self.n_runs = self.n_sens_runs = 0
        self.fd_rows: set[int] = set()
        self.failed_rows: set[int] = set()
        self._cache: tuple[bytes, np.ndarray, np.ndarray | None] | None = None

    def values(self, x: np.ndarray) -> dict[str, float]:
        return {p: float(v) for p, v in zip(self.names, x) if not p.startswith(OFFSET)}

    def offsets(self, x: np.ndarray) -> np.ndarray:
        return np.asarray([x[self.names.index(OFFSET + c)] if OFFSET + c in self.names else 0.0
                           for c in self.channels])

    def _run(self, inputs: Mapping[str, Sequence[Any]], x: np.ndarray, exact: bool) -> ModelRun:
        n = len(inputs["t2_s"])
        self.n_runs += n
        if exact and self.physical:
            self.n_sens_runs += n
        return self.model.run(inputs, self.values(x), self.physical if exact else None)

    def evaluate(self, x: np.ndarray, exact: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """Model outcomes of the kept rows in the measured channels, and (``exact``) their
        derivatives ``[row, channel, physical parameter]``."""
        key = x.tobytes()
        if self._cache is not None and self._cache[0] == key and (self._cache[2] is not None or not exact):
            return self._cache[1], self._cache[2]
        run = self._run(self.inputs, x, exact)
        idx = [CHANNELS.index(c) for c in self.channels]
        y = run.values[:, idx]
        self.failed_rows = {int(self.rows[i]) for i in np.flatnonzero(~run.ok)}
        d = None
        if exact:
            d = (run.d[:, idx, :] if run.d is not None else np.zeros((len(y), len(idx), 0))).copy()
            bad = np.flatnonzero(run.ok & ~run.d_ok)
            if len(bad) and self.physical:
                d[bad] = self._row_differences(bad, x, idx)
            d[~run.ok] = 0.0
        self._cache = (key, y, d)
        return y, d

    def _row_differences(self, bad: np.ndarray, x: np.ndarray, idx: list[int]) -> np.ndarray:
        """Central differences of the flagged rows only (or zeros with ``flagged="drop"``,
        whose rows have been dropped before the fit: this is then never reached)."""
        self.fd_rows |= {int(self.rows[i]) for i in bad}
        sub = {k: [v[i] for i in bad] for k, v in self.inputs.items()}
        out = np.zeros((len(bad), len(idx), len(self.physical)))
        for k, p in enumerate(self.physical):
            j = self.names.index(p)
            h = self.fd_step[j]
            up, down = x.copy(), x.copy()
            up[j] += h
            down[j] -= h
            yu, yd = self._run(sub, up, False).values[:, idx], self._run(sub, down, False).values[:, idx]
            out[:, :, k] = (yu - yd) / (2 * h)
        return np.nan_to_num(out)

    def residuals(self, x: np.ndarray, exact: bool = True) -> np.ndarray:
        y, _ = self.evaluate(x, exact)
        r = (y + self.offsets(x) - self.measured) / self.scale
        # a row whose run has no apex (no flight) at these parameters: a constant penalty of
        # 10 scales per entry, so the trust region steps back; listed in the result
        r = np.where(np.isfinite(y), r, 10.0)
        return r[self.mask]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        _, d = self.evaluate(x, True)
        m, c = self.measured.shape
        J = np.zeros((m, c, len(self.names)))
        for j, p in enumerate(self.names):
            if p.startswith(OFFSET):
                J[:, self.channels.index(p[len(OFFSET):]), j] = 1.0
            else:
                J[:, :, j] = d[:, :, self.physical.index(p)]
        J /= self.scale[None, :, None]
        return J[self.mask]


# ---------------------------------------------------------------------------------------------
# the result


#: A direction of the parameters (each scaled by its bound's width) whose singular value is
#: below this fraction of the largest is undetermined by the data.
UNDETERMINED_RTOL = 1e-6


@dataclass
class Identifiability:
    """Singular values of the scaled residual Jacobian (parameters scaled by their bounds'
    widths), the right singular vectors (rows, unit length, over ``names``) and those of them
    the data do not determine (``singular value < UNDETERMINED_RTOL x largest``)."""

    names: list[str]
    singular_values: np.ndarray
    directions: np.ndarray
    undetermined: list[dict[str, float]]

    def describe(self) -> str:
        lines = ["singular values (parameters scaled by their bounds): "
                 + ", ".join(f"{s:.3g}" for s in self.singular_values)]
        if not self.undetermined:
            lines.append("every parameter is determined by the data")
        for v in self.undetermined:
            terms = " + ".join(f"{w:+.3f}·{k}" for k, w in v.items())
            lines.append(f"undetermined combination: {terms} (scaled by bounds)")
        return "\n".join(lines)


@dataclass
class Calibration:
    """What :func:`calibrate` found. ``params``, ``stderr`` (inf for a parameter in an
    undetermined combination), ``covariance`` (over ``names``), ``intervals`` (95 %: Student t
    with ``dof`` degrees of freedom, normal with ``absolute_sigma``), ``residuals`` (a
    DataFrame-ready dict: inputs, measured, fitted and measured − fitted per channel, in SI),
    ``identifiability``, ``n_model_runs`` (leaps run, of which ``n_sensitivity_runs`` with
    exact derivatives), ``fd_rows`` (rows whose derivative the engine flagged and that were
    differenced), ``dropped_rows`` (rows left out, with why), ``starts`` (each start's cost),
    ``elapsed_s``."""

    model: Any
    names: list[str]
    params: dict[str, float]
    stderr: dict[str, float]
    covariance: np.ndarray
    intervals: dict[str, tuple[float, float]]
    bounds: dict[str, tuple[float, float]]
    residuals: dict[str, np.ndarray]
    identifiability: Identifiability
    cost: float
    dof: int
    sigma2: float
    n_model_runs: int
    n_sensitivity_runs: int
    fd_rows: list[int]
    dropped_rows: dict[int, str]
    starts: list[dict[str, Any]]
    jacobian: str
    elapsed_s: float
    channels: list[str]
    scales: dict[str, float]

    def report(self) -> str:
        """The fit in words: parameters with standard errors and intervals, residuals per
        channel, identifiability, what was done with flagged or failing rows, and the cost."""
        lines = [f"calibration of `{getattr(self.model, 'name', self.model)}`: {len(self.residuals['t2_s'])} rows, "
                 f"channels {', '.join(self.channels)}; jacobian {self.jacobian}"]
        lines.append(f"{'parameter':<24}{'value':>12}{'stderr':>12}   95 % interval          bounds")
        for p in self.names:
            lo, hi = self.intervals[p]
            b = self.bounds[p]
            at = "  (at a bound)" if np.isclose(self.params[p], b, rtol=1e-6, atol=1e-12).any() else ""
            lines.append(f"{p:<24}{self.params[p]:>12.6g}{self.stderr[p]:>12.3g}   [{lo:.6g}, {hi:.6g}]"
                         f"   [{b[0]:g}, {b[1]:g}]{at}")
        for c in self.channels:
            r = self.residuals[f"{c}_residual"]
            rms = math.sqrt(np.nanmean(r ** 2)) if np.isfinite(r).any() else math.nan
            lines.append(f"rms residual {c}: {rms:.4g} (scale {self.scales[c]:.3g})")
        lines.append(self.identifiability.describe())
        if self.fd_rows:
            lines.append(f"rows {self.fd_rows}: the engine flagged their derivative (a change of the mode "
                         "sequence or a simultaneous event); their Jacobian rows are central differences")
        for i, why in self.dropped_rows.items():
            lines.append(f"row {i} dropped: {why}")
        lines.append(f"cost {self.cost:.6g}, residual variance factor {self.sigma2:.4g} ({self.dof} dof); "
                     f"{len(self.starts)} start(s), best cost {min(s['cost'] for s in self.starts):.6g}")
        lines.append(f"model runs {self.n_model_runs} (with exact derivatives {self.n_sensitivity_runs}), "
                     f"{self.elapsed_s:.2f} s")
        return "\n".join(lines)

    def plot(self, path: str | os.PathLike[str], predictions: Mapping[str, Any] | None = None) -> str:
        """Measured against fitted, and predicted, per strategy over ``t2`` (as chapter 3's
        figures): a panel per measured channel (SI units); measured points, the fitted model
        (with the offsets) as a line through the fitted rows, and ``predictions`` (a
        :meth:`predict` result) as dashed lines with a band of two standard deviations.
        Writes ``path`` (PNG, or the format its suffix names) and returns it."""
        from .plots import _pyplot, save_figure

        plt = _pyplot()
        fig, axes = plt.subplots(len(self.channels), 1, figsize=(7.0, 2.2 * len(self.channels)), sharex=True,
                                 squeeze=False)
        res = self.residuals
        strategies = list(dict.fromkeys(list(res["strategy"]) + list((predictions or {}).get("strategy", []))))
        colours = {s: f"C{k}" for k, s in enumerate(strategies)}
        for ax, c in zip(axes[:, 0], self.channels):
            for s in dict.fromkeys(res["strategy"]):
                sel = np.asarray(res["strategy"]) == s
                t2 = np.asarray(res["t2_s"], dtype=float)[sel]
                order = np.argsort(t2)
                ax.plot(t2[order], res[f"{c}_measured"][sel][order], "o", color=colours[s], label=f"{s} measured")
                ax.plot(t2[order], res[f"{c}_fitted"][sel][order], "-", color=colours[s], label=f"{s} fitted")
            for s in dict.fromkeys((predictions or {}).get("strategy", [])):
                sel = np.asarray(predictions["strategy"]) == s
                t2 = np.asarray(predictions["t2_s"], dtype=float)[sel]
                order = np.argsort(t2)
                y, sd = np.asarray(predictions[c])[sel][order], np.asarray(predictions[f"{c}_std"])[sel][order]
                ax.plot(t2[order], y, "--", color=colours[s], label=f"{s} predicted")
                ax.fill_between(t2[order], y - 2 * sd, y + 2 * sd, color=colours[s], alpha=0.15)
            ax.set_ylabel(c)
        axes[-1, 0].set_xlabel("t2_s")
        axes[0, 0].legend(fontsize="x-small", ncol=3)
        fig.suptitle(f"calibration of `{getattr(self.model, 'name', self.model)}`: "
                     + ", ".join(f"{p} = {self.params[p]:.4g}" for p in self.names), fontsize="small")
        fig.tight_layout()
        try:
            save_figure(fig, path)
        finally:
            plt.close(fig)
        return os.fspath(path)

    def predict(self, inputs: Any, strategy: str | None = None) -> dict[str, np.ndarray]:
        """Runs the fitted model (with its measurement offsets) at ``inputs`` (a table with
        ``strategy`` and ``t2_s``, as :func:`read_table` reads it; outcome columns are
        ignored) and returns a DataFrame-ready dict: the inputs, each outcome channel and its
        standard deviation ``<channel>_std`` from the parameters' covariance (delta method:
        ``sqrt(g Σ gᵀ)`` with ``g`` the exact derivative of the prediction; inf where ``g`` has
        a component along an undetermined combination), and ``flew`` (the model reached an apex)."""
        table = read_table(inputs, strategy, outcomes_required=False)
        table.outcomes = {c: np.zeros(len(table)) for c in CHANNELS}
        prob = _Problem(self.model, table, list(self.names), {c: 1.0 for c in CHANNELS},
                        np.ones(len(table), dtype=bool), "finite_difference", _fd_steps(self.names, self.bounds,
                                                                                           self.params))
        x = np.asarray([self.params[p] for p in self.names])
        y, d = prob.evaluate(x, True)
        G = prob.jacobian(x).reshape(len(table), len(CHANNELS), len(self.names))
        out: dict[str, Any] = {k: np.asarray(v) for k, v in table.inputs.items()}
        null = np.asarray([[v.get(p, 0.0) for p in self.names] for v in self.identifiability.undetermined])
        widths = np.asarray([_width(self.bounds[p], self.params[p]) for p in self.names])
        for c, col in enumerate(CHANNELS):
            g = G[:, c, :]
            var = np.einsum("ij,jk,ik->i", g, np.nan_to_num(self.covariance), g)
            std = np.sqrt(np.maximum(var, 0.0))
            if len(null):
                along = np.abs((g * widths) @ null.T).max(axis=1)
                std = np.where(along > 1e-9 * (np.abs(g * widths).max(axis=1) + 1e-300), math.inf, std)
            out[col] = y[:, c] + prob.offsets(x)[c]
            out[f"{col}_std"] = np.where(np.isfinite(y[:, c]), std, math.nan)
        out["flew"] = np.isfinite(y[:, 0])
        return out


# ---------------------------------------------------------------------------------------------
# calibrate


def _width(bound: tuple[float, float], value: float) -> float:
    """A parameter's scale: its bounds' width, or its size where a bound is infinite."""
    lo, hi = bound
    return hi - lo if math.isfinite(hi - lo) else max(abs(value), 1.0)


def _fd_steps(names: Sequence[str], bounds: Mapping[str, tuple[float, float]],
              values: Mapping[str, float]) -> np.ndarray:
    """Central-difference steps: 1e-4 of each parameter's scale (well above the leap's
    integration tolerances, rtol 1e-8, and small against its curvature)."""
    return np.asarray([1e-4 * _width(bounds[p], values[p]) for p in names])


def _check_parameters(model: Any, parameters: Mapping[str, Any], channels: Sequence[str],
                      jacobian: str) -> dict[str, tuple[float, float]]:
    known = model.parameters()
    out: dict[str, tuple[float, float]] = {}
    for name, bound in parameters.items():
        if not isinstance(name, str):
            raise InvalidTypeError(f"`parameters`: names are strings, got {name!r}", "parameters")
        if name.startswith(OFFSET):
            c = name[len(OFFSET):]
            if c not in CHANNELS:
                raise InvalidInputError(f"`{name}`: no such channel (known: {', '.join(CHANNELS)})", name)
            if c not in channels:
                raise InvalidInputError(f"`{name}`: the data do not measure `{c}`", name)
        elif name not in known:
            raise InvalidInputError(f"`{name}`: the model `{model.name}` has no such numeric parameter "
                                    f"(known: {', '.join(sorted(known))})", name)
        elif jacobian == "exact" and name not in model.exact:
            raise InvalidInputError(f"`{name}`: no exact derivative in `{model.name}` (exact: "
                                    f"{', '.join(model.exact)}); fit it with jacobian='finite_difference'", name)
        if (not isinstance(bound, (tuple, list)) or len(bound) != 2
                or not all(isinstance(b, numbers.Real) and not isinstance(b, bool) for b in bound)):
            raise InvalidTypeError(f"`{name}`: bounds must be a pair (lo, hi) of numbers, got {bound!r}", name)
        lo, hi = float(bound[0]), float(bound[1])
        if math.isnan(lo) or math.isnan(hi) or not lo < hi:
            raise InvalidInputError(f"`{name}`: bounds ({lo}, {hi}) are not increasing", name)
        out[name] = (lo, hi)
    if not out:
        raise InvalidInputError("`parameters` is empty: name at least one to fit", "parameters")
    return out


def _covariance(J: np.ndarray, r: np.ndarray, names: list[str], widths: np.ndarray,
                absolute_sigma: bool) -> tuple[np.ndarray, float, int, Identifiability]:
    """``Σ = σ² (JᵀJ)⁺`` over the determined directions (``σ² = |r|²/(m − rank)`` unless the
    scales are the noise's standard deviations, ``absolute_sigma``), and the identifiability
    report of the width-scaled Jacobian ``J diag(widths)``."""
    Js = J * widths[None, :]
    _, s, Vt = np.linalg.svd(Js, full_matrices=False)
    s_full = np.zeros(len(names))
    s_full[:len(s)] = s
    if len(s) < len(names):  # fewer residuals than parameters: the rest are null directions
        Vt = np.linalg.svd(np.vstack([Js, np.zeros((len(names) - len(s), len(names)))]))[2]
    smax = s_full.max() if s_full.size else 0.0
    determined = s_full > UNDETERMINED_RTOL * smax if smax > 0 else np.zeros(len(names), dtype=bool)
    rank = int(determined.sum())
    dof = max(len(r) - rank, 0)
    sigma2 = 1.0 if absolute_sigma else (float(r @ r) / dof if dof > 0 else math.inf)
    inv = np.zeros((len(names), len(names)))
    for i in np.flatnonzero(determined):
        inv += np.outer(Vt[i], Vt[i]) / s_full[i] ** 2
    with np.errstate(invalid="ignore"):  # no degree of freedom left: sigma2 = inf, 0·inf = NaN
        cov = sigma2 * inv * np.outer(widths, widths)
    undetermined = []
    for i in np.flatnonzero(~determined):
        v = Vt[i] / np.abs(Vt[i]).max()
        undetermined.append({p: float(w) for p, w in zip(names, v) if abs(w) > 1e-3})
    involved = {p for v in undetermined for p in v}
    for k, p in enumerate(names):
        if p in involved:
            cov[k, :] = cov[:, k] = math.nan
    return cov, sigma2, dof, Identifiability(names, s_full, Vt, undetermined)


def _quantile_975(dof: int, absolute_sigma: bool) -> float:
    """The two-sided 95 % point of ``(θ̂ − θ)/σ_θ``: the normal's (1.96) where the scales are
    the noise's standard deviations (``absolute_sigma``: σ is known), Student t's with
    ``dof = m − rank`` degrees of freedom where σ² is estimated from the residuals (inf with
    none left)."""
    from scipy.stats import norm, t as student_t

    if absolute_sigma:
        return float(norm.ppf(0.975))
    return float(student_t.ppf(0.975, dof)) if dof > 0 else math.inf


def _starts(x0: np.ndarray, lo: np.ndarray, hi: np.ndarray, n: int, seed: int) -> list[np.ndarray]:
    """The first start is ``x0``; the others uniform in the bounds (finite) or within a
    factor around ``x0``, from ``numpy.random.default_rng(seed)``: deterministic."""
    rng = np.random.default_rng(seed)
    out = [x0]
    for _ in range(n - 1):
        u = rng.uniform(size=len(x0))
        finite = np.isfinite(lo) & np.isfinite(hi)
        out.append(np.where(finite, lo + u * (np.where(finite, hi - lo, 0.0)),
                            x0 + (2 * u - 1) * np.maximum(np.abs(x0), 1.0)))
    return out


def _resolve_model(model: Any, options: Mapping[str, Any] | None, threads: int | None) -> Any:
    if isinstance(model, str):
        if model != "leap":
            raise InvalidInputError(f"`model`: unknown preset {model!r} (known: 'leap'; or pass an object "
                                    "with `parameters()`, `exact` and `run()`, as LeapModel)", "model")
        return LeapModel(options, threads)
    if not all(hasattr(model, a) for a in ("parameters", "exact", "run")):
        raise InvalidTypeError("`model` must be 'leap' or an object with `parameters()`, `exact` and `run()`",
                               "model")
    return model


def calibrate(model: Any, data: Any, parameters: Mapping[str, tuple[float, float]] | None = None, *,
              strategy: str | None = None, initial: Mapping[str, float] | None = None,
              scales: Mapping[str, float] | None = None, loss: str = "linear", f_scale: float = 1.0,
              starts: int = 1, seed: int = 0, jacobian: str = "exact", flagged: str = "finite_difference",
              absolute_sigma: bool = False, options: Mapping[str, Any] | None = None,
              threads: int | None = None, max_nfev: int | None = None) -> Calibration:
    """Fits ``parameters`` (``{name: (lo, hi)}``; ``None``: :func:`default_parameters`) of
    ``model`` (``"leap"`` or a :class:`LeapModel`-like object) to the measured table ``data``
    (see :func:`read_table`; ``strategy`` for a table without that column).

    Residuals are ``(model + offset − measured) / scale`` per measured entry, ``scales`` per
    channel (default :data:`DEFAULT_CHANNEL_SCALES`); ``"offset:<channel>"`` parameters are
    the measurement model's constant offsets. ``scipy.optimize.least_squares`` (trust-region
    reflective, bounds, ``loss``/``f_scale`` as there) from ``starts`` deterministic starts
    (the first ``initial``, default the model's values clipped into the bounds and offsets 0);
    the lowest cost wins. ``jacobian="exact"``: the engine's derivatives through the events;
    ``"finite_difference"``: scipy's forward differences of whole runs (relative step 1e-4),
    for comparison or for parameters without exact derivatives. Rows whose derivative the
    engine flags (a change of the mode sequence, simultaneous events): ``flagged=
    "finite_difference"`` differences those rows only (central, step 1e-4 of the bounds'
    width) and lists them; ``"drop"`` leaves them out of the fit and lists them. Rows whose
    model has no apex at the first start are dropped and listed. ``absolute_sigma``: the
    scales are the noise's standard deviations and the intervals use the normal quantile (else
    the covariance is scaled by the residual variance factor, as ``scipy.optimize.curve_fit``
    does, and the intervals use Student t's with ``m − rank`` degrees of freedom).
    ``options``: fixed model keywords.
    """
    from scipy.optimize import least_squares

    started = time.perf_counter()
    if jacobian not in ("exact", "finite_difference"):
        raise InvalidInputError(f"`jacobian` must be 'exact' or 'finite_difference', got {jacobian!r}", "jacobian")
    if flagged not in ("finite_difference", "drop"):
        raise InvalidInputError(f"`flagged` must be 'finite_difference' or 'drop', got {flagged!r}", "flagged")
    if isinstance(starts, bool) or not isinstance(starts, numbers.Integral) or starts < 1:
        raise InvalidInputError(f"`starts` must be a positive integer, got {starts!r}", "starts")
    m = _resolve_model(model, options, threads)
    table = read_table(data, strategy)
    channels = [c for c in CHANNELS if c in table.outcomes]
    bounds = _check_parameters(m, default_parameters(channels) if parameters is None else parameters,
                               channels, jacobian)
    names = list(bounds)
    sc = {**DEFAULT_CHANNEL_SCALES, **dict(scales or {})}
    for c in channels:
        if not (isinstance(sc[c], numbers.Real) and sc[c] > 0):
            raise InvalidInputError(f"`scales`: `{c}` must be a positive number, got {sc[c]!r}", c)
    for p in names:
        if p in table.inputs:
            raise InvalidInputError(f"`{p}` is both a column of the data and a parameter to fit", p)
    known = m.parameters()
    start_values = {p: 0.0 if p.startswith(OFFSET) else known[p] for p in names}
    for k, v in dict(initial or {}).items():
        if k not in bounds:
            raise InvalidInputError(f"`initial`: `{k}` is not a parameter being fitted", k)
        start_values[k] = float(v)
    lo = np.asarray([bounds[p][0] for p in names])
    hi = np.asarray([bounds[p][1] for p in names])
    x0 = np.clip(np.asarray([start_values[p] for p in names], dtype=float), lo, hi)
    widths = np.asarray([_width(bounds[p], start_values[p]) for p in names])
    keep, dropped, screening = _keep_rows(m, table, names, x0, jacobian, flagged)
    prob = _Problem(m, table, names, sc, keep, flagged, _fd_steps(names, bounds, dict(zip(names, x0))))
    prob.n_runs, prob.n_sens_runs = screening  # the screening run counts too
    exact = jacobian == "exact"
    runs = []
    for x_start in _starts(x0, lo, hi, starts, seed):
        kw: dict[str, Any] = dict(jac=prob.jacobian) if exact else dict(jac="2-point", diff_step=1e-4)
        res = least_squares(lambda x: prob.residuals(x, exact), x_start, bounds=(lo, hi), method="trf",
                            loss=loss, f_scale=f_scale, x_scale=widths, max_nfev=max_nfev, **kw)
        runs.append(res)
    best = min(runs, key=lambda r: r.cost)
    cov, sigma2, dof, ident = _covariance(best.jac, best.fun, names, widths, absolute_sigma)
    q = _quantile_975(dof, absolute_sigma)
    stderr = {p: (math.sqrt(cov[k, k]) if np.isfinite(cov[k, k]) else math.inf) for k, p in enumerate(names)}
    params = {p: float(v) for p, v in zip(names, best.x)}
    prob.residuals(best.x, exact)  # the failing rows at the solution
    for i in sorted(prob.failed_rows):
        dropped.setdefault(i, "the fitted model has no apex for it (penalised at 10 scales per entry)")
    return Calibration(
        model=m, names=names, params=params, stderr=stderr, covariance=cov,
        intervals={p: (params[p] - q * stderr[p], params[p] + q * stderr[p]) for p in names},
        bounds=bounds, residuals=_residual_table(prob, table, best.x), identifiability=ident,
        cost=float(best.cost), dof=dof, sigma2=sigma2, n_model_runs=prob.n_runs,
        n_sensitivity_runs=prob.n_sens_runs, fd_rows=sorted(prob.fd_rows), dropped_rows=dropped,
        starts=[{"x0": dict(zip(names, map(float, s))), "cost": float(r.cost), "nfev": int(r.nfev),
                 "status": int(r.status)} for s, r in zip(_starts(x0, lo, hi, starts, seed), runs)],
        jacobian=jacobian, elapsed_s=time.perf_counter() - started, channels=channels, scales=sc)


def _keep_rows(model: Any, table: MeasuredTable, names: list[str], x0: np.ndarray, jacobian: str,
               flagged: str) -> tuple[np.ndarray, dict[int, str], tuple[int, int]]:
    """Rows to fit: those with an apex at the first start and at least one measured entry;
    with ``flagged="drop"`` also those whose derivative the engine flags there; the rows left
    out with why, and the runs made (all, with derivatives)."""
    physical = [p for p in names if not p.startswith(OFFSET)]
    ask = physical if (jacobian == "exact" and flagged == "drop" and physical) else None
    run = model.run(table.inputs, {p: float(v) for p, v in zip(names, x0) if not p.startswith(OFFSET)}, ask)
    measured = np.column_stack(list(table.outcomes.values()))
    keep = run.ok & np.isfinite(measured).any(axis=1)
    dropped = {int(i): f"no apex at the first start ({run.status[i]})" for i in np.flatnonzero(~run.ok)}
    dropped.update({int(i): "no measured entry" for i in np.flatnonzero(~np.isfinite(measured).any(axis=1))})
    if ask:
        for i in np.flatnonzero(run.ok & ~run.d_ok):
            dropped[int(i)] = "the engine flags its derivative (a change of mode sequence): dropped"
        keep &= run.d_ok
    if not keep.any():
        raise InvalidInputError("`data`: no row is left to fit (see the rows' model status: "
                                + ", ".join(sorted(set(run.status))) + ")", "data")
    return keep, dropped, (len(table), len(table) if ask else 0)


def _residual_table(prob: _Problem, table: MeasuredTable, x: np.ndarray) -> dict[str, np.ndarray]:
    """Every row of the table (NaN for dropped rows): inputs, measured, fitted (with the
    offsets) and measured − fitted per channel."""
    n = len(table)
    out: dict[str, np.ndarray] = {k: np.asarray(v) for k, v in table.inputs.items()}
    y, _ = prob.evaluate(x, False)
    fitted = np.full((n, len(prob.channels)), math.nan)
    fitted[prob.rows] = y + prob.offsets(x)
    for c, col in enumerate(prob.channels):
        out[f"{col}_measured"] = table.outcomes[col]
        out[f"{col}_fitted"] = fitted[:, c]
        out[f"{col}_residual"] = table.outcomes[col] - fitted[:, c]
    return out
