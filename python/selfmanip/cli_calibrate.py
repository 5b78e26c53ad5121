"""``selfmanip calibrate DATA.csv --preset leap --fit NAME=LO:HI … --out DIR``: fits a
preset's named parameters (and the measurement model's offsets, ``offset:<channel>``) to a
table of measured runs with :func:`selfmanip.calibrate` and writes the fit as tables and a
report (``docs/calibration.md``)."""

from __future__ import annotations

import argparse
import os
from typing import Any

import numpy as np

from ._checks import path_arg
from ._tables import write_atomically, write_table
from .errors import InvalidInputError

#: The files ``selfmanip calibrate`` writes into ``--out``.
OUTPUT_FILES = ("params.csv", "covariance.csv", "residuals.csv", "predictions.csv", "report.txt")


def parse_fit(text: str) -> tuple[str, tuple[float, float]]:
    """``NAME=LO:HI`` -> ``(NAME, (LO, HI))``; the name may hold a colon
    (``offset:apex_z_m=-0.05:0.05``). A malformed entry is an error naming ``--fit NAME``."""
    name, sep, bounds = text.rpartition("=")
    name = name.strip()
    if not sep or not name:
        raise InvalidInputError(f"`--fit {text}`: expected NAME=LO:HI, e.g. m_b=5:9.5", "--fit")
    parts = bounds.split(":")
    field = f"--fit {name}"
    if len(parts) != 2:
        raise InvalidInputError(f"`{field}`: bounds {bounds!r} are not LO:HI", field)
    try:
        lo, hi = (float(p) for p in parts)
    except ValueError:
        raise InvalidInputError(f"`{field}`: bounds {bounds!r} are not two numbers LO:HI", field) from None
    return name, (lo, hi)


def parse_set(text: str) -> tuple[str, Any]:
    """``NAME=VALUE`` (a number where it reads as one) for a fixed model option."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise InvalidInputError(f"`--set {text}`: expected NAME=VALUE", "--set")
    try:
        return name.strip(), float(value)
    except ValueError:
        return name.strip(), value.strip()


def _fit_arguments(items: list[str] | None) -> dict[str, tuple[float, float]] | None:
    if not items:
        return None
    out: dict[str, tuple[float, float]] = {}
    for item in items:
        name, bounds = parse_fit(item)
        if name in out:
            raise InvalidInputError(f"`--fit {name}` is given twice", f"--fit {name}")
        out[name] = bounds
    return out


def params_table(fit) -> dict[str, np.ndarray]:
    """One row per fitted parameter: value, standard error, 95 % interval, bounds and whether
    the data determine it (``False``: part of an undetermined combination)."""
    undetermined = {p for v in fit.identifiability.undetermined for p in v}
    return {
        "name": np.asarray(fit.names),
        "value": np.asarray([fit.params[p] for p in fit.names]),
        "stderr": np.asarray([fit.stderr[p] for p in fit.names]),
        "ci95_lo": np.asarray([fit.intervals[p][0] for p in fit.names]),
        "ci95_hi": np.asarray([fit.intervals[p][1] for p in fit.names]),
        "lower_bound": np.asarray([fit.bounds[p][0] for p in fit.names]),
        "upper_bound": np.asarray([fit.bounds[p][1] for p in fit.names]),
        "determined": np.asarray([p not in undetermined for p in fit.names]),
    }


def covariance_table(fit) -> dict[str, np.ndarray]:
    """The covariance over ``fit.names``, a row per parameter (NaN rows: undetermined)."""
    out: dict[str, np.ndarray] = {"name": np.asarray(fit.names)}
    for k, p in enumerate(fit.names):
        out[p] = np.asarray(fit.covariance[:, k])
    return out


def default_prediction_inputs(fit) -> dict[str, list[Any]]:
    """Every strategy at each distinct ``t2`` of the fitted data: the runs of the other
    strategies are those not tried."""
    from .leap import STRATEGIES

    t2 = sorted({float(t) for t in fit.residuals["t2_s"]})
    return {"strategy": [s for s in STRATEGIES for _ in t2], "t2_s": [t for _ in STRATEGIES for t in t2]}


def calibrate_command(args: argparse.Namespace) -> int:
    from .calibrate import calibrate

    if args.threads is not None and args.threads < 1:
        raise InvalidInputError(f"`--threads` must be >= 1, got {args.threads}", "--threads")
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise InvalidInputError(f"`--out`: {args.out!r} is a file, not a directory", "--out")
    options = dict(parse_set(s) for s in args.set or [])
    fit = calibrate(args.preset, args.data, _fit_arguments(args.fit), strategy=args.strategy, loss=args.loss,
                    f_scale=args.f_scale, starts=args.starts, seed=args.seed, jacobian=args.jacobian,
                    flagged=args.flagged, absolute_sigma=args.absolute_sigma, options=options or None,
                    threads=args.threads)
    inputs = args.predict if args.predict else default_prediction_inputs(fit)
    predictions = fit.predict(inputs, strategy=args.strategy if args.predict else None)
    os.makedirs(args.out, exist_ok=True)
    report = fit.report()
    write_table(params_table(fit), os.path.join(args.out, "params.csv"))
    write_table(covariance_table(fit), os.path.join(args.out, "covariance.csv"))
    write_table(fit.residuals, os.path.join(args.out, "residuals.csv"))
    write_table(predictions, os.path.join(args.out, "predictions.csv"))

    def emit(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(report + "\n")

    write_atomically(os.path.join(args.out, "report.txt"), emit)
    written = list(OUTPUT_FILES)
    if args.plot:
        fit.plot(os.path.join(args.out, "fit.png"), predictions)
        written.append("fit.png")
    print(report)
    print(f"wrote {', '.join(written)} to {args.out}")
    return 0


def add_subcommands(sub: "argparse._SubParsersAction") -> None:
    ca = sub.add_parser("calibrate", help="fit a preset's parameters to measured runs (a table) with exact "
                        "Jacobians; writes params, covariance, residuals, predictions and a report")
    ca.add_argument("data", help="measured runs: CSV with SI columns (t2_s, apex_z_m, ...) or the thesis's "
                    "§3.5 layout (t2 [s], z [mm], x [mm], phi [deg], xdot [mm/s], phidot [deg/s]; * missing)")
    ca.add_argument("--preset", default="leap", choices=["leap"], help="the model (default: leap)")
    ca.add_argument("--fit", action="append", metavar="NAME=LO:HI",
                    help="a parameter to fit and its bounds (repeatable), e.g. m_b=5:9.5, "
                         "offset:apex_z_m=-0.1:0.1 (default: the preset's documented set)")
    ca.add_argument("--strategy", default=None, help="the strategy of every row when DATA has no strategy column")
    ca.add_argument("--set", action="append", metavar="NAME=VALUE", help="a fixed model parameter (repeatable)")
    ca.add_argument("--loss", default="linear", choices=["linear", "soft_l1", "huber", "cauchy", "arctan"],
                    help="robust loss (scipy.optimize.least_squares)")
    ca.add_argument("--f-scale", type=float, default=1.0, help="the robust loss's soft margin, in channel scales")
    ca.add_argument("--starts", type=int, default=1, help="multi-start: number of starts (default 1)")
    ca.add_argument("--seed", type=int, default=0, help="seed of the extra starts")
    ca.add_argument("--jacobian", default="exact", choices=["exact", "finite_difference"])
    ca.add_argument("--flagged", default="finite_difference", choices=["finite_difference", "drop"],
                    help="rows whose derivative the engine flags: difference them, or drop them")
    ca.add_argument("--absolute-sigma", action="store_true",
                    help="the channel scales are the noise's standard deviations")
    ca.add_argument("--predict", default=None, help="a table of inputs (strategy, t2) to predict "
                    "(default: every strategy at the data's t2 values)")
    ca.add_argument("--plot", action="store_true", help="also draw fit.png: measured, fitted and predicted "
                    "over t2 per strategy (needs matplotlib)")
    ca.add_argument("--threads", type=int, default=None, help="worker threads (default: all cores)")
    ca.add_argument("--out", required=True, type=path_arg, help="directory for the tables and report.txt")
    ca.set_defaults(calibrate_handler=calibrate_command)
