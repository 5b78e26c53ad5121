"""A planar quadruped pronking and bounding on flat ground: the Python twin of
``crates/selfmanip-sim/examples/quadruped.rs``. Robot and behaviours are data files
(``quadruped.toml``, ``pronk.toml``, ``bound.toml``); the legs are made massless by setting
their links' masses by name (``--massive`` keeps the description's legs); each run is logged
to MCAP and plotted.

    python3 python/examples/quadruped.py [--out-dir .] [--t-final 1.5] [--massive]
"""

from __future__ import annotations

import argparse
import math

import selfmanip
from hopper import DATA, write_log_and_plot  # the example beside this one


def q0(drop_m: float, phi: float, a: float = 0.5) -> list[float]:
    """Dropped from ``drop_m`` (feet above the ground) at pitch ``phi``, legs at their landing
    pose (hip ``a``, knee ``-2a``: each foot under its hip)."""
    return [a, -2.0 * a, a, -2.0 * a, 0.0, -(drop_m + 0.4 * math.cos(a)), phi]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=".")
    ap.add_argument("--t-final", type=float, default=1.5)
    ap.add_argument("--massive", action="store_true", help="keep the legs' masses of the description")
    args = ap.parse_args(argv)
    params: dict[str, float] = {}
    if not args.massive:
        # parameters by name: every link's mass and inertia
        for leg in ("fore", "hind"):
            for k in range(2):
                params[f"legs.{leg}.links[{k}].mass_kg"] = 0.0
                params[f"legs.{leg}.links[{k}].inertia_kg_m2"] = 0.0
    for name, behaviour, phi in (("pronk", "pronk.toml", 0.0), ("bound", "bound.toml", 0.15)):
        e = selfmanip.simulate(DATA / "quadruped.toml", DATA / behaviour, q0(0.05, phi), t_final=args.t_final,
                               params=params, labels=["fore_foot", "hind_foot"])
        flights = sum(1 for c in e.word if c == "00")
        print(f"{name}: {e.status} after {e.t_end_s:.2f} s, {len(e.events)} events, {flights} flights, "
              f"word {e.word_string}")
        print(f"    end: x {e.q_end[4]:.3f} m, height {-e.q_end[5]:.3f} m, pitch {math.degrees(e.q_end[6]):.1f} deg; "
              f"impact losses {e.outcome['impact_loss_j']:.2f} J")
        write_log_and_plot(e, args.out_dir, name, indent="    ")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
