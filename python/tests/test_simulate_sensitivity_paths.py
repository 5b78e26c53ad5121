"""``simulate(..., sensitivity=True)`` on a jump of a user's robot (the hopper of
``examples/data/hopper.toml`` under ``hop.toml``, dropped 10 cm moving forward: touchdown, a
push ``t_compress`` after it, liftoff, the apex passed on the way, flight): the state Jacobian
through the apex and parameters by path (behaviour parameters and numbers, the body's mass),
against an independent route — central differences of whole runs (the start state, or the
field set by ``params=`` and the behaviour recompiled), Richardson-extrapolated — and the
honest flag of a path without an exact derivative."""
from __future__ import annotations


import numpy as np
import pytest

import selfmanip
from selfmanip.errors import InvalidInputError

from conftest import HOP, HOPPER, HOPPER_Q0 as Q0, HOPPER_QD0 as QD0, HOPPER_TIGHT as TIGHT
T_FINAL = 0.35   # the apex at 0.294 s passed, the next touchdown at 0.401 s not reached
KINDS = ["touchdown", "liftoff", "apex"]
# the body's rows: the massless leg's own coordinates follow their prescribed motion through
# a tracking loop that simulate's step control leaves out (its error is not bounded by rtol;
# crates/selfmanip-sim/tests/sensitivity_paths.rs puts it in and checks every row)
BODY = [2, 3, 4, 7, 8, 9]


def run(q0=Q0, qd0=QD0, **params: float) -> tuple[np.ndarray, np.ndarray]:
    e = selfmanip.simulate(HOPPER, HOP, q0, qd0, t_final=T_FINAL, params=params or None, **TIGHT)
    assert [ev["kind"] for ev in e.events] == KINDS, params
    return np.concatenate([e.q_end, e.qd_end]), np.array([ev["t_s"] for ev in e.events])


def richardson(f, h: float) -> np.ndarray:
    d = [(f(s) - f(-s)) / (2 * s) for s in (h, h / 2)]
    return (4 * d[1] - d[0]) / 3


def test_state_jacobian_through_a_passed_apex() -> None:
    e = selfmanip.simulate(HOPPER, HOP, Q0, QD0, t_final=T_FINAL, sensitivity=True, **TIGHT)
    assert [ev["kind"] for ev in e.events] == KINDS
    apex = e.events[2]
    assert apex["saltation_status"] == "defined"
    assert np.abs(apex["saltation"] - np.eye(10)).max() < 1e-12
    jac = e.state_jacobian
    assert jac is not None
    x0 = np.array(Q0 + QD0)
    for c in BODY:
        def at(h: float, c: int = c) -> np.ndarray:
            x = x0.copy()
            x[c] += h
            return run(list(x[:5]), list(x[5:]))[0]
        fd = richardson(at, 1e-6)
        scale = np.abs(fd[BODY]).max() + 1e-3
        assert np.abs(jac[BODY, c] - fd[BODY]).max() < 1e-5 * scale, (c, jac[:, c], fd)


CASES = {
    "parameters.kp_push": 45.0,
    "joints[1].phases[2].torque.kp_n_m_per_rad": 45.0,       # the formula "kp_push"
    "joints[1].phases[1].torque.kd_n_m_s_per_rad": 0.6,      # "kd_spring", stance only
    "joints[1].phases[2].start.delay_s": 0.05,               # the push's delay: a time event
    "body.mass_kg": 4.0,
}


def test_parameters_by_path_match_central_differences() -> None:
    names = list(CASES) + ["legs[0].hip_m[0]"]
    e = selfmanip.simulate(HOPPER, HOP, Q0, QD0, t_final=T_FINAL, sensitivity=True,
                           parameters=names, **TIGHT)
    assert e.parameter_reason is None
    jac = e.parameter_jacobian
    assert jac.shape == (10, len(names))
    assert list(e.parameter_not_differentiated) == ["legs[0].hip_m[0]"]
    assert np.isnan(jac[:, -1]).all()
    for k, (name, p) in enumerate(CASES.items()):
        grads = np.array([ev["parameter_time_gradient"][k] for ev in e.events])
        def at(h: float, name: str = name, p: float = p) -> np.ndarray:
            x, t = run(**{name: p + h})
            return np.concatenate([x[BODY], t])
        fd = richardson(at, 1e-4 * p)
        exact = np.concatenate([jac[BODY, k], grads])
        scale = np.abs(fd).max()
        assert np.abs(exact - fd).max() < 1e-5 * scale, (name, exact, fd)


def test_unknown_path_names_its_index() -> None:
    with pytest.raises(InvalidInputError) as err:
        selfmanip.simulate(HOPPER, HOP, Q0, QD0, t_final=0.2, sensitivity=True,
                           parameters=["body.mass_kg", "legs[0].wings"])
    assert err.value.field == "parameters[1]" and "legs[0].wings" in str(err.value)
