"""``python/examples/leap_design.py`` on a small budget: it runs, its grid answer is the best
feasible point of the same sweep run here directly, and its gradient answer is what a single
leap at that design gives (re-evaluated independently), within the pitch bound."""
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

import selfmanip

pytest.importorskip("scipy")
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "leap_design.py"


def load():
    spec = importlib.util.spec_from_file_location("leap_design", EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_leap_design_small_budget(capsys):
    mod = load()
    grid, grad = mod.main(["--grid", "5x3", "--maxiter", "5", "--threads", "1"])
    out = capsys.readouterr().out
    assert "SLSQP + engine gradients" in out and "grid 5x3 sweep" in out
    assert grid["leaps"] == 15
    t = selfmanip.sweep("-+", t2=np.linspace(-0.2, 0.2, 5), gear_ratio=np.linspace(15.0, 44.0, 3), threads=1)
    ok = t["flew"] & (np.abs(t["apex_phi_rad"]) <= math.radians(20.0))
    assert grid["apex_z_m"] == np.max(t["apex_z_m"][ok])
    # the gradient path's leaps run with the free legs under step control (as every leap with
    # sensitivities): the same leap re-run without them
    r = selfmanip.leap("-+", t2=grad["t2_s"], gear_ratio=grad["gear_ratio"], dt=None,
                       control_free_joints=True)
    assert r.apex.z_m == grad["apex_z_m"]
    assert mod.feasible(grad) and abs(math.degrees(r.apex.phi_rad)) <= 20.0 + 1e-6
    assert grad["leaps"] > 15
