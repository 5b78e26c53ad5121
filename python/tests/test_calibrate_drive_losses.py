"""`selfmanip.calibrate` of the drive's loss options (issue 33): the gearbox efficiency η of
the leap's geared motor recovered from synthetic leaps generated at η = 0.7 (the catalog's is
0.82) with marker offsets of a few cm and motion-capture-sized noise, with the engine's
exact derivatives in η; an unidentifiable combination reported as such. The tables come from
`selfmanip.sweep` at the known values (another route than the fit's)."""

from __future__ import annotations

import numpy as np
import pytest

import selfmanip
from selfmanip.calibrate import DEFAULT_CHANNEL_SCALES, LeapModel, calibrate

ETA = 0.7
OFFSETS = {"apex_z_m": 0.03, "apex_x_m": -0.02}
MEASURED = ("apex_x_m", "apex_z_m", "apex_phi_rad", "apex_xdot_m_s", "apex_phidot_rad_s")
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


def noisy(table, seed):
    rng = np.random.default_rng(seed)
    out = dict(table)
    for c in MEASURED:
        out[c] = table[c] + rng.normal(0.0, DEFAULT_CHANNEL_SCALES[c], len(table[c]))
    return out


def test_the_efficiency_has_an_exact_derivative_and_a_default():
    model = LeapModel()
    assert "gearbox_efficiency" in model.exact and "battery_resistance_ohm" in model.exact
    # unset, the catalog gearbox's efficiency (x-rhex-28, Table 2.2) and an ideal supply
    assert model.parameters()["gearbox_efficiency"] == 0.82
    assert model.parameters()["battery_resistance_ohm"] == 0.0


@pytest.mark.xfail(strict=True, reason="open: measured 17 of 20 for eta and offset:apex_x_m, 19 for "
                   "offset:apex_z_m (16-18 with absolute_sigma): the intervals undercover on four leaps")
def test_eta_and_offsets_recovered_inside_95_percent_interval_in_19_of_20_draws(clean):
    truth = {"gearbox_efficiency": ETA, **{f"offset:{c}": v for c, v in OFFSETS.items()}}
    inside = {p: 0 for p in truth}
    for seed in range(20):
        fit = calibrate("leap", noisy(clean, seed), FIT, threads=2)
        assert not fit.identifiability.undetermined
        assert not fit.fd_rows  # every row differentiated exactly
        for p, v in truth.items():
            lo, hi = fit.intervals[p]
            inside[p] += lo <= v <= hi
    assert all(n >= 19 for n in inside.values()), inside


def test_one_channel_of_one_leap_cannot_separate_eta_from_the_offset(clean):
    one = {"strategy": clean["strategy"][:1], "t2_s": clean["t2_s"][:1], "apex_z_m": clean["apex_z_m"][:1]}
    fit = calibrate("leap", one, {"gearbox_efficiency": (0.4, 1.0), "offset:apex_z_m": (-0.1, 0.1)}, threads=2)
    assert len(fit.identifiability.undetermined) == 1
    assert np.isinf(fit.stderr["gearbox_efficiency"]) and np.isinf(fit.stderr["offset:apex_z_m"])
    assert "undetermined" in fit.report()
