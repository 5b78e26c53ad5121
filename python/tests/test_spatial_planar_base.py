"""A planar base (``base="planar"``, issue 32's API item 7) against Pinocchio with the same base:
its composite root joint of ``PX``, ``PZ``, ``RY`` (``q = [x, z, theta]``, ``v = dq/dt``). On the
shipped quadruped and the six-legged RHex at random states: the layout, ``M``, ``nle``, frame
placements and Jacobians to 1e-10, ``q ⊕ v``; constrained forward dynamics and plastic impact
with the feet held in the plane (rows world ``x`` and ``z``) against ``pin.forwardDynamics``
and ``pin.impulseDynamics`` with the same rows to 1e-9; quasi-static standing balancing
Pinocchio's generalized gravity; pickling keeps the base."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from selfmanip import SpatialRobot
from selfmanip.errors import InvalidInputError

pin = pytest.importorskip("pinocchio", reason="Pinocchio (`pip install pin`, in the test extra) is the independent route")

from pinocchio_routes import contact_rows, dynamics_errors, kinematics_errors, planar_root_joint, rel  # noqa: E402
from test_spatial_pinocchio import FEET, FRAMES, QUADRUPED, RHEX6, RHEX_FRAMES, RHEX_MODES, scaled_urdf  # noqa: E402

PLANE = (0, 2)  # a contact's rows with friction on a planar base: world x, z
QUADRUPED_MODES = [FEET, ["FL_foot", "HR_foot"], [f + ":frictionless" for f in FEET],
                   ["FL_foot", "FR_foot:frictionless", "HL_foot"]]
# robot -> (URDF, links scaled, scale, frames, contact modes)
ROBOTS = {
    "quadruped": (QUADRUPED, (), 1.0, FRAMES, QUADRUPED_MODES),
    "quadruped-small_leg_masses": (QUADRUPED, ("_hip", "_thigh", "_shin", "_foot"), 1e-2, FRAMES, QUADRUPED_MODES),
    "rhex6": (RHEX6, (), 1.0, RHEX_FRAMES, RHEX_MODES),
}


def both(path):
    ours = SpatialRobot.from_urdf(path, base="planar")
    model = pin.buildModelFromUrdf(str(path), planar_root_joint())
    return ours, model, model.createData()


def random_state(ours, rng: np.random.Generator):
    """A planar state in our layout and Pinocchio's: base within 1 m turned by up to ±3 rad,
    joints in ±1.5, rates in ±2, torques in ±5."""
    q = rng.uniform(-1.5, 1.5, ours.nq)
    q[:3] = [*rng.uniform(-1, 1, 2), rng.uniform(-3, 3)]
    v, tau = rng.uniform(-2, 2, ours.nv), rng.uniform(-5, 5, ours.nv)
    qp, vp = ours.to_pinocchio(q, v)
    return q, v, tau, qp, vp


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_planar_base_kinematics_and_rigid_body_terms_are_pinocchios(tmp_path, robot):
    source, suffixes, scale, frames, _ = ROBOTS[robot]
    ours, model, data = both(scaled_urdf(tmp_path, suffixes, scale, source) if suffixes else source)
    assert ours.nq == ours.nv == model.nq == model.nv
    assert ours.joint_names == list(model.names)[1:]
    assert ours.joint_names[0] == "root_joint"
    q0, _ = ours.to_pinocchio(ours.neutral(), np.zeros(ours.nv))
    assert np.array_equal(q0, pin.neutral(model))
    rng = np.random.default_rng(60)
    worst = dict(M=0.0, nle=0.0, placement=0.0, jacobian=0.0, integrate=0.0)
    for _ in range(20):
        q, v, _, qp, vp = random_state(ours, rng)
        for k, e in kinematics_errors(ours, model, data, q, v, frames, (qp, vp)).items():
            worst[k] = max(worst[k], e)
        q1, _ = ours.to_pinocchio(ours.integrate(q, v), v)
        worst["integrate"] = max(worst["integrate"], rel(q1, pin.integrate(model, qp, vp)))
    print(robot, {k: f"{w:.1e}" for k, w in worst.items()})
    assert all(w < 1e-10 for w in worst.values()), worst


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_planar_base_dynamics_and_impact_are_pinocchios(tmp_path, robot):
    source, suffixes, scale, _, modes = ROBOTS[robot]
    ours, model, data = both(scaled_urdf(tmp_path, suffixes, scale, source) if suffixes else source)
    rng = np.random.default_rng(61)
    worst = dict(A=0.0, drift=0.0, qdd=0.0, lam=0.0, v_plus=0.0, impulse=0.0)
    for k in range(24):
        contacts = modes[k % len(modes)]
        q, v, tau, qp, vp = random_state(ours, rng)
        for k, e in dynamics_errors(ours, model, data, contacts, q, v, tau, (qp, vp), PLANE).items():
            worst[k] = max(worst[k], e)
        rows = [r for _, r in ours.dynamics(contacts, q, v, tau).rows]
        assert rows == [r for c in contacts for r in (["n"] if c.endswith("frictionless") else ["t", "n"])]
    print(robot, {k: f"{w:.1e}" for k, w in worst.items()})
    assert all(w < 1e-9 for w in worst.values()), worst


def test_planar_quasi_static_balances_pinocchios_gravity():
    """Standing on four feet in the plane: the external forces and the joint torques that hold
    them balance Pinocchio's generalized gravity, ``g = Jᵀ λ + (0, τ)``, and each internal
    force pushes nothing into the base."""
    ours, model, data = both(QUADRUPED)
    q = ours.neutral()
    q[1], q[2] = 0.3, 0.1
    q[3:] = np.tile([0.1, 0.6, -1.2], 4)
    qp, _ = ours.to_pinocchio(q, np.zeros(ours.nv))
    out = ours.quasi_static(FEET, q)
    J, _ = contact_rows(model, data, qp, np.zeros(model.nv), FEET, friction_rows=PLANE)
    g = pin.computeGeneralizedGravity(model, data, qp)
    tau = np.concatenate([np.zeros(3), out.tau_external])
    assert rel(J.T @ out.lam_external + tau, g) < 1e-10
    assert np.abs(J[:, :3].T @ out.internal_basis).max() < 1e-10
    assert out.grasp.shape == (3, 8) and out.internal_basis.shape == (8, 5)


def test_planar_base_pickles_and_refuses_out_of_plane_ground():
    ours = SpatialRobot.from_urdf(QUADRUPED, base="planar")
    back = pickle.loads(pickle.dumps(ours))
    assert (back.nq, back.nv, back.joint_names) == (ours.nq, ours.nv, ours.joint_names)
    q = ours.neutral()
    q[3:] = 0.3
    assert np.array_equal(back.mass_matrix(q), ours.mass_matrix(q))
    with pytest.raises(InvalidInputError) as e:
        ours.dynamics({"FL_foot": {"friction": 0.8, "normal": [0.0, 0.2, 1.0]}}, q, np.zeros(15), np.zeros(15))
    assert "normal" in e.value.field
    rhex = SpatialRobot.rhex(base="planar")
    assert (rhex.nq, rhex.nv) == (9, 9)


def test_declared_contacts_are_named_by_mode_or_name():
    """``Robot.from_urdf`` is ``SpatialRobot.from_urdf``; contacts declared there are named by
    a mode string, a list of declared names or ``None``, and give what the same dict gives;
    bad declarations and modes name ``contacts``; a pickle keeps them."""
    from selfmanip import Robot

    declared = {f: {"friction": 0.8, "radius_m": 0.02} for f in FEET}
    robot = Robot.from_urdf(QUADRUPED, base="planar", contacts=declared)
    assert isinstance(robot, SpatialRobot) and robot.contacts == declared
    rng = np.random.default_rng(62)
    q, v, tau = rng.uniform(-0.5, 0.5, robot.nq), rng.uniform(-1, 1, robot.nv), rng.uniform(-1, 1, robot.nv)
    three = {f: declared[f] for f in ("FL_foot", "HL_foot", "HR_foot")}
    for named, given in ((None, declared), ("1011", three), (["FL_foot", "HL_foot", "HR_foot"], three)):
        a, b = robot.dynamics(named, q, v, tau), robot.dynamics(given, q, v, tau)
        assert np.array_equal(a.qdd, b.qdd) and a.rows == b.rows
    copy = pickle.loads(pickle.dumps(robot))
    assert copy.contacts == declared
    assert np.array_equal(copy.dynamics("1011", q, v, tau).qdd, robot.dynamics(three, q, v, tau).qdd)
    for bad in ("101", "10x1", ["FL_foot", "trunk"]):
        with pytest.raises(InvalidInputError) as e:
            robot.dynamics(bad, q, v, tau)
        assert e.value.field == "contacts"
    with pytest.raises(InvalidInputError) as e:
        SpatialRobot.from_urdf(QUADRUPED).dynamics(None, q[:0], v, tau)
    assert e.value.field == "contacts"
    with pytest.raises(InvalidInputError) as e:
        Robot.from_urdf(QUADRUPED, contacts={"FL_foot": {"radius_m": -1.0}})
    assert e.value.field.startswith("contacts[FL_foot]")
