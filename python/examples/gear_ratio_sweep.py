"""Thesis section 4.3.3: which gear ratio maximizes the take-off speed? A sweep over the
X-RHex gear ratio G (two motors per planar leg, 20 A current limit) and a few coordination
times, for each strategy; the forward speed at the apex of flight is the take-off speed.

    python3 python/examples/gear_ratio_sweep.py [--out-dir .]

Writes ``gear_ratio_sweep.csv`` / ``.png`` and prints the best G per strategy. The CLI
equivalent: ``selfmanip sweep --strategy ++,-+ --t2=-0.05:0.05:3 --gear-ratio 12:45:34``.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

import selfmanip
from selfmanip.cli_leap import write_table
from selfmanip.plots import sweep_figure


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=".")
    ap.add_argument("--gears", default="12:45:34", help="START:STOP:COUNT of gear ratios")
    args = ap.parse_args(argv)
    a, b, n = args.gears.split(":")
    gears = np.linspace(float(a), float(b), int(n))
    t2 = [-0.05, 0.0, 0.05]
    table = selfmanip.sweep(["++", "+-", "-+", "--"], t2=t2, gear_ratio=gears)
    os.makedirs(args.out_dir, exist_ok=True)
    csv_path = os.path.join(args.out_dir, "gear_ratio_sweep.csv")
    write_table(table, csv_path)
    at0 = {k: v[table["t2_s"] == 0.0] for k, v in table.items()}
    png_path = sweep_figure(at0, os.path.join(args.out_dir, "gear_ratio_sweep.png"),
                            title="Forward speed at the apex vs gear ratio (t2 = 0; cf. thesis section 4.3.3)")
    for s in ("++", "+-", "-+", "--"):
        for t in t2:
            m = (table["strategy"] == s) & (table["t2_s"] == t) & (table["status"] == "ok")
            if not m.any():
                print(f"({s[0]}, {s[1]}) t2={t:+.2f}: no leap reaches an apex")
                continue
            # the take-off speed is the magnitude |x_dot| (Fig. 4.11), whichever way the leap goes:
            # maximizing the signed speed picks the grid's edge for a backward leap
            speed = np.where(m, np.abs(table["apex_xdot_m_s"]), -np.inf)
            i = int(np.argmax(speed))
            edge = table["gear_ratio"][i] in (gears[0], gears[-1])
            print(f"({s[0]}, {s[1]}) t2={t:+.2f}: best G = {table['gear_ratio'][i]:.0f} "
                  f"(take-off speed |x_dot| = {speed[i]:.3f} m/s, "
                  f"{'forward' if table['apex_xdot_m_s'][i] >= 0 else 'backward'}, "
                  f"apex {table['apex_z_m'][i]:.3f} m)"
                  + ("  [at the edge of the grid: widen --gears]" if edge else ""))
    print(f"wrote {csv_path} and {png_path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
