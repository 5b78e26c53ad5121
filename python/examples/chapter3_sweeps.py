"""Thesis chapter 3's sweep (Figs. 3.4-3.5): every strategy over the coordination time t2,
read off as apex height, displacement and pitch with the leap word of each point.

    python3 python/examples/chapter3_sweeps.py [--out-dir .] [--n 41] [--saturated]

Writes ``chapter3_sweep.csv`` and ``chapter3_sweep.png`` and prints, per strategy, how many
leaps reach an apex, the t2 of the highest and of the longest leap and the words seen. This is
the package's main job (``python3 -m selfmanip chapter3``, :mod:`selfmanip.chapter3`); with the
general sweep API it reads:

    table = selfmanip.sweep(["++", "+-", "-+", "--"], t2=np.linspace(-0.2, 0.2, 41))
    selfmanip.plots.sweep_figure(table, "chapter3_sweep.png")

and on the command line:

    selfmanip sweep --strategy ++,+-,-+,-- --t2=-0.2:0.2:41 --out chapter3_sweep.csv
    selfmanip plot chapter3_sweep.csv --out chapter3_sweep.png
"""

from __future__ import annotations

import argparse

from selfmanip.chapter3 import run


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=".")
    ap.add_argument("--n", type=int, default=41, help="t2 samples in [-0.2, 0.2] s")
    ap.add_argument("--saturated", action="store_true",
                    help="chapter 3's saturated torque (default: the engine's default actuator, the geared motor)")
    args = ap.parse_args(argv)
    run(args.out_dir, n=args.n, saturated=args.saturated)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
