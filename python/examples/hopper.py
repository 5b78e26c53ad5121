"""A one-legged hopper dropped from a height, hopping in place: the Python twin of
``crates/selfmanip-sim/examples/hopper.rs``. The robot and the behaviour are data files
(``crates/selfmanip-sim/examples/data/hopper.toml``, ``hop.toml``); the run is logged to MCAP
(open it in Foxglove) and plotted.

    python3 python/examples/hopper.py [--out-dir .] [--t-final 1.0]

The CLI equivalent: ``selfmanip simulate crates/selfmanip-sim/examples/data/hopper.toml
crates/selfmanip-sim/examples/data/hop.toml --q0 0.5,-1,0,-0.451,0 --mcap hopper.mcap
--plot hopper.png``.
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib

import selfmanip
from selfmanip.cli_sim import print_execution

DATA = pathlib.Path(__file__).resolve().parents[2] / "crates" / "selfmanip-sim" / "examples" / "data"


def q0(drop_m: float = 0.1, a: float = 0.5) -> list[float]:
    """Dropped level, the foot ``drop_m`` above the ground, the leg at its landing pose (hip
    ``a``, knee ``-2a``: the foot under the hip, ``2 L cos a`` below it)."""
    return [a, -2.0 * a, 0.0, -(drop_m + 0.4 * math.cos(a)), 0.0]


def write_log_and_plot(e: selfmanip.Execution, out_dir: str, name: str, indent: str = "") -> None:
    """Logs the run to ``<out_dir>/<name>.mcap`` (for Foxglove) and plots it to ``<name>.png``,
    printing each path written."""
    out = pathlib.Path(out_dir)
    print(f"{indent}wrote", e.to_mcap(out / f"{name}.mcap", metadata={"example": name}))
    e.plot(out / f"{name}.png")
    print(f"{indent}wrote", os.fspath(out / f"{name}.png"))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=".")
    ap.add_argument("--t-final", type=float, default=1.0)
    args = ap.parse_args(argv)
    e = selfmanip.simulate(DATA / "hopper.toml", DATA / "hop.toml", q0(), t_final=args.t_final)
    print_execution(e)
    write_log_and_plot(e, args.out_dir, "hopper")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
