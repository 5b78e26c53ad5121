"""Thesis chapter 3's sweep (Figs. 3.4-3.5): every strategy over the coordination time t2,
read off as apex height, displacement and pitch with the leap word of each point.

    python3 python/examples/chapter3_sweeps.py [--out-dir .] [--n 41] [--saturated]

Writes ``chapter3_sweep.csv`` and ``chapter3_sweep.png`` and prints, per strategy, the t2 of
the highest and of the longest leap and the words seen. The CLI equivalent:

    selfmanip sweep --strategy ++,+-,-+,-- --t2=-0.2:0.2:41 --out chapter3_sweep.csv
    selfmanip plot chapter3_sweep.csv --out chapter3_sweep.png
"""

from __future__ import annotations

import argparse
import os
from collections import Counter

import numpy as np

import selfmanip
from selfmanip.cli_leap import write_table
from selfmanip.plots import sweep_figure, word_label


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=".")
    ap.add_argument("--n", type=int, default=41, help="t2 samples in [-0.2, 0.2] s")
    ap.add_argument("--saturated", action="store_true",
                    help="chapter 3's saturated torque (default: the engine's default actuator, the geared motor)")
    args = ap.parse_args(argv)
    t2 = np.linspace(-0.2, 0.2, args.n)
    table = selfmanip.sweep(["++", "+-", "-+", "--"], t2=t2, gear_ratio=None if args.saturated else selfmanip.DEFAULT)
    os.makedirs(args.out_dir, exist_ok=True)
    csv_path = os.path.join(args.out_dir, "chapter3_sweep.csv")
    png_path = os.path.join(args.out_dir, "chapter3_sweep.png")
    write_table(table, csv_path)
    sweep_figure(table, png_path)
    for s in ("++", "+-", "-+", "--"):
        m = (table["strategy"] == s) & (table["status"] == "ok")
        line = f"({s[0]}, {s[1]}): {int(m.sum())}/{args.n} leaps reach an apex"
        if m.any():
            hi = np.argmax(np.where(m, table["apex_z_m"], -np.inf))
            far = np.argmax(np.where(m, np.abs(table["apex_x_m"]), -np.inf))
            line += (f"; highest {table['apex_z_m'][hi]:.3f} m at t2 = {table['t2_s'][hi]:+.3f} s, "
                     f"longest {table['apex_x_m'][far]:+.3f} m at t2 = {table['t2_s'][far]:+.3f} s")
        print(line)
        for word, count in Counter(table["word"][m]).most_common(4):
            print(f"    {count:3d} x {word_label(word)}")
    print(f"wrote {csv_path} and {png_path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
