"""Python-side checks of the chapter-4/5 dynamics; every expected number comes from a second
route (numpy re-assembly, closed forms of the thesis, finite differences)."""

import math

import numpy as np
import pytest

from conftest import gravity_by_finite_differences, standing_q


def test_default_model_is_chapter_4(rhex):
    p = rhex.params
    assert p["m_l"] == 0.0 and p["I_l"] == 0.0, "massless legs per C.6"
    assert p["leg_shape"] == "half_circle" and p["pairs"] == ["front", "rear"]
    assert rhex.nq == 5 and rhex.contact_names == ["front_leg", "rear_leg", "front_body", "rear_body"]
    assert len(rhex.labels()) == 16


@pytest.mark.parametrize("model", ["rhex", "rhex_massive"])
@pytest.mark.parametrize("mode", ["0101", "0100", "0001", "1001", "0110", "1010", "0s01", "010s", "0000"])
def test_equations_of_motion_residual_at_rest(model, mode, request):
    """M q'' + N + A^T lam = Upsilon and A q'' = 0 (5.3)-(5.4) at q' = 0, with N from finite
    differences of the potential energy (not the engine's N)."""
    robot = request.getfixturevalue(model)
    q = [0.35, -0.25, 0.01, -0.15, 0.06]
    tau = [2.0, -3.0]
    d = robot.dynamics(mode, q, [0.0] * 5, tau)
    k = robot.kkt(mode, q)
    upsilon = np.array(tau + [0.0, 0.0, 0.0])
    n = gravity_by_finite_differences(robot, q)
    dyn = k.dynamic_coords
    residual = k.M @ d.qdd + n + k.A.T @ d.lam - upsilon
    assert np.allclose(residual[dyn], 0.0, atol=1e-6 * (1 + np.abs(upsilon).max() + np.abs(n).max()))
    if len(d.lam):
        assert np.allclose(k.A @ d.qdd, 0.0, atol=1e-10)
    # free massless joints report the prescribed acceleration (0 by default)
    for j in d.free_joints:
        assert d.qdd[j] == 0.0


def test_kkt_blocks_invert_the_kkt_matrix(rhex_massive):
    """[[M, A^T], [A, 0]] [[M+, A+^T], [A+, Lambda]] = I (5.2), checked with numpy."""
    q = [0.3, -0.2, 0.0, -0.16, 0.04]
    for mode in ["0101", "0100", "1001", "0s01"]:
        md, ad, lam, a = rhex_massive.kkt(mode, q)
        m = rhex_massive.kkt(mode, q).M
        c = a.shape[0]
        kkt = np.block([[m, a.T], [a, np.zeros((c, c))]])
        inv = np.block([[md, ad.T], [ad, lam]])
        assert np.allclose(kkt @ inv, np.eye(5 + c), atol=1e-9)
        # Lambda = -(A M^-1 A^T)^-1 (negative definite; the thesis text says positive)
        assert np.allclose(lam, -np.linalg.inv(a @ np.linalg.solve(m, a.T)), rtol=1e-9, atol=1e-12)
        assert np.all(np.linalg.eigvalsh(lam) < 0)


def test_lemma_5_2_classical_formula_with_massive_legs(rhex_massive):
    """With M invertible, (5.3)-(5.4) equal the classical (5.8)-(5.9)."""
    rng = np.random.default_rng(7)
    for _ in range(10):
        q = [rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 0.0, -0.15, rng.uniform(-0.1, 0.1)]
        tau = list(rng.uniform(-5, 5, 2))
        d = rhex_massive.dynamics("0101", q, [0.0] * 5, tau)
        k = rhex_massive.kkt("0101", q)
        f = np.array(tau + [0.0] * 3) - gravity_by_finite_differences(rhex_massive, q)
        minv_f = np.linalg.solve(k.M, f)
        lam = np.linalg.solve(k.A @ np.linalg.solve(k.M, k.A.T), k.A @ minv_f)
        qdd = minv_f - np.linalg.solve(k.M, k.A.T @ lam)
        assert np.allclose(d.lam, lam, rtol=1e-6, atol=1e-6)
        assert np.allclose(d.qdd, qdd, rtol=1e-6, atol=1e-6)


def test_flight_is_free_fall(rhex, rhex_massive):
    """In flight the body falls at g (z down: z'' = +g) and does not rotate with zero torque."""
    q = [0.3, -1.0, 0.0, -0.5, 0.2]
    for robot in (rhex, rhex_massive):
        d = robot.dynamics("0000", q, [0.0] * 5, [0.0, 0.0])
        assert d.lam.size == 0
        assert d.qdd[3] == pytest.approx(9.81, rel=1e-12)
        assert d.qdd[2] == pytest.approx(0.0, abs=1e-12)
    # massless legs have no dynamics in flight: both joints are free and prescribed
    d = rhex.dynamics("0000", q, [0.0] * 5, [0.0, 0.0], free_joint_qdd=[1.5, -2.0])
    assert d.free_joints == [0, 1]
    assert list(d.qdd[:2]) == [1.5, -2.0]
    assert d.qdd[4] == pytest.approx(0.0, abs=1e-12)


def test_result_c1_rear_minus_front_push(rhex):
    """Result C.1 (4.60): symmetric stance, rear minus front toe normal push = 2 tau / l."""
    l = rhex.params["l1"]
    for theta in (0.1, 0.4, 0.7):
        for tau in (1.0, 4.0, 8.0):
            d = rhex.dynamics("0101", standing_q(theta, theta), [0.0] * 5, [tau, tau])
            front_n, rear_n = d.lam[1], d.lam[3]
            assert (-rear_n) - (-front_n) == pytest.approx(2 * tau / l, rel=1e-9)


def test_plastic_impact_conserves_momentum_and_loses_energy(rhex_massive):
    """M (q'+ - q'-) = -A^T P and A q'+ = 0 (5.10); kinetic energy never increases."""
    q = standing_q(0.2, 0.2)
    rng = np.random.default_rng(3)
    for _ in range(10):
        qd = rng.normal(size=5)
        imp = rhex_massive.impact("0101", q, qd)
        k = rhex_massive.kkt("0101", q)
        assert np.allclose(k.A @ imp.qd_plus, 0.0, atol=1e-12)
        assert np.allclose(k.M @ (imp.qd_plus - qd), -k.A.T @ imp.impulse, atol=1e-10)
        assert rhex_massive.energy(q, imp.qd_plus)[0] <= rhex_massive.energy(q, qd)[0] + 1e-12


def test_contact_gaps_are_touchdown_guards(rhex):
    """Standing on both toes with a level body: toe gaps 0, body ends at rho - rho_b above."""
    p = rhex.params
    gaps = rhex.contact_gaps(standing_q(0.3, 0.3))
    assert gaps["front_leg"] == pytest.approx(0.0, abs=1e-12)
    assert gaps["rear_leg"] == pytest.approx(0.0, abs=1e-12)
    h = p["rho1"] * math.cos(0.3)
    assert gaps["front_body"] == pytest.approx(h - p["rho_b"], abs=1e-12)


def test_quasi_static_pose_and_result_b1(rhex):
    """Legs straight down: level body at height rho. Over the torus the pitch never exceeds
    Result B.1's arcsin((rho - rho_b) / 2l) and comes within a grid step of it."""
    p = rhex.params
    pose = rhex.quasi_static_pose(0.0, 0.0)
    assert pose["phi"] == pytest.approx(0.0, abs=1e-12)
    assert pose["height_m"] == pytest.approx(p["rho1"], abs=1e-12)
    assert pose["label"] == "0101"
    n = 48
    cm = rhex.contact_mode_map(n)
    bound = math.asin((p["rho1"] - p["rho_b"]) / (p["l1"] + p["l2"]))
    assert np.nanmax(cm.phi) <= bound + 1e-9
    assert np.nanmax(cm.phi) > bound - 2 * math.pi / n


def test_quasi_static_internal_force_is_ker_grasp_map(rhex):
    """(4.22): internal forces lie in ker G_s; the particular solution balances gravity."""
    q = standing_q(0.3, 0.3)
    qs = rhex.quasi_static("0101", q, torque_constraints=[[1.0, -1.0]])
    assert qs.internal_basis.shape == (4, 1)
    assert np.allclose(qs.G_s @ qs.internal_basis, 0.0, atol=1e-12)
    # G_s f = -F_g: the ground pushes the robot up with its whole weight
    assert np.allclose(qs.G_s @ qs.f_particular, -np.array(qs.gravity_wrench), atol=1e-9)
    assert qs.tau_particular[0] == pytest.approx(qs.tau_particular[1], abs=1e-9)
