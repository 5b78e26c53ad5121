"""`selfmanip.calibrate` of the drive's loss options (issue 33): the gearbox efficiency η of
the leap's geared motor recovered from synthetic leaps generated at η = 0.7 (the catalog's is
0.82) with marker offsets of a few cm and motion-capture-sized noise, with the engine's
exact derivatives in η; an unidentifiable combination reported as such. The tables come from
`selfmanip.sweep` at the known values (another route than the fit's)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import selfmanip
from calibration_coverage import ACCEPTED_MISSES, DRAWS, MEASURED, assert_nominal_coverage, noisy
from selfmanip.calibrate import LeapModel, calibrate

ETA = 0.7
OFFSETS = {"apex_z_m": 0.03, "apex_x_m": -0.02}
TRUTH = {"gearbox_efficiency": ETA, **{f"offset:{c}": v for c, v in OFFSETS.items()}}
FIT = {"gearbox_efficiency": (0.4, 1.0), "offset:apex_z_m": (-0.1, 0.1), "offset:apex_x_m": (-0.1, 0.1)}


@pytest.fixture(scope="module")
def clean():
    t2 = [-0.08, -0.03, 0.04, 0.09]
    t = selfmanip.sweep("--", t2=t2, gearbox_efficiency=ETA, control_free_joints=True, threads=2)
    assert np.asarray(t["flew"], dtype=bool).all(), t["status"]
    out = {"strategy": np.asarray(["--"] * len(t2)), "t2_s": np.asarray(t2)}
    for c in MEASURED:
        out[c] = np.asarray(t[c]) + OFFSETS.get(c, 0.0)
    return out



def test_the_efficiency_has_an_exact_derivative_and_a_default():
    model = LeapModel()
    assert "gearbox_efficiency" in model.exact and "battery_resistance_ohm" in model.exact
    # unset, the catalog gearbox's efficiency (x-rhex-28, Table 2.2) and an ideal supply
    assert model.parameters()["gearbox_efficiency"] == 0.82
    assert model.parameters()["battery_resistance_ohm"] == 0.0


@pytest.fixture(scope="module")
def draws(clean):
    return [calibrate("leap", noisy(clean, seed), FIT, threads=2) for seed in range(DRAWS)]


def test_eta_and_offsets_recovered_inside_95_percent_interval_at_the_nominal_rate(draws):
    # seeds 0–19 alone give 17, 19 and 17 of 20, seeds 20–39 give 19, 20 and 19 (see
    # calibration_coverage: twenty draws cannot show 95 %); standard errors 20 % too small (or
    # 60 % too large) fail the check on these draws
    assert all(not fit.fd_rows for fit in draws)  # every row differentiated exactly
    assert draws[0].dof == 4 * len(MEASURED) - len(TRUTH)
    assert_nominal_coverage(draws, TRUTH)


#: The two-sided 95 % point of the standard normal distribution.
Z_975 = 1.959963984540054


def test_with_known_noise_the_intervals_use_the_normal_quantile(clean, draws):
    # absolute_sigma (the scales are the noise's standard deviations, as here): the same
    # estimate, the covariance without the residual variance factor, θ̂ ± 1.96 σ_θ
    for seed in (0, 1):
        rel = draws[seed]
        known = calibrate("leap", noisy(clean, seed), FIT, absolute_sigma=True, threads=2)
        assert known.sigma2 == 1.0
        for p in TRUTH:
            assert known.params[p] == rel.params[p]
            assert known.stderr[p] == pytest.approx(rel.stderr[p] / math.sqrt(rel.sigma2), rel=1e-9)
            assert known.intervals[p] == pytest.approx((known.params[p] - Z_975 * known.stderr[p],
                                                        known.params[p] + Z_975 * known.stderr[p]), rel=1e-12)
    # these intervals miss at the nominal rate too (Student t's 2.11 σ_θ would cover 96.5 %)
    misses = {p: sum(abs(f.params[p] - v) > Z_975 * f.stderr[p] / math.sqrt(f.sigma2) for f in draws)
              for p, v in TRUTH.items()}
    print(f"\nmisses of the 95 % intervals with known noise in {DRAWS} draws: {misses}")
    assert all(ACCEPTED_MISSES[0] <= n <= ACCEPTED_MISSES[1] for n in misses.values()), misses


def test_one_channel_of_one_leap_cannot_separate_eta_from_the_offset(clean):
    one = {"strategy": clean["strategy"][:1], "t2_s": clean["t2_s"][:1], "apex_z_m": clean["apex_z_m"][:1]}
    fit = calibrate("leap", one, {"gearbox_efficiency": (0.4, 1.0), "offset:apex_z_m": (-0.1, 0.1)}, threads=2)
    assert len(fit.identifiability.undetermined) == 1
    assert np.isinf(fit.stderr["gearbox_efficiency"]) and np.isinf(fit.stderr["offset:apex_z_m"])
    assert "undetermined" in fit.report()
