"""``selfmanip analysis``: the data behind the section-4.3 figures (CSV) and a JSON summary of
Results B.1, C.4, C.5 (``selfmanip analysis results``). Plots: ``selfmanip plot fig4.8 --out f.png``."""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from ._checks import path_arg
from ._tables import write_atomically
from . import analysis
from .figures import FIGURE_NAMES, figure_data


def add_subcommands(subparsers) -> None:
    """Registers ``analysis`` on the ``selfmanip`` subparsers."""
    an = subparsers.add_parser("analysis", help="data behind Figs. 4.3/4.6/4.8/4.10-4.12 (CSV) or a results summary (JSON)")
    an.add_argument("what", choices=FIGURE_NAMES + ("results",), help="a figure name, or `results`")
    an.add_argument("--n", type=int, default=None, help="grid size (figures that have one)")
    an.add_argument("--out", default=None, type=path_arg, help="output file (default: stdout)")
    an.set_defaults(analysis_handler=run)


def _csv(d: dict) -> str:
    cols = {k: np.asarray(v) for k, v in d.items()}
    # 2-D figures: flatten every array of the grid's shape, broadcast the axes
    shapes = [v.shape for v in cols.values() if v.ndim == 2]
    if shapes:
        shape = shapes[0]
        axes = [k for k, v in cols.items() if v.ndim == 1]
        out = {}
        if len(axes) >= 2 and (len(cols[axes[0]]), len(cols[axes[1]])) == shape:
            a, b = np.meshgrid(cols[axes[0]], cols[axes[1]], indexing="ij")
            out[axes[0]], out[axes[1]] = a.ravel(), b.ravel()
        for k, v in cols.items():
            if v.ndim == 2 and v.shape == shape:
                out[k] = v.ravel()
        cols = out
    keys = list(cols)
    lines = [",".join(keys)]
    for i in range(len(cols[keys[0]])):
        lines.append(",".join(str(cols[k][i]) for k in keys))
    return "\n".join(lines) + "\n"


def results_summary() -> dict:
    r = analysis.sensor_pitch_range()
    g, v = analysis.optimal_gear_ratio()
    return {
        "B1_max_sensor_pitch_deg": math.degrees(r["max_phi"]),
        "B1_min_sensor_pitch_deg": math.degrees(r["min_phi"]),
        "B1_rolling_only_max_deg": math.degrees(r["rolling_max_phi"]),
        "C4_midstance_stick_m_s": abs(analysis.takeoff_speed(0.0, 0.0, leg="stick")["xdot"]),
        "C4_midstance_rolling_m_s": abs(analysis.takeoff_speed(0.0, 0.0, leg="rolling")["xdot"]),
        "fig4_11_optimal_gear_ratio_phi0": g,
        "fig4_11_best_speed_m_s": v,
        "C5_leg_effectiveness_3_pairs": analysis.leg_effectiveness(),
        "C5_deg_per_revolution": 360.0 * analysis.leg_effectiveness(),
        "model": "Table 4.2 (X-RHex motor, two motors per planar leg)",
    }


def run(args: argparse.Namespace) -> int:
    if args.what == "results":
        text = json.dumps(results_summary(), indent=2) + "\n"
    else:
        text = _csv(figure_data(args.what, args.n))
    if args.out:
        def emit(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8") as f:
                f.write(text)

        write_atomically(args.out, emit)
    else:
        sys.stdout.write(text)
    return 0
