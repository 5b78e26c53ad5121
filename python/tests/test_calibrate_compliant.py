"""`selfmanip.calibrate` of a compliant C-leg's spring (issue 33: "a compliant leg of a stated
stiffness and damping"): ``leg_stiffness`` and ``leg_damping`` recovered from a noiseless
synthetic table of (+,+) leaps generated at a stated radial spring, with the engine's exact
derivatives in both. The table comes from `selfmanip.sweep` at the known values (another route
than the fit's); Rust's ``crates/rhex-model/tests/compliant_leap.rs`` checks the 95 %
intervals over noise draws."""

from __future__ import annotations

import numpy as np
import pytest

import selfmanip
from calibration_coverage import DRAWS, MEASURED, assert_nominal_coverage, noisy
from selfmanip.calibrate import LeapModel, calibrate

#: Stick legs with Table 4.2's pair mass on the hip link and pinned toes (what a compliant leg
#: is made of: docs/leap-model.md).
PARAMS = {"leg_shape": "stick", "m_l": 0.126, "I_l": 0.00092, "mu_front": None, "mu_middle": None,
          "mu_rear": None}
K, C = 2e4, 160.0
T2 = [0.01, 0.03, 0.05]
CHANNELS = ("apex_x_m", "apex_z_m", "apex_phi_rad")
FIT = {"leg_stiffness": (1e4, 4e4), "leg_damping": (80.0, 320.0)}


def _options(k, c):
    return {**PARAMS, "compliant_leg": {"stiffness_n_per_m": k, "damping_n_s_per_m": c}}


@pytest.fixture(scope="module")
def clean():
    t = selfmanip.sweep("++", t2=T2, params=PARAMS, control_free_joints=True, threads=2,
                        config={"compliant_leg": {"stiffness_n_per_m": K, "damping_n_s_per_m": C}})
    assert np.asarray(t["flew"], dtype=bool).all(), t["status"]
    return {"strategy": np.asarray(["++"] * len(T2)), "t2_s": np.asarray(T2),
            **{c: np.asarray(t[c]) for c in CHANNELS}}


def test_spring_parameters_read_from_the_option():
    p = LeapModel(_options(1e4, 50.0)).parameters()
    assert (p["leg_stiffness"], p["leg_damping"]) == (1e4, 50.0)
    assert {"leg_stiffness", "leg_damping"} <= set(LeapModel.exact)
    assert "leg_stiffness" not in LeapModel().parameters()  # a rigid leap has no spring


def test_stiffness_and_damping_recovered_from_a_noiseless_table(clean):
    fit = calibrate("leap", clean, FIT, options=_options(1.5e4, 120.0), threads=2)
    assert not fit.fd_rows  # every row differentiated exactly
    assert fit.params["leg_stiffness"] == pytest.approx(K, rel=1e-4)
    assert fit.params["leg_damping"] == pytest.approx(C, rel=1e-4)


@pytest.fixture(scope="module")
def clean_measured():
    t = selfmanip.sweep("++", t2=T2, params=PARAMS, control_free_joints=True, threads=2,
                        config={"compliant_leg": {"stiffness_n_per_m": K, "damping_n_s_per_m": C}})
    return {"strategy": np.asarray(["++"] * len(T2)), "t2_s": np.asarray(T2),
            **{c: np.asarray(t[c]) for c in MEASURED}}


def test_stiffness_and_damping_inside_95_percent_intervals_at_the_nominal_rate(clean_measured):
    """Motion-capture noise (the channel scales) on the five apex channels: the reported 95 %
    intervals cover the stated spring at the nominal rate over the noise draws."""
    fits = [calibrate("leap", noisy(clean_measured, seed), FIT, options=_options(1.5e4, 120.0), threads=2)
            for seed in range(DRAWS)]
    assert all(not f.fd_rows for f in fits)
    assert_nominal_coverage(fits, {"leg_stiffness": K, "leg_damping": C})
