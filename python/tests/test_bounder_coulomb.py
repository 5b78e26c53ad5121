"""Issue 30 item 3: Coulomb sliding by default. The newcomer's bounder (issue appendix) with
its feet's kinetic coefficient given as 0.8 (what the default now is, ``mu_kinetic = mu``)
finishes its 20-point bound sweep -- no ``zeno``, every run a typed status -- and where its feet
slide the friction does work: the energy balance ``E1 - E0 = W + W_d + W_fr - L`` closes to
1e-6 J with ``W_fr < 0``. Frictionless sliding (Assumption 5.9) stays available as
``mu_kinetic = 0``."""

import json

import pytest

import selfmanip
from test_bounder_landing import Q0, bound, description


def robot(tmp_path, mu_kinetic):
    d = description()
    for c in d["contacts"]:
        if mu_kinetic is not None:
            c["friction"]["mu_kinetic"] = mu_kinetic
    path = tmp_path / "bounder.json"
    path.write_text(json.dumps(d))
    return selfmanip.Robot.from_file(path)


def test_the_default_kinetic_coefficient_is_the_static_one(tmp_path):
    """The same runs with ``mu_kinetic`` omitted and given as ``mu``: the same executions."""
    a = selfmanip.simulate(robot(tmp_path, None), bound(20.0), Q0, t_final=0.6)
    b = selfmanip.simulate(robot(tmp_path, 0.8), bound(20.0), Q0, t_final=0.6)
    assert a.status == b.status and a.word == b.word
    assert [ev["t_s"] for ev in a.events] == [ev["t_s"] for ev in b.events]


def test_coulomb_bound_sweep_finishes_and_friction_works(tmp_path):
    r = robot(tmp_path, 0.8)
    statuses, slid = [], 0
    for i in range(20):
        kp = 10.0 + 2.0 * i
        e = selfmanip.simulate(r, bound(kp), Q0, t_final=0.6)
        statuses.append(e.status)
        assert e.status == "final_time", (kp, e.status, e.reason)
        # the balance's residual is the integration error of the state: within 1e-6 J at the
        # default tolerances (docs/python-simulate.md)
        er = e.energy_report()
        assert abs(er.residual_j) < 1e-6, (kp, er)
        # friction takes energy, never gives it
        assert er.friction_work_j <= 1e-12, (kp, er)
        if er.friction_work_j < -1e-9:
            slid += 1
    assert "zeno" not in statuses
    assert slid > 0, "some run of the sweep slides its feet"


@pytest.mark.parametrize("mu_kinetic", [0.0])
def test_frictionless_sliding_does_no_friction_work(tmp_path, mu_kinetic):
    e = selfmanip.simulate(robot(tmp_path, mu_kinetic), bound(20.0), Q0, t_final=0.6)
    er = e.energy_report()
    assert er.friction_work_j == 0.0
    assert abs(er.residual_j) < 1e-6, er
