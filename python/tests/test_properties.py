"""Hypothesis: leaps over random valid parameters raise nothing but the documented
``SelfmanipError`` (a ``ValueError``), report a known status, and when the leap flew
reach an apex no lower than where the body started, with the word running from rest (1010)
to flight (0000); a sweep over the same random points agrees with the leaps one by one."""

import math

import numpy as np
import pytest

import selfmanip

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

STATUSES = {"apex", "final_time", "zeno", "event_budget", "no_contact_solution", "several_contact_solutions",
            "terrain_discontinuity", "singular_flow"}

point = st.fixed_dictionaries({
    "strategy": st.sampled_from(["++", "+-", "-+", "--"]),
    "t2": st.floats(-0.2, 0.2),
    "gear_ratio": st.one_of(st.none(), st.floats(12.0, 45.0)),
    "params": st.fixed_dictionaries({
        "m_b": st.floats(5.0, 12.0),
        "I_b": st.floats(0.08, 0.2),
        "mu_rear": st.floats(0.6, 3.0),
        "mu_middle": st.floats(0.6, 3.0),
        "leg_shape": st.sampled_from(["half_circle", "stick"]),
    }),
    "delta_t_s": st.sampled_from([0.0, 0.01, 0.03]),
})

SETTINGS = settings(max_examples=25, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(point)
def test_random_valid_leaps(p):
    try:
        r = selfmanip.leap(p["strategy"], p["t2"], p["gear_ratio"], p["params"], dt=None, delta_t_s=p["delta_t_s"])
    except selfmanip.SelfmanipError:
        return  # documented: an engine failure names its reason
    assert r.status in STATUSES
    assert r.cells[0] == "1010"
    assert r.flew == (r.status == "apex")  # stopping at the apex
    if r.flew:
        start_height = -r.q0[r.q_names.index("z")]
        assert r.apex is not None and r.apex.z_m >= start_height - 1e-9
        assert r.cells[-1] == "0000"
        assert all(math.isfinite(v) for v in r.apex.__dict__.values())


@settings(max_examples=5, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(point, min_size=2, max_size=6))
def test_sweep_agrees_with_single_leaps(points):
    cols = dict(strategy=[p["strategy"] for p in points], t2=[p["t2"] for p in points],
                gear_ratio=[p["gear_ratio"] or 28.0 for p in points],
                m_b=[p["params"]["m_b"] for p in points], leg_shape=[p["params"]["leg_shape"] for p in points])
    table = selfmanip.sweep(**cols, grid=False, threads=2)
    for i in range(len(points)):
        try:
            r = selfmanip.leap(cols["strategy"][i], cols["t2"][i], cols["gear_ratio"][i],
                               {"m_b": cols["m_b"][i], "leg_shape": cols["leg_shape"][i]}, dt=None)
        except selfmanip.SelfmanipError as e:
            assert table["error"][i] == str(e)
            continue
        assert (table["status"][i], table["word"][i]) == (r.status, r.word)
        z = np.nan if r.apex is None else r.apex.z_m
        assert np.array_equal(table["apex_z_m"][i], z, equal_nan=True)
