"""The leap's compliant C-leg option from Python (``leap(..., compliant_leg={...})``,
``docs/leap-model.md``): the exact derivatives in ``leg_stiffness`` and ``leg_damping``
against central differences of whole leaps, and bad input as typed errors naming the field."""

import pytest

import selfmanip

#: Stick legs with Table 4.2's pair mass on the hip link and pinned toes: what a compliant
#: leg is made of (a half-circle cannot roll on a bending link, a massless one cannot slide).
PARAMS = {"leg_shape": "stick", "m_l": 0.126, "I_l": 0.00092, "mu_front": None, "mu_middle": None,
          "mu_rear": None}


def _leap(k, c, **kw):
    return selfmanip.leap("++", t2=0.03, params=PARAMS, dt=None, control_free_joints=True,
                          compliant_leg={"stiffness_n_per_m": k, "damping_n_s_per_m": c}, **kw)


def test_apex_derivatives_in_stiffness_and_damping_match_central_differences():
    k, c = 2e4, 160.0
    r = _leap(k, c, sensitivities=["leg_stiffness", "leg_damping"])
    assert r.flew and r.sensitivity_ok, r.sensitivity_reason
    for name, p in (("leg_stiffness", k), ("leg_damping", c)):
        h = 1e-3 * p
        kw = (lambda x: (x, c)) if name == "leg_stiffness" else (lambda x: (k, x))
        up, down = _leap(*kw(p + h)).apex, _leap(*kw(p - h)).apex
        for col, attr in (("apex_z_m", "z_m"), ("apex_phi_rad", "phi_rad"), ("apex_x_m", "x_m")):
            fd = (getattr(up, attr) - getattr(down, attr)) / (2 * h)
            exact = r.sensitivity[(col, name)]
            assert exact == pytest.approx(fd, rel=1e-3, abs=1e-9), (col, name)


@pytest.mark.parametrize("leg, field", [
    ({"stiffness_n_per_m": -1.0}, "compliant_leg.stiffness_n_per_m"),
    ({"damping_n_s_per_m": 3.0}, "compliant_leg.damping_n_s_per_m"),
    ({"stiffness_n_per_m": 1e4, "knee_side": 0.5}, "compliant_leg.knee_side"),
])
def test_bad_compliant_legs_name_the_field(leg, field):
    with pytest.raises(selfmanip.InvalidInputError) as e:
        selfmanip.leap("++", params=PARAMS, dt=None, compliant_leg=leg)
    assert e.value.field == field


def test_rigid_leap_refuses_spring_derivatives():
    with pytest.raises(selfmanip.InvalidInputError) as e:
        selfmanip.leap("++", dt=None, sensitivities=["leg_stiffness"])
    assert e.value.field == "leg_stiffness"
