"""Apex sensitivities from Python (issue 18's contract): ``selfmanip.leap(...,
sensitivities=[...])``, the sweep's ``d_<apex column>/d_<name>`` columns and
``sensitivity_ok``, the CLI's ``--sensitivities``. The derivatives are checked against central
differences of whole leaps (the independent route; the Rust tests in
``tests/leap_sensitivity.rs`` do it for every parameter and strategy to 1e-5), and the sweep's
columns against single leaps (the same numbers, bit for bit)."""
import math

import numpy as np
import pytest

import selfmanip
from selfmanip import cli
from selfmanip.cli_leap import read_table

APEX = ("apex_t_s", "apex_x_m", "apex_z_m", "apex_phi_rad", "apex_xdot_m_s", "apex_zdot_m_s",
        "apex_phidot_rad_s")
# tolerances tight enough for central differences to resolve 1e-5 (see the Rust tests)
TIGHT = dict(rtol=1e-12, event_tol_s=1e-14, control_free_joints=True)


def test_leap_sensitivity_mapping_and_saltations():
    r = selfmanip.leap("++", t2=0.05, dt=None, sensitivities=["t2", "gear_ratio", "m_b"])
    assert r.sensitivity_ok, r.sensitivity_reason
    assert set(r.sensitivity) == {(c, p) for c in APEX for p in ("t2", "gear_ratio", "m_b")}
    assert all(math.isfinite(v) for v in r.sensitivity.values())
    # the apex is where ż = 0: its derivative vanishes
    assert r.sensitivity[("apex_zdot_m_s", "t2")] == 0.0
    n = 2 * len(r.q0)
    for e in r.events:
        assert e["saltation"].shape == (n, n), e
    # without sensitivities: no saltations, no mapping; the leap with sensitivities is the
    # one run with the free legs under step control (the engine sets it on that path)
    plain = selfmanip.leap("++", t2=0.05, dt=None, control_free_joints=True)
    assert plain.sensitivity is None and "saltation" not in plain.events[0]
    assert plain.apex == r.apex and plain.word == r.word
    assert selfmanip.leap("++", t2=0.05, dt=None, control_free_joints=True,
                          sensitivities=["t2"]).apex == r.apex
    assert "d_apex_z_m/d_t2" in r.to_dict()["sensitivity"]


@pytest.mark.parametrize("name,h", [("t2", 1e-6), ("m_b", 7e-4)])
def test_leap_sensitivity_against_central_differences(name, h):
    r = selfmanip.leap("+-", t2=0.05, dt=None, sensitivities=[name], **TIGHT)
    assert r.sensitivity_ok, r.sensitivity_reason

    def apex(delta):
        if name == "t2":
            a = selfmanip.leap("+-", t2=0.05 + delta, dt=None, **TIGHT).apex
        else:
            m_b = selfmanip.leap.defaults()["params"]["m_b"]
            a = selfmanip.leap("+-", t2=0.05, dt=None, params={"m_b": m_b + delta}, **TIGHT).apex
        return np.array([a.t_s, a.x_m, a.z_m, a.phi_rad, a.xdot_m_s, a.zdot_m_s, a.phidot_rad_s])

    fd = (apex(h) - apex(-h)) / (2 * h)
    d = np.array([r.sensitivity[(c, name)] for c in APEX])
    scale = np.max(np.abs(fd))
    assert np.max(np.abs(d - fd)) <= 1e-5 * scale, (d, fd)


def test_sweep_columns_equal_single_leaps_and_are_deterministic():
    names = ["t2", "gear_ratio"]
    t2 = [0.0, 0.05, 0.1]
    tables = [selfmanip.sweep(["++", "-+"], t2=t2, threads=k, sensitivities=names) for k in (1, 2)]
    a, b = tables
    for c in APEX:
        for p in names:
            key = f"d_{c}/d_{p}"
            assert a[key].dtype == float
            assert np.array_equal(a[key], b[key], equal_nan=True), key
    assert a["sensitivity_ok"].dtype == bool and np.array_equal(a["sensitivity_ok"], b["sensitivity_ok"])
    for i, (s, t) in enumerate(zip(a["strategy"], a["t2_s"])):
        r = selfmanip.leap(str(s), t2=float(t), dt=None, sensitivities=names)
        assert a["sensitivity_ok"][i] == r.sensitivity_ok
        for c in APEX:
            for p in names:
                v = a[f"d_{c}/d_{p}"][i]
                assert (math.isnan(v) and math.isnan(r.sensitivity[(c, p)])) or v == r.sensitivity[(c, p)]
    # t2 = 0: both legs touch down at once, the mode sequence changes either side: flagged
    i0 = [i for i, t in enumerate(a["t2_s"]) if t == 0.0]
    assert not a["sensitivity_ok"][i0].any()
    assert np.isnan(a["d_apex_z_m/d_t2"][i0]).all()
    assert a["sensitivity_ok"].any()
    # the sweep's other columns are those of the leaps with the free legs under step control
    plain = selfmanip.sweep(["++", "-+"], t2=t2, threads=2, config={"control_free_joints": True})
    for k in plain:
        assert np.array_equal(plain[k], a[k]) if plain[k].dtype.kind in "US" else \
            np.array_equal(plain[k], a[k], equal_nan=True), k


def test_unknown_parameter_names_raise_naming_them():
    with pytest.raises(ValueError, match="m_x") as e:
        selfmanip.leap("++", t2=0.05, dt=None, sensitivities=["t2", "m_x"])
    assert e.value.field == "m_x"
    with pytest.raises(ValueError, match="m_x"):
        selfmanip.sweep("++", t2=0.05, sensitivities=["m_x"])
    # a point whose actuator has no gear ratio fails alone, naming the field (a sweep never
    # loses its other points)
    with pytest.warns(selfmanip.errors.AllPointsFailedWarning):
        t = selfmanip.sweep("++", t2=0.05, gear_ratio=None, sensitivities=["gear_ratio"])
    assert t["status"][0] == "invalid_params" and "gear_ratio" in t["error"][0]
    assert not t["sensitivity_ok"][0] and math.isnan(t["d_apex_z_m/d_gear_ratio"][0])
    with pytest.raises(TypeError, match="sensitivities"):
        selfmanip.leap("++", dt=None, sensitivities="t2")


def test_cli_sweep_sensitivities(tmp_path):
    out = tmp_path / "s.csv"
    assert cli.main(["sweep", "--t2", "0.05,0.1", "--sensitivities", "t2,gear_ratio", "--progress", "never",
                     "--out", str(out)]) == 0
    got = read_table(str(out))
    want = selfmanip.sweep("++", t2=[0.05, 0.1], sensitivities=["t2", "gear_ratio"])
    for c in APEX:
        for p in ("t2", "gear_ratio"):
            k = f"d_{c}/d_{p}"
            assert np.allclose(got[k], want[k], rtol=1e-12, equal_nan=True), k
    assert [str(x) for x in got["sensitivity_ok"]] in (["True", "True"], [True, True], ["true", "true"])
