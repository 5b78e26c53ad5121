"""``simulate(..., sensitivity=True, parameters=[...])`` in a contact's friction coefficients
through the bindings: the newcomer's bounder (issue 30) dropped pitched at 1 m/s, its hind
foot landing sliding, sticking, slipping (the slip guard ``|λ_t| = μ(−λ_n)``) and sliding on
the cone's edge (Coulomb) to 0.09 s, against Richardson central differences of whole runs
with the coefficient set by ``params=``; and the pseudo-impulse's ``delta_t_s``, whose column
is zero (it selects the impact's mode only) as the differences are."""
from __future__ import annotations

import json

import numpy as np
import pytest

import selfmanip

LINK = {"length_m": 0.15, "mass_kg": 0.1, "inertia_kg_m2": 1.875e-4}
Q0 = [0.5, -1.0, 0.5, -1.0, 0.0, -0.30, 0.1]
QD0 = [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]
# every component to the same absolute tolerance: differences of whole runs resolve a
# derivative no better than each run's error
TIGHT = dict(rtol=1e-12, event_tol_s=1e-14, velocity_tolerance="uniform")
KINDS = ["touchdown", "stick", "slip"]
T_FINAL = 0.09
MU = 0.4


def foot(leg):
    return {"name": f"{leg}_foot", "leg": leg, "shape": {"kind": "point", "position_m": [0, 0.15]},
            "friction": {"kind": "sticking", "mu": MU}}


SERVO = {"kind": "servo", "kp_n_m_per_rad": 30.0, "kd_n_m_s_per_rad": 0.5}
BEHAVIOUR = {"joints": [{"joint": j, "phases": [{"name": "h", "torque": dict(SERVO, target_rad=t)}]}
                        for j, t in (("front[0]", 0.5), ("front[1]", -1.0), ("hind[0]", 0.5), ("hind[1]", -1.0))]}


@pytest.fixture(scope="module")
def bounder(tmp_path_factory):
    d = {"name": "bounder", "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.0267},
         "contacts": [foot("front"), foot("hind")],
         "legs": [{"name": n, "hip_m": [x, 0.0], "links": [dict(LINK), dict(LINK)]}
                  for n, x in (("front", 0.2), ("hind", -0.2))]}
    path = tmp_path_factory.mktemp("bounder") / "bounder.json"
    path.write_text(json.dumps(d))
    return selfmanip.Robot.from_file(path)


def run(robot, **params):
    e = selfmanip.simulate(robot, BEHAVIOUR, Q0, QD0, t_final=T_FINAL, params=params or None, **TIGHT)
    assert [ev["kind"] for ev in e.events] == KINDS, params
    return np.concatenate([e.q_end, e.qd_end, [ev["t_s"] for ev in e.events]])


def richardson(f, h):
    d = [(f(s) - f(-s)) / (2 * s) for s in (h, h / 2)]
    return (4 * d[1] - d[0]) / 3


def test_the_sliding_foots_friction_matches_central_differences(bounder):
    name = "contacts.hind_foot.friction.mu"
    e = selfmanip.simulate(bounder, BEHAVIOUR, Q0, QD0, t_final=T_FINAL, sensitivity=True,
                           parameters=[name], **TIGHT)
    assert [ev["kind"] for ev in e.events] == KINDS
    assert e.parameter_reason is None and not e.parameter_not_differentiated
    exact = np.concatenate([e.parameter_jacobian[:, 0],
                            [ev["parameter_time_gradient"][0] for ev in e.events]])
    fd = richardson(lambda h: run(bounder, **{name: MU + h}), 1e-4 * MU)
    scale = np.abs(fd).max()
    assert scale > 1e-2
    assert np.abs(exact - fd).max() < 1e-5 * scale, (exact, fd)


def test_the_pseudo_impulse_duration_has_a_zero_column(bounder):
    e = selfmanip.simulate(bounder, BEHAVIOUR, Q0, QD0, t_final=T_FINAL, sensitivity=True,
                           parameters=["options.delta_t_s"], delta_t_s=0.01, **TIGHT)
    assert e.parameter_reason is None and not e.parameter_not_differentiated
    assert (e.parameter_jacobian[:, 0] == 0.0).all()
    a = selfmanip.simulate(bounder, BEHAVIOUR, Q0, QD0, t_final=T_FINAL, delta_t_s=0.01 + 1e-6, **TIGHT)
    b = selfmanip.simulate(bounder, BEHAVIOUR, Q0, QD0, t_final=T_FINAL, delta_t_s=0.01 - 1e-6, **TIGHT)
    assert list(a.q_end) == list(b.q_end) and list(a.qd_end) == list(b.qd_end)
    zero = selfmanip.simulate(bounder, BEHAVIOUR, Q0, QD0, t_final=T_FINAL, sensitivity=True,
                              parameters=["options.delta_t_s"], **TIGHT)
    assert list(zero.parameter_not_differentiated) == ["options.delta_t_s"]
