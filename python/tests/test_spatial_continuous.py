"""A URDF ``continuous`` joint against Pinocchio, which stores it as ``(cos θ, sin θ)``
(``nq`` one larger per such joint, ``nv`` the same): ``to_pinocchio``/``from_pinocchio``
convert ``q``, and at converted states Pinocchio's ``M``, ``nle``, frame placements and
Jacobians equal ours to 1e-10. The URDF,
``tests/data/urdf/cart_continuous.urdf``, is a free-flying cart with a revolute
arm, a continuous joint on the arm and a continuous wheel (siblings in name order, which is
Pinocchio's order)."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

from selfmanip import SpatialRobot
from selfmanip.errors import InvalidInputError

pin = pytest.importorskip("pinocchio", reason="Pinocchio (`pip install pin`, in the test extra) is the independent route")

CART = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data" / "urdf" / "cart_continuous.urdf"
FRAMES = ["wheel", "arm", "tip", "tip_joint"]


@pytest.fixture(scope="module")
def robots():
    ours = SpatialRobot.from_urdf(CART)
    model = pin.buildModelFromUrdf(str(CART), pin.JointModelFreeFlyer())
    return ours, model, model.createData()


def test_layouts_differ_by_one_coordinate_per_continuous_joint(robots):
    ours, model, _ = robots
    assert (ours.nq, ours.nv) == (10, 9)
    assert (model.nq, model.nv) == (12, 9)


def test_converted_states_give_pinocchios_dynamics(robots):
    ours, model, data = robots
    rng = np.random.default_rng(7)
    for _ in range(10):
        # angles beyond ±π too: the conversion is the rotation, not the number
        q = ours.integrate(ours.neutral(), rng.uniform(-5.0, 5.0, ours.nv))
        v = rng.uniform(-2.0, 2.0, ours.nv)
        qp, vp = ours.to_pinocchio(q, v)
        assert qp.shape == (model.nq,)
        np.testing.assert_array_equal(vp, v)
        np.testing.assert_allclose(pin.crba(model, data, qp), ours.mass_matrix(q), atol=1e-10)
        np.testing.assert_allclose(pin.nonLinearEffects(model, data, qp, vp), ours.bias_forces(q, v), atol=1e-10)
        pin.computeJointJacobians(model, data, qp)
        pin.framesForwardKinematics(model, data, qp)
        for name in FRAMES:
            fid = model.getFrameId(name)
            np.testing.assert_allclose(data.oMf[fid].homogeneous, ours.frame_placement(q, name), atol=1e-10)
            np.testing.assert_allclose(pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED),
                                       ours.frame_jacobian(q, name, frame="local_world_aligned"), atol=1e-10)
        # and back: Pinocchio's own integration of the same rates lands on ours
        q_pin_next = pin.integrate(model, qp, 0.3 * vp)
        q_next, _ = ours.from_pinocchio(q_pin_next, vp)
        np.testing.assert_allclose(ours.difference(ours.integrate(q, 0.3 * v), q_next)[:6], 0.0, atol=1e-12)
        np.testing.assert_allclose(ours.to_pinocchio(ours.integrate(q, 0.3 * v), v)[0], q_pin_next, atol=1e-12)


def test_off_circle_coordinates_name_the_joint(robots):
    ours, model, _ = robots
    qp = pin.neutral(model)
    qp[10] = 0.5  # the wheel's cos θ with sin θ = 0
    with pytest.raises(InvalidInputError, match="wheel_joint"):
        ours.from_pinocchio(qp, np.zeros(ours.nv))
    with pytest.raises(InvalidInputError, match="v"):
        ours.to_pinocchio(ours.neutral(), np.zeros(ours.nv + 1))
