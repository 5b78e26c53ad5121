"""Gradient-based leap design (issue 18): maximize the apex height over the coordination time
``t2`` and the gear ratio ``G`` subject to ``|apex pitch| <= 20 deg``, with scipy's SLSQP fed
the engine's exact gradients (``selfmanip.leap(..., sensitivities=["t2", "gear_ratio"])``:
variational equations and saltation matrices through every event), side by side with the
brute-force sweep over a grid. Each evaluation is one leap; the table at the end gives the
evaluations each method used and its answer.

    python python/examples/leap_design.py                 # strategy -+, 41 x 15 grid
    python python/examples/leap_design.py --strategy +- --grid 21x8 --maxiter 30

The apex is a piecewise-smooth function of the design: where a small change of ``t2`` or
``G`` changes the leap's mode sequence (which legs touch, in which order), the derivative is
undefined and the engine flags it (``sensitivity_ok`` False). There the example takes the
derivative of the neighbouring piece (at ``t2 + 1e-6 s``) and counts it. SLSQP finds a local
optimum of the piece it starts in and its neighbours; the grid sees every piece at its
resolution — the table shows both.
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np
from scipy.optimize import minimize

import selfmanip

PITCH_MAX = math.radians(20.0)
T2_BOUNDS = (-0.2, 0.2)
G_BOUNDS = (15.0, 44.0)


class Design:
    """The leap as a function of ``x = (t2, G)``: apex height, pitch and their gradients, one
    leap per distinct ``x`` (memoized)."""

    def __init__(self, strategy: str):
        self.strategy = strategy
        self.cache: dict[tuple[float, float], tuple[float, float, np.ndarray, np.ndarray]] = {}
        self.leaps = 0
        self.neighbour_gradients = 0

    def _leap(self, t2: float, g: float):
        self.leaps += 1
        return selfmanip.leap(self.strategy, t2=t2, actuator=selfmanip.GearedMotor(ratio=g), dt=None,
                              sensitivities=["t2", "gear_ratio"])

    def __call__(self, x) -> tuple[float, float, np.ndarray, np.ndarray]:
        key = (float(x[0]), float(x[1]))
        if key not in self.cache:
            r = self._leap(*key)
            if r.apex is None:
                # no flight: the lowest apex there is, pitch treated as level
                self.cache[key] = (0.0, 0.0, np.zeros(2), np.zeros(2))
                return self.cache[key]
            z, phi = r.apex.z_m, r.apex.phi_rad
            s = r
            if not r.sensitivity_ok:
                # a change of the mode sequence here: the neighbouring piece's derivative
                self.neighbour_gradients += 1
                s = self._leap(key[0] + 1e-6, key[1])
            dz = np.array([s.sensitivity[("apex_z_m", "t2")], s.sensitivity[("apex_z_m", "gear_ratio")]])
            dphi = np.array([s.sensitivity[("apex_phi_rad", "t2")],
                             s.sensitivity[("apex_phi_rad", "gear_ratio")]])
            if not (np.isfinite(dz).all() and np.isfinite(dphi).all()):
                dz, dphi = np.zeros(2), np.zeros(2)
            self.cache[key] = (z, phi, dz, dphi)
        return self.cache[key]


def gradient_design(strategy: str, x0: tuple[float, float], maxiter: int) -> dict:
    """SLSQP on ``-z`` with ``PITCH_MAX ∓ phi >= 0``, gradients from the engine."""
    d = Design(strategy)
    # scale G to order one so that the two design variables have comparable steps
    sc = np.array([1.0, 0.01])

    def unpack(u):
        return u / sc

    res = minimize(
        lambda u: -d(unpack(u))[0],
        np.array(x0) * sc,
        jac=lambda u: -d(unpack(u))[2] / sc,
        bounds=[(T2_BOUNDS[0] * sc[0], T2_BOUNDS[1] * sc[0]), (G_BOUNDS[0] * sc[1], G_BOUNDS[1] * sc[1])],
        constraints=[
            {"type": "ineq", "fun": lambda u: PITCH_MAX - d(unpack(u))[1],
             "jac": lambda u: -d(unpack(u))[3] / sc},
            {"type": "ineq", "fun": lambda u: PITCH_MAX + d(unpack(u))[1],
             "jac": lambda u: d(unpack(u))[3] / sc},
        ],
        method="SLSQP",
        options={"maxiter": maxiter, "ftol": 1e-9},
    )
    x = unpack(res.x)
    z, phi, _, _ = d(x)
    return {"method": "SLSQP + engine gradients", "t2_s": x[0], "gear_ratio": x[1], "apex_z_m": z,
            "apex_pitch_deg": math.degrees(phi), "leaps": d.leaps,
            "neighbour_gradients": d.neighbour_gradients, "converged": bool(res.success),
            "message": res.message}


def grid_design(strategy: str, n_t2: int, n_g: int, threads: int | None, best: int = 1) -> dict:
    """The best feasible point of a brute-force sweep over the grid (and the `best` best as
    `starts`)."""
    t2 = np.linspace(*T2_BOUNDS, n_t2)
    g = np.linspace(*G_BOUNDS, n_g)
    t = selfmanip.sweep(strategy, t2=t2, actuator=[selfmanip.GearedMotor(ratio=x) for x in g], threads=threads)
    feasible = t["flew"] & (np.abs(t["apex_phi_rad"]) <= PITCH_MAX)
    out = {"method": f"grid {n_t2}x{n_g} sweep", "leaps": len(t2) * len(g), "apex_z_m": math.nan,
           "t2_s": math.nan, "gear_ratio": math.nan, "apex_pitch_deg": math.nan, "starts": []}
    if not feasible.any():
        return out
    order = np.argsort(-np.where(feasible, t["apex_z_m"], -np.inf))[: min(best, int(feasible.sum()))]
    i = int(order[0])
    out.update(t2_s=float(t["t2_s"][i]), gear_ratio=float(t["gear_ratio"][i]),
               apex_z_m=float(t["apex_z_m"][i]), apex_pitch_deg=math.degrees(t["apex_phi_rad"][i]),
               starts=[(float(t["t2_s"][j]), float(t["gear_ratio"][j])) for j in order])
    return out


def feasible(r: dict) -> bool:
    return math.isfinite(r["apex_z_m"]) and abs(r["apex_pitch_deg"]) <= math.degrees(PITCH_MAX) + 1e-6


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--strategy", default="-+")
    ap.add_argument("--grid", default="41x15", help="grid points in t2 x gear ratio")
    ap.add_argument("--maxiter", type=int, default=40, help="SLSQP iterations")
    ap.add_argument("--start", default=None,
                    help="SLSQP start t2,G (default: the three best feasible points of a 5x3 grid)")
    ap.add_argument("--threads", type=int, default=None)
    args = ap.parse_args(argv)
    n_t2, n_g = (int(v) for v in args.grid.lower().split("x"))
    t0 = time.perf_counter()
    grid = grid_design(args.strategy, n_t2, n_g, args.threads)
    grid["seconds"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if args.start is None:
        # SLSQP from the three best feasible points of a coarse grid: the apex is piecewise
        # smooth, and a local method stays near the piece it starts in
        coarse = grid_design(args.strategy, 5, 3, args.threads, best=3)
        starts = coarse["starts"] or [(0.05, 28.0)]
        extra = coarse["leaps"]
    else:
        starts = [tuple(float(v) for v in args.start.split(","))]
        extra = 0
    runs = [gradient_design(args.strategy, st, args.maxiter) for st in starts]
    ok = [r for r in runs if feasible(r)] or runs
    grad = max(ok, key=lambda r: r["apex_z_m"])
    grad["leaps"] = sum(r["leaps"] for r in runs) + extra
    grad["neighbour_gradients"] = sum(r["neighbour_gradients"] for r in runs)
    grad["seconds"] = time.perf_counter() - t0
    start = starts[runs.index(grad)]
    print(f"maximize apex height subject to |apex pitch| <= 20 deg, strategy {args.strategy}, "
          f"t2 in {T2_BOUNDS} s, G in {G_BOUNDS}")
    print(f"{'method':32} {'leaps':>6} {'seconds':>8} {'t2 (s)':>9} {'G':>7} {'apex z (m)':>10} {'pitch (deg)':>11}")
    for r in (grid, grad):
        print(f"{r['method']:32} {r['leaps']:6d} {r['seconds']:8.2f} {r['t2_s']:9.4f} {r['gear_ratio']:7.2f} "
              f"{r['apex_z_m']:10.4f} {r['apex_pitch_deg']:11.2f}")
    print(f"SLSQP from {len(starts)} start(s) (the best feasible points of a 5x3 grid, whose leaps are "
          f"counted); the best feasible answer started at t2 {start[0]:.3f} s, G {start[1]:.1f}: "
          f"{grad['message']}; feasible: {feasible(grad)}; gradients taken on a neighbouring "
          f"piece: {grad['neighbour_gradients']}")
    return [grid, grad]


if __name__ == "__main__":
    main()
