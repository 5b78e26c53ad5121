"""A joint's armature (``armature_kg_m2`` in a robot description: the drive's rotors reflected
to the joint, ``n J G^2``) passes through the Python layer as the Rust core reads it, and a
bad value is a ValueError naming the field.

Independent route, a closed form: a massless link with armature ``a`` on a free body in flight
is a pure rotor on ``M``'s diagonal, ``a theta'' = tau`` with nothing else moving, and its
kinetic energy is ``a theta'^2 / 2``; without armature the same link is a free massless joint.
"""

import math
import tomllib

import pytest

import selfmanip
from conftest import REPO

G = 9.81


def robot(armature: float) -> selfmanip.Robot:
    """``tests/data/robots/rotor_on_a_body.toml`` with ``armature`` at its arm's joint."""
    description = tomllib.loads((REPO / "tests" / "data" / "robots" / "rotor_on_a_body.toml").read_text())
    description["legs"][0]["links"][0]["armature_kg_m2"] = armature
    return selfmanip.Robot.from_dict(description)


def test_a_massless_link_with_armature_is_a_rotor_on_the_diagonal():
    a, tau = 0.012, 0.6
    r = robot(a)
    d = r.dynamics("", [0.3, 0.0, 0.0, 0.0], [0.0] * 4, [tau])
    assert d.free_joints == []
    assert math.isclose(d.qdd[0], tau / a, rel_tol=1e-12)
    assert abs(d.qdd[1]) + abs(d.qdd[2] - G) + abs(d.qdd[3]) < 1e-12
    kinetic, _ = r.energy([0.3, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0])
    assert math.isclose(kinetic, 0.5 * a * 4.0, rel_tol=1e-12)
    # without armature the link is a free massless joint (its acceleration prescribed: 0)
    d = robot(0.0).dynamics("", [0.3, 0.0, 0.0, 0.0], [0.0] * 4, [tau])
    assert d.free_joints == [0] and d.qdd[0] == 0.0


@pytest.mark.parametrize("bad", [-0.01, math.nan])
def test_bad_armature_names_the_field(bad):
    with pytest.raises(ValueError, match="armature_kg_m2"):
        robot(bad)
