"""A robot that is not RHex, loaded from a description file."""

import numpy as np
import pytest

import selfmanip
from conftest import QUADRUPED, gravity_by_finite_differences


def test_quadruped_loads_from_toml_and_json(quadruped):
    assert quadruped.nq == 7 and quadruped.n_joints == 4
    assert quadruped.contact_names == ["fore_foot", "hind_foot", "fore_knee", "belly"]
    assert quadruped.coordinate_names[-3:] == ["x", "z", "phi"]


@pytest.mark.parametrize("mode", ["fore_foot,hind_foot", "fore_foot", "hind_foot:slide", "fore_knee,belly", ""])
def test_quadruped_residuals(quadruped, mode):
    if ":slide" in mode:
        # the identity below has no kinetic friction term: slide frictionlessly (Assumption
        # 5.9, mu_kinetic = 0; sliding is Coulomb by default)
        import tomllib

        data = tomllib.loads(QUADRUPED.read_text())
        for c in data["contacts"]:
            if c["friction"]["kind"] == "sticking":
                c["friction"]["mu_kinetic"] = 0.0
        quadruped = selfmanip.Robot.from_dict(data)
    q = [0.4, -0.8, -0.3, 0.7, 0.0, -0.3, 0.05]
    tau = [1.0, -2.0, 0.5, 3.0]
    d = quadruped.dynamics(mode, q, [0.0] * 7, tau)
    k = quadruped.kkt(mode, q)
    ups = np.array(tau + [0.0] * 3)
    n = gravity_by_finite_differences(quadruped, q)
    res = k.M @ d.qdd + n + k.A.T @ d.lam - ups
    assert np.allclose(res, 0.0, atol=1e-6)
    if d.lam.size:
        assert np.allclose(k.A @ d.qdd, 0.0, atol=1e-10)


def test_quadruped_json_matches_toml(tmp_path):
    tomllib = pytest.importorskip("tomllib")
    import json

    data = tomllib.loads(QUADRUPED.read_text())
    path = tmp_path / "quadruped.json"
    path.write_text(json.dumps(data))
    a = selfmanip.Robot.from_file(path)
    b = selfmanip.Robot.from_file(QUADRUPED)
    q = [0.1, -0.2, 0.3, 0.4, 0.0, -0.3, 0.0]
    da = a.dynamics("fore_foot", q, [0.1] * 7, [0.0] * 4)
    db = b.dynamics("fore_foot", q, [0.1] * 7, [0.0] * 4)
    assert np.array_equal(da.qdd, db.qdd) and np.array_equal(da.lam, db.lam)
