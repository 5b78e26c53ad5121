"""Floquet multipliers of a hopping gait: the one-legged hopper of
``crates/selfmanip-sim/examples/data/hopper.toml`` hopping in place under
``hop_periodic.toml`` (a pre-loaded knee spring in stance, a limp hip, the landing pose held in
the air). Newton shooting on the apex-to-apex return map finds the periodic orbit; its
multipliers say which perturbations die out and which grow (``docs/periodic-orbits.md``). The
Rust twin is ``crates/selfmanip-sim/examples/floquet_hopper.rs``.

    python3 python/examples/floquet_hopper.py [--out-dir .]

Expected: three events a period (touchdown, liftoff, apex), the height's multiplier ~0.43
(stable), the horizontal speed's ~1.26 (unstable: nothing places the foot), two at 1 (the
body's pitch rate is conserved: the leg force passes through the centre of mass), the leg's
~0 (it reaches its landing pose in every flight).
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib

import numpy as np

import selfmanip

DATA = pathlib.Path(__file__).resolve().parents[2] / "crates" / "selfmanip-sim" / "examples" / "data"
ROBOT, BEHAVIOUR = DATA / "hopper.toml", DATA / "hop_periodic.toml"


def guess(apex_height_m: float = 0.45, a: float = 0.5) -> list[float]:
    """An apex guess: level, at rest, the leg in its landing pose (hip ``a``, knee ``-2a``)."""
    return [a, -2.0 * a, 0.0, -apex_height_m, 0.0]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=".")
    args = ap.parse_args(argv)
    o = selfmanip.periodic_orbit(ROBOT, BEHAVIOUR, guess())
    print(f"periodic orbit: period {o.period_s:.5f} s, apex height {-o.q[3]:.5f} m, "
          f"{o.iterations} Newton iterations, residual {o.residual:.1e}")
    print("events per period:", " -> ".join(e["kind"] for e in o.events))
    print(f"stride {o.drift[0]:+.2e} m per period ({', '.join(o.cyclic)} cyclic); "
          f"orbit one of a family along {o.rank_deficiency} direction(s)")
    print("section multipliers (section coordinates:", ", ".join(o.section_coordinates) + "):")
    for lam in o.section_multipliers:
        print(f"  {lam.real:+.6f} {lam.imag:+.2e}i   |λ| = {abs(lam):.6f}")
    print("stability:", o.stability)
    full = np.linalg.eigvals(o.period_monodromy)
    print("period monodromy multipliers (the trivial 1 of the flow added):",
          ", ".join(f"{abs(z):.4f}" for z in sorted(full, key=abs, reverse=True)))

    # one period from the fixed point, and the multipliers against the unit circle
    e = selfmanip.simulate(ROBOT, BEHAVIOUR, o.q, o.qd, t_final=o.period_s, rtol=1e-10)
    tr = e.trajectory(0.002)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.2))
    a1.plot(tr.t_s, -tr.q[:, 3], label="body height -z (m)")
    a1.plot(tr.t_s, tr.q[:, 1], label="knee angle (rad)")
    for ev in e.events:
        a1.axvline(ev["t_s"], color="0.7", lw=0.8)
        a1.text(ev["t_s"], a1.get_ylim()[1], ev["kind"], rotation=90, va="top", fontsize=8)
    a1.set_xlabel("t (s)")
    a1.set_title("one period from the fixed point")
    a1.legend(loc="lower right", fontsize=8)
    th = np.linspace(0, 2 * math.pi, 200)
    a2.plot(np.cos(th), np.sin(th), color="0.6", lw=1)
    a2.scatter(o.section_multipliers.real, o.section_multipliers.imag, color="C3", zorder=3)
    a2.set_aspect("equal")
    a2.axhline(0, color="0.85", lw=0.8)
    a2.axvline(0, color="0.85", lw=0.8)
    a2.set_title(f"Floquet multipliers ({o.stability})")
    a2.set_xlabel("Re λ")
    a2.set_ylabel("Im λ")
    fig.tight_layout()
    out = pathlib.Path(args.out_dir) / "floquet_hopper.png"
    fig.savefig(out, dpi=110)
    print("wrote", os.fspath(out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
