"""``simulate(..., sensitivity=True, parameters=[...])`` in a link's mass, inertia and centre of
mass through the bindings: the quadruped of ``examples/data/quadruped.toml`` (massive thighs
and shanks) thrown up, passing its apex, landing hind foot then fore foot (plastic impacts),
slipping and lifting off, against Richardson central differences of whole runs with the field
set by ``params=`` to ``p ± h``; a link mass of 0 and a link's length flagged with their
reasons (NaN columns)."""
from __future__ import annotations

import math

import numpy as np

import selfmanip

from conftest import HOPPER_DATA, HOPPER_TIGHT as TIGHT

QUADRUPED = HOPPER_DATA / "quadruped.toml"
A = 0.5
Q0 = [A, -2 * A, A, -2 * A, 0.0, -(0.1 + 0.4 * math.cos(A)), 0.15]
QD0 = [0.0, 0.0, 0.0, 0.0, 0.8, -0.5, 0.0]
T_FINAL = 0.3
KINDS = ["apex", "touchdown", "touchdown", "slip", "liftoff"]
BEHAVIOUR = {"joints": [
    {"joint": j, "phases": [{"name": "h", "torque": {
        "kind": "servo", "target_rad": t, "kp_n_m_per_rad": 150.0, "kd_n_m_s_per_rad": 2.0}}]}
    for j, t in [("fore[0]", A), ("fore[1]", -2 * A), ("hind[0]", A), ("hind[1]", -2 * A)]]}
CASES = {
    "legs.fore.links[0].mass_kg": 0.4,
    "legs.hind.links[1].inertia_kg_m2": 0.0008,
}


def end(**params: float) -> np.ndarray:
    e = selfmanip.simulate(QUADRUPED, BEHAVIOUR, Q0, QD0, t_final=T_FINAL, stop_at=None,
                           params=params, **TIGHT)
    assert [ev["kind"] for ev in e.events] == KINDS, params
    return np.concatenate([e.q_end, e.qd_end, [ev["t_s"] for ev in e.events]])


def richardson(f, h: float) -> np.ndarray:
    d = [(f(s) - f(-s)) / (2 * s) for s in (h, h / 2)]
    return (4 * d[1] - d[0]) / 3


def test_link_inertia_by_path_matches_central_differences() -> None:
    names = list(CASES) + ["legs.hind.hip_m[0]"]
    e = selfmanip.simulate(QUADRUPED, BEHAVIOUR, Q0, QD0, t_final=T_FINAL, stop_at=None,
                           sensitivity=True, parameters=names, **TIGHT)
    assert [ev["kind"] for ev in e.events] == KINDS
    assert e.parameter_reason is None
    jac = e.parameter_jacobian
    assert list(e.parameter_not_differentiated) == ["legs.hind.hip_m[0]"]
    assert np.isnan(jac[:, -1]).all()
    for k, (name, p) in enumerate(CASES.items()):
        grads = [ev["parameter_time_gradient"][k] for ev in e.events]
        exact = np.concatenate([jac[:, k], grads])
        fd = richardson(lambda h, name=name, p=p: end(**{name: p + h}), 1e-4 * p)
        scale = np.abs(fd).max()
        assert scale > 1e-3, name
        assert np.abs(exact - fd).max() < 1e-5 * scale, (name, exact, fd)


def test_link_mass_of_zero_is_flagged() -> None:
    name = "legs.fore.links[1].mass_kg"
    e = selfmanip.simulate(QUADRUPED, BEHAVIOUR, Q0, QD0, t_final=0.1, stop_at=None,
                           params={name: 0.0}, sensitivity=True, parameters=[name], **TIGHT)
    assert "no mass" in e.parameter_not_differentiated[name]
    assert np.isnan(e.parameter_jacobian[:, 0]).all()
