"""Plots: a synthetic sweep table (over t2 and over the gear ratio) and a leap each give a PNG;
the drawn robot agrees with the engine's contact points (independent kinematics)."""

import numpy as np
import pytest

import selfmanip
from selfmanip.leap import SWEEP_COLUMNS

pytest.importorskip("matplotlib")
from selfmanip import plots  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"


def synthetic_table(t2, gears, seed=0):
    rng = np.random.default_rng(seed)
    rows = [(s, g, t) for s in ("++", "-+") for g in gears for t in t2]
    n = len(rows)
    words = np.array(["1010-0110-0101-0001-0000", "1010-1001-0101-0100-0000", ""])
    w = words[rng.integers(0, 3, n)]
    table = {c: rng.normal(size=n) for c in SWEEP_COLUMNS}
    table.update(strategy=np.array([r[0] for r in rows]), gear_ratio=np.array([r[1] for r in rows], dtype=float),
                 t2_s=np.array([r[2] for r in rows], dtype=float), word=w,
                 status=np.where(w == "", "zeno", "ok"), error=np.full(n, ""), n_events=np.zeros(n, dtype=np.int64))
    return table


@pytest.mark.parametrize("t2, gears", [(np.linspace(-0.2, 0.2, 21), [28.0]), ([0.0], np.linspace(15, 40, 11)),
                                       (np.linspace(-0.2, 0.2, 5), [20.0, 28.0, np.nan])])
def test_sweep_figure_writes_a_png(tmp_path, t2, gears):
    out = plots.sweep_figure(synthetic_table(t2, gears), tmp_path / "s.png")
    assert open(out, "rb").read(8) == PNG


def test_sweep_figure_names_a_missing_column(tmp_path):
    t = synthetic_table([0.0], [28.0])
    del t["apex_x_m"]
    with pytest.raises(ValueError, match="apex_x_m"):
        plots.sweep_figure(t, tmp_path / "s.png")


@pytest.mark.parametrize("shape", ["stick", "half_circle"])
def test_drawn_legs_touch_the_engine_contact_points(shape, tmp_path):
    r = selfmanip.leap("++", 0.0, 28.0, {"leg_shape": shape}, dt=0.004)
    tr = r.trajectory
    checked = 0
    for k in range(len(tr.t_s)):
        lines = plots.robot_outline(r.params, tr.q[k])
        for c, name in enumerate(tr.contacts):
            p = tr.contact_points_m[k, c]
            if not name.endswith("_leg") or not np.all(np.isfinite(p)):
                continue
            leg = lines[3 + ["middle_leg", "rear_leg"].index(name)]
            if shape == "stick":
                assert leg[-1] == pytest.approx(p, abs=1e-9)  # the toe
            else:
                # the contact point lies on the drawn arc (densely resampled)
                d = np.min(np.hypot(*(leg - p).T))
                assert d < 0.5 * r.params["rho1"] * (np.pi / 24) * 0.6
            checked += 1
    assert checked > 0
    out = plots.plot_result(r, tmp_path / "strip.png")
    assert open(out, "rb").read(8) == PNG
