"""``simulate(..., sensitivity=True, parameters=[...])``: the final state's derivatives with
respect to a behaviour's named parameters, against central differences of whole runs with the
parameter set by ``params=`` (an independent route: the behaviour recompiled at ``p +- h``),
and a typed error naming an unknown parameter."""
from __future__ import annotations


import numpy as np
import pytest

import selfmanip
from selfmanip.errors import InvalidInputError, InvalidTypeError

from conftest import HOP, HOPPER, HOPPER_Q0 as Q0, HOPPER_QD0 as QD0, HOPPER_TIGHT as TIGHT
VALUES = {"kp_push": 45.0, "t_compress": 0.05, "kp_spring": 60.0}


def end_state(t_final: float, **params: float) -> tuple[np.ndarray, list[str]]:
    e = selfmanip.simulate(HOPPER, HOP, Q0, QD0, t_final=t_final, params=params, **TIGHT)
    return np.concatenate([e.q_end, e.qd_end]), [ev["kind"] for ev in e.events]


def test_parameter_jacobian_matches_central_differences() -> None:
    # through the touchdown, the push t_compress after it and the liftoff, once the legs'
    # swings after the liftoff are over (before the apex)
    tf = 0.28
    names = list(VALUES)
    e = selfmanip.simulate(HOPPER, HOP, Q0, QD0, t_final=tf, sensitivity=True, parameters=names,
                           **TIGHT)
    kinds = [ev["kind"] for ev in e.events]
    assert kinds == ["touchdown", "liftoff"]
    assert e.parameters == names and e.parameter_reason is None
    jac = e.parameter_jacobian
    assert jac.shape == (2 * len(Q0), len(names))
    assert all(ev["parameter_time_gradient"].shape == (len(names),) for ev in e.events)
    for k, name in enumerate(names):
        p = VALUES[name]
        h = 1e-3 * abs(p)
        cols = []
        for step in (h, h / 2):
            (xp, kp), (xm, km) = end_state(tf, **{name: p + step}), end_state(tf, **{name: p - step})
            assert kp == kinds and km == kinds
            cols.append((xp - xm) / (2 * step))
        fd = (4 * cols[1] - cols[0]) / 3   # Richardson: the differences' h^2 term removed
        # the body's rows: the massless leg's own coordinates follow their prescribed motion
        # through a tracking loop that simulate's step control leaves out (its error, ~1e-7
        # rad/s here, is not bounded by rtol; the Rust test puts it in and checks every row)
        body = [2, 3, 4, 7, 8, 9]
        scale = np.abs(fd[body]).max() + 1e-3
        assert np.abs(jac[body, k] - fd[body]).max() < 1e-5 * scale, (name, jac[:, k], fd)


def test_unknown_parameter_is_a_typed_error_naming_it() -> None:
    with pytest.raises(InvalidInputError) as err:
        selfmanip.simulate(HOPPER, HOP, Q0, QD0, t_final=0.2, sensitivity=True,
                           parameters=["kp_push", "kp_pushh"])
    assert err.value.field == "parameters[1]" and "kp_pushh" in str(err.value)
    with pytest.raises(InvalidInputError) as err:
        selfmanip.simulate(HOPPER, HOP, Q0, QD0, t_final=0.2, parameters=["kp_push"])
    assert err.value.field == "parameters"
    with pytest.raises(InvalidTypeError):
        selfmanip.simulate(HOPPER, HOP, Q0, QD0, t_final=0.2, sensitivity=True, parameters="kp_push")
