"""One column vocabulary in every sweep (docs/sweeps.md, "One column vocabulary"): ``apex_z_m``
is the body centre's height above the ground, positive up, and ``apex_zdot_m_s`` its rate up —
in the leap sweep and in the sweep of any robot. Second route: the engine's own NED state of
the same run (``z`` down), and the leap's apex read one leap at a time."""
from __future__ import annotations

import math
import pathlib

import numpy as np

import selfmanip

DATA = pathlib.Path(__file__).resolve().parents[2] / "crates" / "selfmanip-sim" / "examples" / "data"
HOPPER, HOP = DATA / "hopper.toml", DATA / "hop.toml"


def _hopper_q0(drop_m: float, a: float = 0.5) -> list[float]:
    # the foot circle (radius 0.02) under the hip at 2 L cos a, `drop_m` above the ground
    return [a, -2 * a, 0.0, -(drop_m + 0.4 * math.cos(a) + 0.02), 0.0]


def test_a_robot_sweep_reports_the_apex_height_up():
    over = {"kp_push": [35.0, 55.0]}
    r = selfmanip.sweep(HOPPER, HOP, over=over, q0=_hopper_q0(0.1), t_final=0.4, threads=1)
    for i, kp in enumerate(over["kp_push"]):
        run = selfmanip.simulate(HOPPER, HOP, _hopper_q0(0.1), t_final=0.4, params={"kp_push": kp})
        ned = run.apex  # the run's own outcome: NED, z down
        assert r["apex_z_m"][i] == -ned["z_m"] > 0.0
        assert r["apex_zdot_m_s"][i] == -ned["zdot_m_s"]
        assert r["apex_x_m"][i] == ned["x_m"] and r["apex_t_s"][i] == ned["t_s"]
        landing = run.outcome["landing"]["before"]
        assert r["landing_z_m"][i] == -landing["z_m"]


def test_the_leap_sweep_reports_the_apex_height_up():
    r = selfmanip.sweep("++", t2=[0.0, 0.05], threads=1)
    for i, t2 in enumerate(r["t2_s"]):
        one = selfmanip.leap("++", t2=float(t2))
        assert one.flew
        # the leap's apex: above the ground it started on, rising no more
        assert r["apex_z_m"][i] == one.apex.z_m > 0.0
        assert abs(r["apex_zdot_m_s"][i]) < 1e-6
    assert np.all(r["apex_z_m"] > 0.0)
