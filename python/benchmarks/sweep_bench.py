"""Leaps per second through the Python API (issue 5's targets: >= 2,000 (+,+) leaps/s in a
sweep on the 2-core machine, >= 1.8x from 1 to 2 threads).

    python3 python/benchmarks/sweep_bench.py [--points 400] [--repeat 3]

Prints the best of ``--repeat`` runs for 1 and 2 threads (and all CPUs if more), the speed-up,
and checks that the tables are bit-identical across thread counts.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import selfmanip


def run(points: int, threads: int, repeat: int, strategy: str) -> tuple[float, dict]:
    t2 = np.linspace(-0.2, 0.2, points)
    best, table = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        table = selfmanip.sweep(strategy, t2=t2, gear_ratio=28.0, threads=threads)
        best = min(best, time.perf_counter() - t0)
    return points / best, table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=400)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--strategy", default="++")
    args = ap.parse_args()
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    counts = sorted({1, 2, cpus})
    rates, tables = {}, {}
    for n in counts:
        rates[n], tables[n] = run(args.points, n, args.repeat, args.strategy)
        ok = int(np.sum(tables[n]["flew"]))
        print(f"threads={n}: {rates[n]:8.0f} leaps/s  ({args.points} {args.strategy} leaps, {ok} ok)")
    print(f"speed-up 1 -> 2 threads: {rates[2] / rates[1]:.2f}x")
    ref = tables[1]
    same = all(np.array_equal(np.asarray(ref[k]).view(np.int64) if ref[k].dtype == np.float64 else ref[k],
                              np.asarray(t[k]).view(np.int64) if t[k].dtype == np.float64 else t[k])
               for t in tables.values() for k in ref)
    print(f"bit-identical across thread counts: {same}")


if __name__ == "__main__":
    main()
