"""selfmanip.analysis: section 4.3's design analyses checked against closed forms re-derived
here (not against stored outputs), plus typed errors and the CLI. Each check prints or states
the thesis value next to ours."""

import json
import math
import tomllib

import numpy as np
import pytest

import selfmanip
from selfmanip import analysis, rhex

from conftest import QUADRUPED, REPO

DEG = math.pi / 180


def test_max_sensor_pitch_is_the_closed_form_of_result_b1():
    # thesis: arcsin((rho1 - rho_b)/(l1 + l2)) ~ 17 deg; ours: search over every mode
    p = rhex.default_params()
    want = math.asin((p["rho1"] - p["rho_b"]) / (p["l1"] + p["l2"]))
    assert analysis.max_sensor_pitch() == pytest.approx(want, abs=1e-7)
    assert math.degrees(want) == pytest.approx(17.02, abs=0.01)
    m = rhex.Model({"rho1": 0.2, "rho_b": 0.03, "l2": 0.18})
    want2 = math.asin((0.2 - 0.03) / (0.205 + 0.18))
    assert analysis.max_sensor_pitch(m, grid=48) == pytest.approx(want2, abs=1e-7)


def test_pitch_rate_gain_matches_4_59():
    # (4.59): (rho sin(u) - 2(l1+l2) cos(phi)) / (rho sin(u)), front rolling + rear body
    m = rhex.Model()
    p = m.params
    for t1 in (-1.2, -0.8, -0.4):
        pose = m.quasi_static_pose(t1, -2.5)
        u = t1 - pose["phi"]
        want = (p["rho1"] * math.sin(u) - 2 * (p["l1"] + p["l2"]) * math.cos(pose["phi"])) / (p["rho1"] * math.sin(u))
        assert analysis.pitch_rate_gain(t1, -2.5, m) == pytest.approx(want, rel=1e-9)


def test_holding_torque_by_virtual_work():
    # tau1 = m_b g dh/dtheta1 along the constrained motion (finite differences of the pose)
    m = rhex.Model({"leg_shape": "stick"})
    p = m.params
    for t1 in (-0.9, -0.3, 0.4):
        h = 1e-6
        dh = (m.quasi_static_pose(t1 + h, -2.5)["height_m"] - m.quasi_static_pose(t1 - h, -2.5)["height_m"]) / (2 * h)
        tau = analysis.holding_torque(t1, -2.5, m)["tau"]
        assert tau[0] == pytest.approx(p["m_b"] * p["g"] * dh, rel=1e-6, abs=1e-9)


def _xrhex_line(ratio):
    cat = tomllib.loads(selfmanip._native.motor_thesis_catalog_toml())
    mot = next(x for x in cat["motor"] if x["name"] == "x-rhex")
    eta = next(x for x in cat["gearbox"] if x["name"] == "x-rhex-28")["efficiency"]
    stall = 2 * ratio * eta * mot["torque_constant_n_m_per_a"] * mot["current_limit_a"]
    return stall, mot["no_load_speed_rad_s"] / ratio


@pytest.mark.parametrize("leg,factor", [("stick", 1.0), ("rolling", 0.5)])
def test_takeoff_speed_matches_4_65_and_4_66(leg, factor):
    # re-derived at mid-stance: factor*I x^2 + kb x - kc = 0 (thesis (4.65)/(4.66))
    p = rhex.default_params()
    stall, w0 = _xrhex_line(23.0)
    kg, kp = 1 / w0, stall * w0
    kb = p["l2"] * kg**2 * kp
    kc = kb * p["rho2"] / kg + p["rho2"] * p["g"] * p["I_b"]
    i = factor * p["I_b"]
    want = (-kb + math.sqrt(kb * kb + 4 * i * kc)) / (2 * i)
    got = analysis.takeoff_speed(0.0, 0.0, leg=leg)
    assert abs(got["xdot"]) == pytest.approx(want, rel=1e-8)
    assert got["tau"] == pytest.approx(stall * (1 - got["leg_rate"] / w0), rel=1e-9)


def test_result_c4_rolling_beats_stick_over_fig_4_10():
    # thesis: >= 0.6 m/s faster over Fig. 4.10's range; we check > 0 everywhere, and print
    d = analysis.fig_4_10(n=5)
    gap = d["rolling"] - d["stick"]
    assert np.all(gap > 0)
    print(f"C.4 min margin {gap.min():.3f} m/s (thesis 0.6)")


def _effectiveness(p, n_legs, hips):
    m_r = p["m_b"] * n_legs * p["m_l"] / (p["m_b"] + n_legs * p["m_l"])
    c2 = (p["rho1"] / 2) ** 2
    spread = sum(h * h for h in hips)
    return (n_legs * p["I_l"] + m_r * c2) / (p["I_b"] + n_legs * p["I_l"] + p["m_l"] * spread + m_r * c2)


def test_leg_effectiveness_matches_rederived_4_68():
    # thesis: 0.035 (model, six legs), 0.039 measured; ours (re-derived (4.68)) ~0.032
    p = dict(rhex.default_params(), m_l=0.126, I_l=0.00092)
    for pairs, hips in ((3, (0.205, 0.0, -0.205)), (2, (0.205, -0.205))):
        assert analysis.leg_effectiveness(pairs=pairs) == pytest.approx(_effectiveness(p, pairs, hips), rel=1e-9)
    # more than the naive 6 I_l / I_b, less than the thesis's 0.035
    eps = analysis.leg_effectiveness()
    assert 3 * p["I_l"] / p["I_b"] < eps < 0.035


def test_tail_effect_two_routes_agree_on_the_quadruped():
    out = analysis.tail_effect(QUADRUPED, [0.4, -0.8, -0.3, 0.7, 0, 0, 0], [0, 2], period_s=1.0, dt_s=2e-4)
    assert out["simulated"]["delta_phi"] == pytest.approx(out["momentum_delta_phi"], rel=2e-3)
    assert out["simulated"]["joint_travel"][0] == pytest.approx(2 * math.pi, abs=1e-3)


def test_reactive_stand_drives_both_costs_to_zero():
    for shape in ("stick", "half_circle"):
        tr = analysis.reactive_stand(seed=3, leg_shape=shape, steps=1500)
        assert np.all(np.diff(tr["delta"]) <= 1e-12 + 1e-9 * tr["delta"][:-1])
        assert tr["epsilon"][-1] < 1e-8 and tr["delta"][-1] < 1e-8
        assert np.abs(tr["tau"][-1]).max() < 1e-4


def test_splay_derivative_matches_4_61_for_a_point_mass():
    m = rhex.Model({"leg_shape": "stick", "I_b": 0.0})
    p = m.params
    tm, tau = 20 * DEG, 10.0
    want = -2 * p["rho1"] * tau * math.sin(tm) ** 2 / (p["l1"] ** 2 * math.cos(tm))
    assert analysis.splay_derivative(tm, tau, model=m) == pytest.approx(want, rel=1e-5)


def test_bad_input_is_typed():
    with pytest.raises(ValueError, match="pairs"):
        analysis.leg_effectiveness(pairs=4)
    with pytest.raises(TypeError, match="model"):
        analysis.max_sensor_pitch(model="rhex")
    with pytest.raises(ValueError, match="leg"):
        analysis.takeoff_speed(0.0, 0.0, leg="wheel")
    with pytest.raises(TypeError, match="theta1"):
        analysis.pitch_rate_gain("0.1")
    with pytest.raises(ValueError, match="m_l"):
        analysis.leg_effectiveness(rhex.Model())  # chapter-4 legs are massless
    with pytest.raises(ValueError, match="gear_ratio"):
        analysis.takeoff_speed(0.0, 0.0, gear_ratio=-1.0)
    with pytest.raises(ValueError, match="unknown figure"):
        from selfmanip import figures

        figures.plot_figure("fig9.9", "x.png")


def test_cli_analysis_and_plot(tmp_path, capsys):
    from selfmanip.cli import main

    assert main(["analysis", "fig4.10", "--n", "3"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0] == "theta2,phi,stick,rolling" and len(lines) == 1 + 9
    assert main(["plot", "fig9.9", "--out", str(tmp_path / "x.png")]) == 2
    pytest.importorskip("matplotlib")
    out = tmp_path / "f48.png"
    assert main(["plot", "fig4.8", "--out", str(out)]) == 0
    assert out.read_bytes()[:4] == b"\x89PNG"
