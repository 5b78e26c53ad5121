"""`selfmanip.calibrate` of the rear toes' friction coefficient (issue 33: "toe friction μ …
as parameters"): ``mu_rear`` recovered from synthetic (+,−) leaps generated at μ = 2.0 (the
default is 2.5) with motion-capture-sized noise, with the engine's exact derivatives in μ (the
static coefficient and, with Coulomb toes, the kinetic one with it). The tables come from
`selfmanip.sweep` at the known value (another route than the fit's)."""

from __future__ import annotations

import numpy as np
import pytest

import selfmanip
from calibration_coverage import DRAWS, MEASURED, assert_nominal_coverage, noisy
from selfmanip.calibrate import LeapModel, calibrate

MU = 2.0
TRUTH = {"mu_rear": MU}
FIT = {"mu_rear": (1.0, 4.0)}
T2 = [0.03, 0.05, 0.08, 0.1]


@pytest.fixture(scope="module")
def clean():
    t = selfmanip.sweep("+-", t2=T2, mu_rear=MU, control_free_joints=True, threads=2)
    assert np.asarray(t["flew"], dtype=bool).all(), t["status"]
    out = {"strategy": np.asarray(["+-"] * len(T2)), "t2_s": np.asarray(T2)}
    for c in MEASURED:
        out[c] = np.asarray(t[c])
    return out



def test_mu_rear_has_an_exact_derivative():
    assert {"mu_front", "mu_middle", "mu_rear"} <= set(LeapModel.exact)
    assert LeapModel().parameters()["mu_rear"] == 2.5


@pytest.fixture(scope="module")
def draws(clean):
    return [calibrate("leap", noisy(clean, seed), FIT, threads=2) for seed in range(DRAWS)]


def test_mu_rear_recovered_inside_95_percent_interval_at_the_nominal_rate(draws):
    assert all(not fit.fd_rows for fit in draws)  # every row differentiated exactly
    assert all(abs(f.params["mu_rear"] - MU) < 0.5 for f in draws)
    assert_nominal_coverage(draws, TRUTH)
