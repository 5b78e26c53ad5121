"""Which gear ratio: the takeoff-speed analysis (Fig. 4.11) and the leap sweeps, reconciled
(``docs/gear-ratio.md``, ``python/examples/gear_ratio_sweep.py``).

Both routes drive the legs with the same motor line, ``tau = c G (1 - G u / omega_nl)``
(two X-RHex motors per planar leg, 20 A at stall, gearbox efficiency 0.82), and both choose
G by the same condition on it, ``d tau / d G = 0`` at the motor speeds that matter: the
analysis at one instant (takeoff: the motor at half its no-load speed), a leap over its
whole stance (the work-optimal ratio of its own leg-rate history). Each test checks one of
these claims against a route that does not share its code: the closed form of the motor
line against the analysis's numerical optimum; a finer grid against the sweep's optimum;
the stance closed form against the sweep's brute-force optimum; the motor catalog's
torque-speed curve against the closed form's work."""

from __future__ import annotations

import importlib.util
import math
import pathlib

import numpy as np
import pytest

import selfmanip
from selfmanip import analysis, motor

ROOT = pathlib.Path(__file__).resolve().parents[2]
#: Table 2.1: the X-RHex motor's no-load speed at 37 V, 10314 rpm.
OMEGA_NL = 10314.0 * 2.0 * math.pi / 60.0
DEG = math.pi / 180.0


def _example():
    spec = importlib.util.spec_from_file_location("gear_ratio_sweep", ROOT / "python" / "examples" / "gear_ratio_sweep.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def example():
    return _example()


@pytest.mark.parametrize("phi", [-5 * DEG, 0.0, 5 * DEG])
def test_fig_4_11_optimum_runs_the_motor_at_half_its_no_load_speed(phi):
    """(4.64)-(4.66) with the motor line: at a fixed state the rear leg's normal force depends
    on G only through the torque ``tau(u, G) = c G (1 - G u / omega_nl)`` (massless leg, no
    rotor inertia), so the takeoff rate ``u*(G)`` is stationary in G exactly where
    ``d tau / d G = c (1 - 2 G u / omega_nl) = 0``: ``G* = omega_nl / (2 u*)``, the motor at
    half its no-load speed, its maximum power, at takeoff (by the envelope theorem also with
    theta2 optimized). The analysis finds G* numerically (grid + golden section over G and
    theta2); the closed form reads it off the leg rate at its own optimum."""
    g, v = analysis.optimal_gear_ratio(phi=phi)
    theta2 = float(analysis.fig_4_11(ratios=[g], phis=[phi])["theta2_opt"][0, 0])
    b = analysis.takeoff_speed(theta2, phi, 0.0, g, leg="rolling")
    assert not b["holds_to_no_load"]
    assert b["xdot"] == pytest.approx(v, rel=1e-4)
    assert g * b["leg_rate"] / OMEGA_NL == pytest.approx(0.5, abs=1e-4)
    assert g == pytest.approx(OMEGA_NL / (2.0 * b["leg_rate"]), rel=2e-4)
    # the analysis's torque is the leap's drive (catalog x-rhex-28, two motors) at that rate,
    # scaled to G: the two routes share the motor line
    c = motor.torque_speed_curve("x-rhex-28", points=201)
    tau_28 = np.interp(b["leg_rate"] * g / 28.0, c["speed_rad_s"], c["torque_n_m"])
    assert b["tau"] == pytest.approx(2.0 * (g / 28.0) * tau_28, rel=1e-6)


def test_fig_4_11_optimum_is_the_thesis_window():
    """Fig. 4.11: the best takeoff speed peaks inside 25-30 (our 27.9 at phi = 0); a sampled
    curve around it confirms the maximum independently of the golden section."""
    g, v = analysis.optimal_gear_ratio()
    assert 25.0 <= g <= 30.0
    f = analysis.fig_4_11(ratios=np.arange(20.0, 36.5, 0.5), phis=[0.0])
    best = float(f["gear_ratio"][int(np.nanargmax(f["xdot"][:, 0]))])
    assert abs(best - g) <= 0.5 and np.nanmax(f["xdot"]) <= v + 1e-6


def _apex(strategy, t2, gears):
    t = selfmanip.sweep(strategy, t2=t2, gear_ratio=gears, threads=2)
    return t, np.where(t["flew"], t["apex_z_m"], np.nan)


def test_leap_apex_height_optimum_is_interior_and_stands_on_a_finer_grid(example):
    """The default (+,+) leap at t2 = 0 over G in [8, 60] (step 4): the apex height peaks
    inside the grid, and a grid 16 times finer around it (step 0.25 over two coarse steps
    either side) finds its maximum within one coarse step of the coarse optimum, no lower.
    The example reports the same optimum."""
    gears = np.arange(8.0, 60.5, 4.0)
    table, z = _apex("++", 0.0, gears)
    i = int(np.nanargmax(z))
    assert 0 < i < len(gears) - 1, "an interior optimum"
    g_c = gears[i]
    fine = np.arange(g_c - 8.0, g_c + 8.0 + 1e-9, 0.25)
    _, zf = _apex("++", 0.0, fine)
    j = int(np.nanargmax(zf))
    assert abs(fine[j] - g_c) <= 4.0 and 0 < j < len(fine) - 1
    assert zf[j] >= z[i] - 1e-12
    (row,) = example.best_gear_ratios(table, "apex_height")
    assert row["gear_ratio"] == g_c and not row["at_edge"] and row["value"] == z[i]
    # the thesis window of the analysis contains the leap's optimum here
    assert 20.0 <= fine[j] <= 30.0


@pytest.mark.parametrize("strategy,t2", [("++", 0.0), ("++", 0.1), ("++", 0.15), ("--", -0.05), ("--", 0.0)])
def test_leap_optimum_is_the_work_optimal_ratio_of_its_own_stance(example, strategy, t2):
    """A leap's motors do the work ``W(G) = int tau(u, G) u dt`` along their stance; with the
    leg-rate history u(t) held fixed it is maximal at ``G_w = omega_nl int u / (2 int u^2)``
    (``stance_work_optimal_ratio``). The brute-force sweep's apex-height optimum (step 0.5)
    lies within 3 of ``G_w`` of its own best leap, and the leap at ``G_w`` is within 1 % of
    the best apex: the leap picks G by the same motor-line condition as the analysis, on
    the speeds its stance runs through (the curve is flat: +-2 % spans G 20-40)."""
    gears = np.arange(16.0, 44.01, 0.5)
    _, z = _apex(strategy, t2, gears)
    g_opt = float(gears[int(np.nanargmax(z))])
    r = selfmanip.leap(strategy, t2=t2, gear_ratio=g_opt, dt=5e-4)
    g_w = example.stance_work_optimal_ratio(r)
    assert abs(g_w - g_opt) <= 3.0, (g_opt, g_w)
    z_w = selfmanip.leap(strategy, t2=t2, gear_ratio=g_w, dt=None).apex.z_m
    assert z_w >= 0.99 * np.nanmax(z)


def test_stance_work_optimal_ratio_maximizes_the_catalog_motors_work(example):
    """Second formulation of ``G_w``: the work of the catalog drive's torque-speed curve (Fig. 2.6,
    ``x-rhex-28`` scaled to ratio G: ``tau_G(u) = (G/28) tau_28(u G / 28)``, two motors per
    leg) along the same stance history, maximized over G numerically, peaks at the closed form's
    ``G_w``."""
    r = selfmanip.leap("++", t2=0.0, gear_ratio=28.0, dt=5e-4)
    g_w = example.stance_work_optimal_ratio(r, omega_nl=OMEGA_NL)
    c = motor.torque_speed_curve("x-rhex-28", points=401)
    tr = r.trajectory
    t = tr.t_s

    def work(g):
        w = 0.0
        for leg, char in ((0, 1), (1, 3)):
            on = np.array([m[char] != "0" for m in tr.mode])
            u = np.maximum(tr.qd[:, leg], 0.0) * on
            tau = 2.0 * (g / 28.0) * np.interp(u * g / 28.0, c["speed_rad_s"], c["torque_n_m"])
            w += np.trapezoid(tau * u, t)
        return w

    gs = np.arange(15.0, 45.0, 0.01)
    ws = np.array([work(g) for g in gs])
    assert gs[int(np.argmax(ws))] == pytest.approx(g_w, abs=0.02)


def test_example_takeoff_speed_is_a_magnitude(example):
    """The example maximized a signed speed once and so reported the grid's edge for backward
    leaps. (-,-) at t2 = 0 leaps backward at every G: the largest signed x_dot is the slowest
    backward leap, at the lowest G of the grid; the example's take-off speed is |x_dot|, whose
    best lies inside the grid and is the fastest leap."""
    gears = np.arange(8.0, 60.5, 2.0)
    table = selfmanip.sweep("--", t2=0.0, gear_ratio=gears, threads=2)
    ok = table["flew"]
    xd = table["apex_xdot_m_s"][ok]
    assert (xd < 0).all(), "backward leaps"
    assert table["gear_ratio"][ok][int(np.argmax(xd))] == gears[0], "signed: the grid's edge"
    (row,) = example.best_gear_ratios(table, "takeoff_speed")
    assert not row["at_edge"] and row["value"] == pytest.approx(float(np.max(-xd)))
    assert row["value"] > 5.0 * abs(float(np.max(xd)))


def test_example_says_so_when_every_point_fails(example, tmp_path, capsys):
    """A gear-ratio sweep whose leaps all end before flight (t_final_s = 0.05 s) exits 1 with
    the failure named on stderr, and the CSV's ``error`` column gives every point's reason."""
    code = example.main(["--gears", "20:30:2", "--t2", "0,0.02", "--set", "t_final_s=0.05",
                         "--out-dir", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 1
    assert "error: all 16 points of the sweep failed (16 final_time)" in err
    lines = (tmp_path / "gear_ratio_sweep.csv").read_text().strip().splitlines()
    header = lines[0].split(",")
    k = header.index("error")
    assert len(lines) == 17 and all("t_final_s" in ln.split(",", k)[k] for ln in lines[1:])
