"""Which gear ratio? The takeoff-speed analysis (thesis section 4.3.3, Fig. 4.11) against leap
sweeps over the X-RHex gear ratio G (two motors per planar leg, 20 A current limit) at several
coordination times t2, for each strategy, each objective named: apex height, and the take-off
speed |x_dot| (the forward speed at the apex of flight, unchanged in flight; a magnitude, so a
backward leap's fastest G is found too, not the grid's edge). Why the two routes differ:
``docs/gear-ratio.md``.

    python3 python/examples/gear_ratio_sweep.py [--out-dir .] [--gears 8:60:53] [--t2 -0.1,0,0.1]

Writes ``gear_ratio_sweep.csv`` / ``.png``; prints the analysis's optimum, then per strategy and
t2 the best G for each objective with the range of G within 2 % of the best, and the
work-optimal ratio of the best leap's own stance (``stance_work_optimal_ratio``). Exits 1 with
a message when no point of the sweep reaches an apex. The CLI equivalent of the sweep:
``selfmanip sweep --strategy ++,+-,-+,-- --t2=-0.1:0.15:6 --gear-ratio 8:60:53``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tomllib
import warnings
from typing import Any, Mapping

import numpy as np

import selfmanip
from selfmanip import analysis
from selfmanip.cli_leap import write_table
from selfmanip.leap import failure_summary
from selfmanip.motor import thesis_catalog_toml
from selfmanip.plots import sweep_figure

STRATEGIES = ("++", "+-", "-+", "--")
DEFAULT_T2 = (-0.1, -0.05, 0.0, 0.05, 0.1, 0.15)

#: What "best" means: the column and the map applied to it. ``takeoff_speed`` is the magnitude
#: |x_dot| (Fig. 4.11's quantity): the signed speed would make the lowest speed of a backward
#: leap the "best".
OBJECTIVES = {
    "apex_height": ("apex_z_m", lambda v: v),
    "takeoff_speed": ("apex_xdot_m_s", np.abs),
}


def no_load_speed_rad_s() -> float:
    """The X-RHex motor's no-load speed at 37 V (Table 2.1, from the shipped catalog)."""
    cat = tomllib.loads(thesis_catalog_toml())
    return float(next(m for m in cat["motor"] if m["name"] == "x-rhex")["no_load_speed_rad_s"])


def objective_values(table: Mapping[str, Any], objective: str) -> np.ndarray:
    """The objective per row, NaN where the leap did not fly (column ``flew``)."""
    if objective not in OBJECTIVES:
        raise ValueError(f"`objective`: expected one of {sorted(OBJECTIVES)}, got {objective!r}")
    col, f = OBJECTIVES[objective]
    ok = np.asarray(table["flew"], dtype=bool)
    return np.where(ok, f(np.asarray(table[col], dtype=float)), np.nan)


def best_gear_ratios(table: Mapping[str, Any], objective: str, window: float = 0.02) -> list[dict[str, Any]]:
    """Per (strategy, t2) of a sweep table: the gear ratio maximizing ``objective`` among the
    points that reached an apex, its value, whether it lies on the edge of the swept G
    (``at_edge``: widen the grid), the range of G within ``window`` (relative) of the best
    (``near_best``: how flat the optimum is), and how many points reached an apex."""
    vals = objective_values(table, objective)
    strategy = np.asarray(table["strategy"]).astype(str)
    t2 = np.asarray(table["t2_s"], dtype=float)
    gear = np.asarray(table["gear_ratio"], dtype=float)
    out = []
    for s in [s for s in STRATEGIES if s in set(strategy)]:
        for t in np.unique(t2[strategy == s]):
            m = (strategy == s) & (t2 == t)
            g, v = gear[m], vals[m]
            order = np.argsort(g)
            g, v = g[order], v[order]
            row: dict[str, Any] = {"strategy": s, "t2_s": float(t), "objective": objective,
                                   "n": int(m.sum()), "n_ok": int(np.isfinite(v).sum())}
            if row["n_ok"] == 0:
                row.update(gear_ratio=math.nan, value=math.nan, at_edge=False, near_best=(math.nan, math.nan))
            else:
                i = int(np.nanargmax(v))
                near = g[np.isfinite(v) & (v >= v[i] - window * abs(v[i]))]
                row.update(gear_ratio=float(g[i]), value=float(v[i]), at_edge=i in (0, len(g) - 1),
                           near_best=(float(near.min()), float(near.max())))
            out.append(row)
    return out


def stance_work_optimal_ratio(result: "selfmanip.LeapResult", omega_nl: float | None = None) -> float:
    """The gear ratio that maximizes the motors' work along this leap's own stance, its leg
    rates held fixed: with the motor line ``tau = c G (1 - G u / omega_nl)`` (u the leg rate in
    the push direction, c = motors x efficiency x stall torque of one motor) the work is
    ``W(G) = c (G int u dt - G^2/omega_nl int u^2 dt)`` over the time each leg is on the ground,
    maximal at ``G_w = omega_nl int u dt / (2 int u^2 dt)``. Fig. 4.11's optimum is the same
    condition at one instant (the motor at half its no-load speed at takeoff); a leap's optimum
    is near the fixed point ``G = G_w(G)`` (``docs/gear-ratio.md``). Rates against the push
    (u < 0) count as 0: there the current limit holds the torque at stall, independent of
    the line."""
    tr = result.trajectory
    if tr is None:
        raise ValueError("`result` has no trajectory (run the leap with a `dt`)")
    omega = no_load_speed_rad_s() if omega_nl is None else float(omega_nl)
    t = np.asarray(tr.t_s, dtype=float)
    s1 = 0.0
    s2 = 0.0
    # mode labels FB FL RB RL: the front leg's contact is character 1, the rear leg's 3
    for leg, (char, sign) in enumerate(((1, result.strategy[0]), (3, result.strategy[1]))):
        on = np.array([m[char] != "0" for m in tr.mode])
        u = np.maximum((1.0 if sign == "+" else -1.0) * np.asarray(tr.qd[:, leg], dtype=float), 0.0) * on
        s1 += float(np.trapezoid(u, t))
        s2 += float(np.trapezoid(u * u, t))
    return omega * s1 / (2.0 * s2) if s2 > 0.0 else math.nan


def analysis_optimum(phi: float = 0.0, phi_dot: float = 0.0) -> dict[str, float]:
    """Fig. 4.11's optimum at pitch ``phi``: the gear ratio, the takeoff speed |x_dot|, the
    rear-leg angle at the best takeoff, the leg rate there and the motor's fraction of its
    no-load speed at that instant (``G theta_dot / omega_nl``)."""
    g, v = analysis.optimal_gear_ratio(phi=phi, phi_dot=phi_dot)
    f = analysis.fig_4_11(ratios=[g], phis=[phi])
    theta2 = float(f["theta2_opt"][0, 0])
    b = analysis.takeoff_speed(theta2, phi, phi_dot, g, leg="rolling")
    return {"gear_ratio": g, "xdot": v, "theta2": theta2, "leg_rate": b["leg_rate"],
            "speed_fraction": g * b["leg_rate"] / no_load_speed_rad_s()}


def _edge(row: Mapping[str, Any]) -> str:
    return "  [at the edge of the grid: widen --gears]" if row["at_edge"] else ""


def _range(text: str) -> np.ndarray:
    a, b, n = text.split(":")
    return np.linspace(float(a), float(b), int(n))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=".")
    ap.add_argument("--gears", default="8:60:53", help="START:STOP:COUNT of gear ratios")
    ap.add_argument("--t2", default=",".join(f"{t:g}" for t in DEFAULT_T2),
                    help="comma-separated coordination times (s)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="a fixed numeric parameter of every leap, e.g. --set mu_rear=1.8")
    args = ap.parse_args(argv)
    gears = _range(args.gears)
    t2 = [float(t) for t in args.t2.split(",")]
    fixed = {}
    for item in args.set:
        name, sep, value = item.partition("=")
        if not sep:
            ap.error(f"--set: expected NAME=VALUE, got {item!r}")
        fixed[name.strip()] = float(value)
    with warnings.catch_warnings():
        # a sweep that fails everywhere is reported below, with the exit code
        warnings.simplefilter("ignore", selfmanip.AllPointsFailedWarning)
        table = selfmanip.sweep(list(STRATEGIES), t2=t2, gear_ratio=gears, **fixed)
    os.makedirs(args.out_dir, exist_ok=True)
    csv_path = os.path.join(args.out_dir, "gear_ratio_sweep.csv")
    write_table(table, csv_path)
    failed = failure_summary(table)
    if failed is not None:
        print(f"gear_ratio_sweep: error: {failed}", file=sys.stderr)
        return 1
    png_path = sweep_figure(table, os.path.join(args.out_dir, "gear_ratio_sweep.png"),
                            title="Leaps over t2 and gear ratio (cf. thesis section 4.3.3)")
    a = analysis_optimum()
    print(f"takeoff-speed analysis (Fig. 4.11, rear leg alone, rolling, phi = 0): best G = {a['gear_ratio']:.1f} "
          f"(|x_dot| = {a['xdot']:.2f} m/s; the motor at {a['speed_fraction']:.2f} of its no-load speed at takeoff)")
    by = {obj: {(r["strategy"], r["t2_s"]): r for r in best_gear_ratios(table, obj)} for obj in OBJECTIVES}
    for key, h in by["apex_height"].items():
        s, t = key
        v = by["takeoff_speed"][key]
        if h["n_ok"] == 0:
            print(f"({s[0]}, {s[1]}) t2={t:+.2f}: no leap reaches an apex")
            continue
        r = selfmanip.leap(s, t2=t, gear_ratio=h["gear_ratio"], dt=5e-4)
        gw = stance_work_optimal_ratio(r)
        print(f"({s[0]}, {s[1]}) t2={t:+.2f} ({h['n_ok']}/{h['n']} reach an apex): "
              f"apex height best at G = {h['gear_ratio']:.1f} ({h['value']:.3f} m; within 2 %: "
              f"G {h['near_best'][0]:.0f}-{h['near_best'][1]:.0f}; stance work-optimal G_w = {gw:.1f}){_edge(h)} | "
              f"take-off speed |x_dot| best at G = {v['gear_ratio']:.1f} ({v['value']:.2f} m/s){_edge(v)}")
    print(f"wrote {csv_path} and {png_path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
