"""The stiff switch, on by default (``simulate(..., stiff_switch=False)`` turns it off: RODAS4 on
stiff stretches, docs/decisions/2026-11-29-stiff-switch-to-rodas4.md) on a user's robot with
stiff servo damping on light shins: the run is the explicit run's to the tolerances (two
integrators, one motion), closes its energy balance, and a run made for derivatives keeps the
switch, its state Jacobian the explicit run's to the tolerances."""

import numpy as np
import pytest

import selfmanip

LINK = {"length_m": 0.15, "mass_kg": 0.1, "inertia_kg_m2": 1.875e-4}
SHIN = {"length_m": 0.15, "mass_kg": 0.002, "inertia_kg_m2": 2e-6}  # k_d / I = 2e5 /s


def _foot(g):
    return {"name": f"{g}_foot", "leg": g, "shape": {"kind": "point", "position_m": [0, 0.15]},
            "friction": {"kind": "sticking", "mu": 0.8}}


ROBOT = {"name": "bounder", "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.0267},
         "contacts": [_foot("front"), _foot("hind")],
         "legs": [{"name": n, "hip_m": [x, 0.0], "links": [dict(LINK), dict(SHIN)]}
                  for n, x in (("front", 0.2), ("hind", -0.2))]}
BEHAVIOUR = {"joints": [{"joint": j, "phases": [{"name": "h", "torque": {
    "kind": "servo", "target_rad": t, "kp_n_m_per_rad": 20.0, "kd_n_m_s_per_rad": 0.4}}]}
    for j, t in (("front[0]", 0.6), ("front[1]", -0.8), ("hind[0]", 0.6), ("hind[1]", -0.8))]}
Q0 = [0.5, -1.0, 0.5, -1.0, 0.0, -0.33, 0.0]


def _run(**options):
    return selfmanip.simulate(ROBOT, BEHAVIOUR, Q0, t_final=0.3, **options)


def test_the_switched_run_is_the_explicit_run_and_balances_its_energy():
    implicit, explicit = _run(), _run(stiff_switch=False)
    assert implicit.status == explicit.status == "final_time"
    assert implicit.word == explicit.word
    # both integrate one motion to rtol 5e-9: their end states agree far inside 1e-5
    np.testing.assert_allclose(implicit.q_end, explicit.q_end, atol=1e-5)
    np.testing.assert_allclose(implicit.qd_end, explicit.qd_end, atol=1e-4)
    for e in (implicit, explicit):
        assert abs(e.energy_report().residual_j) < 1e-6


def test_a_run_for_derivatives_keeps_the_switch():
    e, explicit = _run(sensitivity=True), _run(sensitivity=True, stiff_switch=False)
    assert e.status == explicit.status == "final_time"
    assert e.state_jacobian is not None and explicit.state_jacobian is not None
    # two integrations of one variational equation (RODAS4's tangent on the implicit steps,
    # DOPRI5's on the explicit run's): one derivative to well within issue 30's 1e-5
    scale = np.abs(explicit.state_jacobian).max()
    assert np.abs(e.state_jacobian - explicit.state_jacobian).max() < 1e-5 * scale


@pytest.mark.parametrize("bad", ["yes", 1.5])
def test_a_bad_switch_is_a_typed_error(bad):
    with pytest.raises((TypeError, ValueError)) as err:
        _run(stiff_switch=bad)
    assert "stiff_switch" in str(err.value)
