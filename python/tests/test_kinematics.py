"""Forward kinematics, Jacobians and contact points for any robot (issue 17, item 7), each
checked by a route of its own: the RHex stick leg's toe by the closed form of the frame
conventions (docs/conventions.md), every Jacobian column by central finite differences of
the positions, the contact Jacobians by the constraint matrix ``A`` of the KKT system, and
the Jacobians at the centres of mass by the kinetic energy (4.24) that the engine computes
from its mass matrix."""

import math
import pathlib
import tomllib

import numpy as np
import pytest

import selfmanip
from conftest import QUADRUPED


def body_to_world(x, z, phi, px, pz):
    """NED: x forward, z down, phi nose-up about +y: ``p_w = p_b0 + R(phi) p``."""
    c, s = math.cos(phi), math.sin(phi)
    return np.array([x + c * px + s * pz, z - s * px + c * pz])


@pytest.fixture(scope="module")
def stick():
    return selfmanip.rhex.Model({"leg_shape": "stick"})


def test_rhex_stick_toes_follow_the_closed_form(stick):
    p = stick.params
    rng = np.random.default_rng(3)
    for _ in range(20):
        t1, t2, x, z, phi = rng.uniform(-1.5, 1.5, 5)
        q = [t1, t2, x, z, phi]
        k = stick.forward_kinematics(q)
        # hips at +-l on the body's x axis; a leg of length rho points along the body's +z
        # turned by theta clockwise, i.e. about -y (the thesis's theta, joint axis -y): its
        # world angle about +y is b = phi - theta and its toe the hip plus R(b) (0, rho) =
        # rho (sin b, cos b)
        for j, (hip_x, rho, th) in enumerate(((p["l1"], p["rho1"], t1), (-p["l2"], p["rho2"], t2))):
            hip = body_to_world(x, z, phi, hip_x, 0.0)
            b = phi - th
            toe = hip + rho * np.array([math.sin(b), math.cos(b)])
            assert k.joint_positions_m[j] == pytest.approx(hip, abs=1e-12)
            assert k.link_tips_m[j] == pytest.approx(toe, abs=1e-12)
            assert k.link_angles_rad[j] == pytest.approx(b, abs=1e-12)
        assert k.body_position_m == pytest.approx([x, z]) and k.body_angle_rad == pytest.approx(phi)
        assert k.body_velocity_m_s is None
        # the stick toes are the leg contacts' points (rows 1, 3 of FB FL RB RL)
        cp = stick.contact_points(q)
        names = list(cp.names)
        assert cp.points_m[names.index("front_leg")] == pytest.approx(k.link_tips_m[0], abs=1e-12)
        assert cp.points_m[names.index("rear_leg")] == pytest.approx(k.link_tips_m[1], abs=1e-12)
        assert cp.gaps_m == pytest.approx([-pt[1] for pt in cp.points_m], abs=1e-12)  # flat ground z = 0


@pytest.mark.parametrize("robot", ["quadruped", "stick"])
def test_jacobians_match_finite_differences(robot, quadruped, stick):
    r = quadruped if robot == "quadruped" else stick
    rng = np.random.default_rng(7)
    q = rng.uniform(-0.8, 0.8, r.nq)
    h = 1e-6
    parts = ["body"] + r.coordinate_names[: r.n_joints]
    for part in parts:
        point = rng.uniform(-0.1, 0.1, 2)
        pj = r.jacobian(q, part, point)
        assert pj.jacobian.shape == (3, r.nq)
        fd = np.zeros((3, r.nq))
        for k in range(r.nq):
            e = np.zeros(r.nq)
            e[k] = h
            plus, minus = r.jacobian(q + e, part, point), r.jacobian(q - e, part, point)
            fd[:2, k] = (plus.position_m - minus.position_m) / (2 * h)
            fd[2, k] = (plus.angle_rad - minus.angle_rad) / (2 * h)
        np.testing.assert_allclose(pj.jacobian, fd, atol=1e-8, err_msg=part)
    # velocities from the kinematics equal J qd at the link tips
    qd = rng.normal(size=r.nq)
    k = r.forward_kinematics(q, qd)
    for j in range(r.n_joints):
        length = np.linalg.norm(k.link_tips_m[j] - k.joint_positions_m[j])
        pj = r.jacobian(q, j, (0.0, length))
        assert pj.position_m == pytest.approx(k.link_tips_m[j], abs=1e-12)
        assert pj.jacobian[:2] @ qd == pytest.approx(k.link_tip_velocities_m_s[j], abs=1e-10)
        assert pj.jacobian[2] @ qd == pytest.approx(k.link_rates_rad_s[j], abs=1e-12)


def test_contact_jacobians_are_the_rows_of_A(quadruped):
    # A (4.11) is A_k = -B^T J_p: minus each active contact's point Jacobian projected on its
    # contact frame B, whose tangent on flat ground is world +x and whose normal, into the
    # ground, is world +z (z down)
    q = [0.4, -0.8, -0.3, 0.7, 0.0, -0.3, 0.0]
    cp = quadruped.contact_points(q)
    k = quadruped.kkt("fore_foot,hind_foot:slide", q)
    for (name, direction), row in zip(k.rows, k.A):
        c = list(cp.names).index(name)
        want = -cp.jacobians[c, 0 if direction == "tangential" else 1]
        np.testing.assert_allclose(row, want, atol=1e-12, err_msg=(name, direction))
    assert cp.normals == pytest.approx(np.tile([0.0, 1.0], (len(cp.names), 1)))


def test_com_jacobians_give_the_engines_kinetic_energy(quadruped):
    """T = 1/2 sum m |J_com qd|^2 + 1/2 I (J_w qd)^2 over body and links equals the engine's
    qd^T M qd / 2 (4.24), with masses and centres of mass read from the description file."""
    d = tomllib.loads(pathlib.Path(QUADRUPED).read_text())
    rng = np.random.default_rng(11)
    q, qd = rng.uniform(-0.6, 0.6, quadruped.nq), rng.normal(size=quadruped.nq)
    parts = [("body", d["body"]["mass_kg"], d["body"]["inertia_kg_m2"], (0.0, 0.0))]
    j = 0
    for leg in d["legs"]:
        for link in leg["links"]:
            com = link.get("com_m", (0.0, 0.5 * link["length_m"]))
            parts.append((j, link["mass_kg"], link["inertia_kg_m2"], com))
            j += 1
    t = 0.0
    for part, m, inertia, com in parts:
        jac = quadruped.jacobian(q, part, com).jacobian
        v, w = jac[:2] @ qd, jac[2] @ qd
        t += 0.5 * m * v @ v + 0.5 * inertia * w * w
    assert quadruped.energy(q, qd)[0] == pytest.approx(t, rel=1e-12)


def test_kinematics_inputs_are_checked(quadruped):
    with pytest.raises(selfmanip.InvalidInputError, match="`q` has length 3") as e:
        quadruped.forward_kinematics([0.0, 0.0, 0.0])
    assert e.value.field == "q"
    with pytest.raises(selfmanip.InvalidInputError, match="`qd`.*non-finite") as e:
        quadruped.contact_points([0.0] * 7, [0.0, math.nan] + [0.0] * 5)
    assert e.value.field == "qd"
    with pytest.raises(selfmanip.InvalidInputError, match="unknown part 'tail'"):
        quadruped.jacobian([0.0] * 7, "tail")
    with pytest.raises(selfmanip.InvalidInputError, match="joint index 9"):
        quadruped.jacobian([0.0] * 7, 9)
    with pytest.raises(selfmanip.InvalidTypeError, match="part"):
        quadruped.jacobian([0.0] * 7, 1.5)
