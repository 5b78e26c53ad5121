"""A one-legged hopper hopping forward up a ledge: the Python twin of
``crates/selfmanip-sim/examples/ledge.rs``. The hopper and its behaviour (``hopper.toml``,
``hop_up.toml``: the leg tucks up in the air and lands ahead of the hip), a forward start
speed, and a step 4 cm up ahead (a terrain with a face, an edge and a top); logged to MCAP and
plotted.

    python3 python/examples/ledge.py [--out-dir .] [--t-final 2.0] [--set lean=0.08]
"""

from __future__ import annotations

import argparse

import selfmanip
from hopper import DATA, q0, write_log_and_plot  # the example beside this one
from selfmanip.cli_sim import parse_terrain


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=".")
    ap.add_argument("--t-final", type=float, default=2.0)
    ap.add_argument("--speed", type=float, default=0.6, help="forward start speed (m/s)")
    ap.add_argument("--terrain", default="ledge,height_m=0.04,distance_m=0.55")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="a parameter by name")
    args = ap.parse_args(argv)
    # dropped 5 cm, the leg at its landing pose, moving forward at `speed`
    qd0 = [0.0, 0.0, args.speed, 0.0, 0.0]
    params = {k: float(v) for k, v in (s.split("=", 1) for s in args.set)}
    e = selfmanip.simulate(DATA / "hopper.toml", DATA / "hop_up.toml", q0(drop_m=0.05), qd0, terrain=parse_terrain(args.terrain),
                           t_final=args.t_final, params=params)
    print(f"status {e.status} after {e.t_end_s:.2f} s, word {e.word_string}")
    for ev in e.events:
        print(f"  t {ev['t_s']:.4f} s  {ev['kind']:<9} {ev['mode_before']} -> {ev['mode_after']}")
    x, z = e.q_end[2], e.q_end[3]
    print(f"end: body x {x:.3f} m, height {-z:.3f} m")
    write_log_and_plot(e, args.out_dir, "ledge")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
