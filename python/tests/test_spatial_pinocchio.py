"""Pinocchio as the independent route for the spatial engine (issue 32): on the shipped
12-joint quadruped URDF, at random states, ``M``, ``nle``, frame placements and Jacobians to
1e-10; constrained forward dynamics against ``pin.forwardDynamics`` with the same contact
Jacobian to 1e-9; plastic impact against ``pin.impulseDynamics`` to 1e-9; and with the shins'
mass eps -> 0, Pinocchio's answers converge to ours at eps = 0 (where its ``crba`` is singular
and its solvers cannot run)."""

from __future__ import annotations

import pathlib
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from selfmanip import SpatialRobot
from selfmanip.errors import InvalidInputError, SingularKktError

pin = pytest.importorskip("pinocchio", reason="Pinocchio (`pip install pin`, in the test extra) is the independent route")

from pinocchio_routes import contact_rows, dynamics_errors, kinematics_errors, rel  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
QUADRUPED = ROOT / "tests" / "data" / "urdf" / "quadruped12.urdf"
# the six-legged RHex of Table 4.2 (its legs 0.063 kg each), written by
# selfmanip_core::spatial::rhex::RhexSixLegs::urdf
RHEX6 = ROOT / "tests" / "data" / "urdf" / "rhex6.urdf"
RHEX_LEGS = [f"{p}_{s}" for p in ("front", "middle", "rear") for s in ("left", "right")]
FEET = ["FL_foot", "FR_foot", "HL_foot", "HR_foot"]
FRAMES = FEET + ["trunk", "imu", "FL_thigh", "HR_shin", "HL_knee", "FR_foot_fixed"]
LEGS = ("_hip", "_thigh", "_shin", "_foot")
SHINS = ("_shin", "_foot")


def scaled_urdf(tmp_path: pathlib.Path, suffixes: tuple[str, ...], scale: float,
                source: pathlib.Path = QUADRUPED) -> pathlib.Path:
    """The robot of ``source`` with the links ending in ``suffixes`` scaled in mass and inertia."""
    tree = ET.parse(source)
    for link in tree.getroot().iter("link"):
        if link.get("name", "").endswith(suffixes):
            inertial = link.find("inertial")
            mass = inertial.find("mass")
            mass.set("value", repr(float(mass.get("value")) * scale))
            inertia = inertial.find("inertia")
            for k, val in inertia.attrib.items():
                inertia.set(k, repr(float(val) * scale))
    path = tmp_path / f"{source.stem}_{'_'.join(s.strip('_') for s in suffixes)}_{scale:g}.urdf"
    tree.write(path)
    return path


def both(path: pathlib.Path):
    ours = SpatialRobot.from_urdf(path)
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    return ours, model, model.createData()


def random_state(rng: np.random.Generator, nq: int, nv: int):
    q = np.zeros(nq)
    q[:3] = rng.uniform(-1, 1, 3)
    quat = rng.normal(size=4)
    q[3:7] = quat / np.linalg.norm(quat)
    q[7:] = rng.uniform(-1.5, 1.5, nq - 7)
    return q, rng.uniform(-2, 2, nv), rng.uniform(-5, 5, nv)


def pin_mass_matrix(model, data, q):
    M = pin.crba(model, data, q)
    return np.triu(M) + np.triu(M, 1).T


VARIANTS = {"as_shipped": ((), 1.0), "small_leg_masses": (LEGS, 1e-2), "massless_shins": (SHINS, 0.0)}
RHEX_VARIANTS = {"table_4_2_legs": ((), 1.0), "small_leg_masses": (("_leg",), 1e-2), "tenth_leg_masses": (("_leg",), 0.1),
                 "massless_legs": (("_leg",), 0.0)}
RHEX_FRAMES = [f"{leg}_{f}" for leg in RHEX_LEGS for f in ("toe", "arc")] + ["body", "front_left_end", "rear_right_hip"]
# the cases of the kinematics test: (robot, variant) -> (URDF, suffixes, scale, frames, (nq, nv))
KINEMATICS = {("quadruped", k): (QUADRUPED, *v, FRAMES, (19, 18)) for k, v in VARIANTS.items()} | {
    ("rhex6", k): (RHEX6, *v, RHEX_FRAMES, (13, 12)) for k, v in RHEX_VARIANTS.items()}


@pytest.mark.parametrize("case", list(KINEMATICS), ids=lambda c: "-".join(c))
def test_kinematics_mass_matrix_and_bias_forces_match_pinocchio(tmp_path, case):
    source, suffixes, scale, frames, dims = KINEMATICS[case]
    variant = case[1]
    ours, model, data = both(scaled_urdf(tmp_path, suffixes, scale, source) if suffixes else source)
    assert (ours.nq, ours.nv) == (model.nq, model.nv) == dims
    assert ours.joint_names == list(model.names)[1:]
    rng = np.random.default_rng(10)
    worst = dict(M=0.0, nle=0.0, placement=0.0, jacobian=0.0)
    for _ in range(20):
        q, v, _ = random_state(rng, model.nq, model.nv)
        for k, e in kinematics_errors(ours, model, data, q, v, frames).items():
            worst[k] = max(worst[k], e)
    print(case, {k: f"{w:.1e}" for k, w in worst.items()})
    assert all(w < 1e-10 for w in worst.values()), worst
    if variant.startswith("massless"):
        # Pinocchio's crba is singular here too: the quadruped's rank 14 of 18, RHex's 6 of 12
        assert np.linalg.matrix_rank(pin_mass_matrix(model, data, q), tol=1e-10) == {"quadruped": 14, "rhex6": 6}[case[0]]


def test_configuration_group_matches_pinocchio():
    """``integrate``/``difference`` are Pinocchio's on the same layout (the free flyer on SE(3)
    with the body-frame twist, not a decoupled R^3 x SO(3)); ``neutral`` too."""
    ours, model, _ = both(QUADRUPED)
    assert np.array_equal(ours.neutral(), pin.neutral(model))
    rng = np.random.default_rng(14)
    worst = 0.0
    for _ in range(50):
        q, v, _ = random_state(rng, model.nq, model.nv)
        q1, _, _ = random_state(rng, model.nq, model.nv)
        worst = max(worst, rel(ours.integrate(q, v), pin.integrate(model, q, v)))
        worst = max(worst, rel(ours.difference(q, q1), pin.difference(model, q, q1)))
    print(f"integrate/difference vs Pinocchio: {worst:.1e}")
    assert worst < 1e-12, worst


MODES = [FEET, ["FL_foot", "HR_foot"], [f + ":frictionless" for f in FEET], ["FL_foot", "FR_foot:frictionless", "HL_foot"]]


TOES = [f"{leg}_toe" for leg in RHEX_LEGS]
# RHex's contact sets of full row rank: a tripod, two toes, four frictionless toes, a mixed set
RHEX_MODES = [[TOES[0], TOES[3], TOES[4]], [TOES[1], TOES[5]], [t + ":frictionless" for t in TOES[:4]],
              [TOES[0], TOES[1] + ":frictionless", TOES[4], TOES[5] + ":frictionless"]]
# (robot, variant) -> (URDF, suffixes, scale, modes)
DYNAMICS = {("quadruped", k): (QUADRUPED, *VARIANTS[k], MODES) for k in ("as_shipped", "small_leg_masses")} | {
    ("rhex6", "table_4_2_legs"): (RHEX6, *RHEX_VARIANTS["table_4_2_legs"], RHEX_MODES)}
# (RHex's Table 4.2 legs, 63 g each, are its small leg masses: lighter ones make Pinocchio's
# M^-1 route lose lam, 3.9e-9 at a tenth and 1.8e-8 at 1e-2, while q'' agrees to 3.5e-12; the
# eps -> 0 test below follows that limit)


@pytest.mark.parametrize("case", list(DYNAMICS), ids=lambda c: "-".join(c))
def test_constrained_dynamics_and_impact_match_pinocchio(tmp_path, case):
    source, suffixes, scale, modes = DYNAMICS[case]
    ours, model, data = both(scaled_urdf(tmp_path, suffixes, scale, source) if suffixes else source)
    rng = np.random.default_rng(11)
    worst = dict(A=0.0, drift=0.0, qdd=0.0, lam=0.0, v_plus=0.0, impulse=0.0)
    for k in range(24):
        contacts = modes[k % len(modes)]
        q, v, tau = random_state(rng, model.nq, model.nv)
        for k, e in dynamics_errors(ours, model, data, contacts, q, v, tau).items():
            worst[k] = max(worst[k], e)
    print(case, {k: f"{w:.1e}" for k, w in worst.items()})
    assert all(w < 1e-9 for w in worst.values()), worst


# robot -> (URDF, massless links, contacts): the quadruped's shins on four feet; RHex's six
# legs on their toes, frictionless (six rows: with friction the set is redundant)
LIMITS = {"quadruped": (QUADRUPED, SHINS, FEET), "rhex6": (RHEX6, ("_leg",), [t + ":frictionless" for t in TOES])}


@pytest.mark.parametrize("robot", list(LIMITS))
def test_massless_limit_of_pinocchio_converges_to_ours(tmp_path, robot):
    """Pinocchio needs a mass on every moving link; with the legs' (shins') mass and inertia
    scaled by eps its answers approach ours at eps = 0 (exact, singular M), the gap falling
    with eps."""
    source, massless, contacts = LIMITS[robot]
    ours = SpatialRobot.from_urdf(scaled_urdf(tmp_path, massless, 0.0, source))
    rng = np.random.default_rng(12)
    states = [random_state(rng, ours.nq, ours.nv) for _ in range(5)]
    exact = []
    for q, v, tau in states:
        out = ours.dynamics(contacts, q, v, tau)
        assert np.all(np.isfinite(out.qdd)) and np.all(np.isfinite(out.lam))
        residual = out.A @ out.qdd + out.drift
        assert np.max(np.abs(residual)) <= 1e-12 * max(1.0, np.max(np.abs(out.A) @ np.abs(out.qdd))), residual
        imp = ours.impact(contacts, q, v)
        assert np.max(np.abs(out.A @ imp.v_plus)) <= 1e-12 * max(1.0, np.max(np.abs(v)))
        exact.append((out, imp))
    gaps, kkt_gaps = [], []
    for eps in [1e-2, 1e-4, 1e-6, 1e-8]:
        _, model, data = both(scaled_urdf(tmp_path, massless, eps, source))
        gap = kkt_gap = 0.0
        for (q, v, tau), (out, imp) in zip(states, exact):
            J, gamma = contact_rows(model, data, q, v, contacts)
            qdd = pin.forwardDynamics(model, data, q, v, tau, J, gamma)
            gap = max(gap, rel(qdd, out.qdd), rel(data.lambda_c, out.lam))
            pin.impulseDynamics(model, data, q, v, J, 0.0)
            gap = max(gap, rel(data.dq_after, imp.v_plus), rel(data.impulse_c, imp.impulse))
            # the same Pinocchio M and nle, the KKT matrix solved whole by LU (no M^-1)
            M, h, c = pin_mass_matrix(model, data, q), pin.nonLinearEffects(model, data, q, v), len(gamma)
            K = np.block([[M, J.T], [J, np.zeros((c, c))]])
            x = np.linalg.solve(K, np.concatenate([tau - h, -gamma]))
            kkt_gap = max(kkt_gap, rel(x[:ours.nv], out.qdd), rel(-x[ours.nv:], out.lam))
        gaps.append(gap)
        kkt_gaps.append(kkt_gap)
    print(robot, "eps = 1e-2, 1e-4, 1e-6, 1e-8: |Pinocchio(eps) - ours(0)|", [f"{g:.1e}" for g in gaps],
          "; |KKT LU of Pinocchio's M, nle (eps) - ours(0)|", [f"{g:.1e}" for g in kkt_gaps])
    for g in (gaps, kkt_gaps):
        assert all(b < a for a, b in zip(g, g[1:])), g
    # the gap is the legs' mass, O(eps) (RHex's ~15 eps), down to Pinocchio's round-off (it
    # factors M, of condition ~1/eps), which floors the quadruped's at ~1e-7
    assert gaps[-1] < 1e-6 and kkt_gaps[-1] < 1e-6, (gaps, kkt_gaps)


def test_bad_input_names_the_field(tmp_path):
    robot = SpatialRobot.from_urdf(QUADRUPED)
    q = robot.neutral()
    bad = q.copy()
    bad[6] = 1.1
    with pytest.raises(InvalidInputError) as e:
        robot.mass_matrix(bad)
    assert e.value.field == "q"
    with pytest.raises(InvalidInputError) as e:
        robot.frame_placement(q, "no_such_frame")
    assert e.value.field == "name"
    with pytest.raises(InvalidInputError) as e:
        robot.dynamics(["no_such_foot"], q, np.zeros(18), np.zeros(18))
    assert e.value.field == "contacts"
    with pytest.raises(InvalidInputError) as e:
        robot.frame_jacobian(q, "FL_foot", "body")
    assert e.value.field == "frame"
    with pytest.raises(InvalidInputError) as e:
        SpatialRobot.from_urdf(QUADRUPED, base="sagittal")
    assert e.value.field == "base"
    v = np.zeros(18)
    v[3] = np.nan
    with pytest.raises(InvalidInputError) as e:
        robot.bias_forces(q, v)
    assert e.value.field == "v"
    negative = scaled_urdf(tmp_path, ("FL_shin",), -1.0)
    with pytest.raises(InvalidInputError) as e:
        SpatialRobot.from_urdf(negative)
    assert e.value.field == "link[FL_shin].inertial.mass"
    # a massless shin off the ground has no dynamics: Lemma 5.1's typed error
    massless = SpatialRobot.from_urdf(scaled_urdf(tmp_path, SHINS, 0.0))
    with pytest.raises(SingularKktError):
        massless.dynamics(FEET[:3], q, np.zeros(18), np.zeros(18))


def test_rhex_and_quasi_static_name_bad_fields():
    """The six-legged RHex's constructor and the quasi-static solve: typed errors naming the
    field; and the quasi-static forces balance the base (``grasp @ lam = gravity_wrench``,
    internal forces in ``ker grasp``) on RHex's six frictionless toes."""
    rhex = SpatialRobot.rhex()
    assert (rhex.nq, rhex.nv) == (13, 12)
    assert abs(rhex.total_mass - 7.15) < 1e-12
    for kwargs, field in [({"leg_mass_kg": -1.0}, "leg_mass_kg"), ({"leg_inertia_kg_m2": float("nan")}, "leg_inertia_kg_m2"),
                          ({"hip_half_width_m": 0.0}, "hip_half_width_m")]:
        with pytest.raises(InvalidInputError) as e:
            SpatialRobot.rhex(**kwargs)
        assert e.value.field == field
    q = rhex.neutral()
    q[2] = 0.17
    qs = rhex.quasi_static([t + ":frictionless" for t in TOES], q)
    assert np.max(np.abs(qs.grasp @ qs.lam_external - qs.gravity_wrench)) < 1e-10
    assert qs.internal_basis.shape == (6, 3)
    assert np.max(np.abs(qs.grasp @ qs.internal_basis)) < 1e-12
    # six equal toes under the centre of mass: 7.15 g / 6 each
    assert np.max(np.abs(qs.lam_external - 7.15 * 9.81 / 6)) < 1e-10
    with pytest.raises(InvalidInputError) as e:
        rhex.quasi_static(["no_such_toe"], q)
    assert e.value.field == "contacts"
    with pytest.raises(InvalidInputError) as e:
        rhex.quasi_static(TOES[:1], q)
    assert e.value.field == "contacts"
    fixed = SpatialRobot.from_urdf(QUADRUPED, base="fixed")
    with pytest.raises(InvalidInputError) as e:
        fixed.quasi_static(["FL_foot"], fixed.neutral())
    assert e.value.field == "base"


@pytest.mark.parametrize("friction", [True, False], ids=["sticking", "frictionless"])
def test_impact_with_lift_off_is_pinocchios_on_the_feet_it_holds(friction):
    """The quadruped's four feet at random states with ``lift_off``: each foot separates or is
    held by complementarity. With each outcome's active set fixed, Pinocchio's
    ``impulseDynamics`` on the held feet gives the same ``v_plus`` and impulses (1e-9), its
    normal impulses push and the separated feet's normal velocities after (by Pinocchio's
    Jacobian) are non-negative. Frictionless feet have exactly one outcome (``W`` positive
    definite: a P-matrix problem); sticking feet (mu = infinity, no slip) may have several, or
    none, where ``impact`` raises ``InvalidInputError`` naming ``contacts``."""
    ours, model, data = both(QUADRUPED)
    contacts = FEET if friction else [f + ":frictionless" for f in FEET]
    rng = np.random.default_rng(23)
    worst, separated, held_counts, outcomes, unresolved = 0.0, 0, set(), 0, 0
    for _ in range(24):
        q, v, _ = random_state(rng, model.nq, model.nv)
        found = ours.impact_outcomes(contacts, q, v, lift_off=True)
        assert friction or len(found) == 1
        if len(found) == 1:
            assert ours.impact(contacts, q, v, lift_off=True).states == found[0].states
        else:
            with pytest.raises(InvalidInputError) as e:
                ours.impact(contacts, q, v, lift_off=True)
            assert e.value.field == "contacts"
            unresolved += 1
        for imp in found:
            outcomes += 1
            held = [c for c, s in zip(contacts, imp.states) if s != "separate"]
            free = [c for c, s in zip(contacts, imp.states) if s == "separate"]
            separated += len(free)
            held_counts.add(len(held))
            names = {h.partition(":")[0] for h in held}
            rows = [r for r, (frame, _) in enumerate(imp.rows) if frame in names]
            others = [r for r in range(len(imp.rows)) if r not in rows]
            assert np.all(imp.impulse[others] == 0.0)
            after, impulse = v, np.zeros(0)
            if held:
                J, _ = contact_rows(model, data, q, v, held)
                pin.impulseDynamics(model, data, q, v, J, 0.0)
                after, impulse = data.dq_after.copy(), data.impulse_c.copy()
                normals = impulse[2::3] if friction else impulse
                assert np.all(normals >= -1e-9 * np.max(np.abs(impulse)))
                worst = max(worst, rel(imp.impulse[rows], impulse))
            worst = max(worst, rel(imp.v_plus, after))
            if free:
                J_free, _ = contact_rows(model, data, q, v, [f.partition(":")[0] + ":frictionless" for f in free])
                assert np.all(J_free @ after >= -1e-9 * max(1.0, np.max(np.abs(v))))
    print(f"lift-off vs Pinocchio on the held feet: {worst:.1e}; {outcomes} outcomes "
          f"({unresolved} states without exactly one), {separated} feet separated; feet held "
          f"{sorted(held_counts)}")
    assert worst < 1e-9 and separated >= 10 and len(held_counts) >= 3


def test_a_floating_joint_inside_the_tree_is_pinocchios(tmp_path):
    """A URDF ``floating`` joint is a free flyer at its origin, as Pinocchio reads it: a 1.5 kg
    payload floating on the quadruped's trunk (a second free flyer inside the tree, nq 26, nv
    24): ``M``, ``nle``, its frames' placements and Jacobians to 1e-10, and the constrained
    dynamics and impact on the four feet to 1e-9, at random states."""
    tree = ET.parse(QUADRUPED)
    root = tree.getroot()
    root.append(ET.fromstring(
        '<link name="payload"><inertial><origin xyz="0.02 0 0.01"/><mass value="1.5"/>'
        '<inertia ixx="0.01" ixy="0.001" ixz="0" iyy="0.02" iyz="0" izz="0.015"/></inertial></link>'))
    root.append(ET.fromstring(
        '<joint name="payload_joint" type="floating"><origin xyz="0.1 0 0.2" rpy="0.2 0.1 0"/>'
        '<parent link="trunk"/><child link="payload"/></joint>'))
    path = tmp_path / "quadruped_payload.urdf"
    tree.write(path)
    ours, model, data = both(path)
    assert (ours.nq, ours.nv) == (model.nq, model.nv) == (26, 24)
    assert ours.joint_names == list(model.names)[1:]
    rng = np.random.default_rng(12)
    lower, upper = -np.ones(model.nq), np.ones(model.nq)
    worst = dict(M=0.0, nle=0.0, frames=0.0, qdd=0.0, lam=0.0, impact=0.0)
    for _ in range(10):
        q = pin.randomConfiguration(model, lower, upper)
        v, tau = rng.uniform(-2, 2, model.nv), rng.uniform(-5, 5, model.nv)
        worst["M"] = max(worst["M"], rel(ours.mass_matrix(q), pin_mass_matrix(model, data, q)))
        worst["nle"] = max(worst["nle"], rel(ours.bias_forces(q, v), pin.nonLinearEffects(model, data, q, v)))
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for name in ("payload", "payload_joint", "FL_foot"):
            fid = model.getFrameId(name)
            worst["frames"] = max(worst["frames"], rel(ours.frame_placement(q, name), data.oMf[fid].homogeneous),
                                  rel(ours.frame_jacobian(q, name, "local"), pin.getFrameJacobian(model, data, fid, pin.LOCAL)))
        J, gamma = contact_rows(model, data, q, v, FEET)
        out = ours.dynamics(FEET, q, v, tau)
        worst["qdd"] = max(worst["qdd"], rel(out.qdd, pin.forwardDynamics(model, data, q, v, tau, J, gamma)))
        worst["lam"] = max(worst["lam"], rel(out.lam, data.lambda_c))
        imp = ours.impact(FEET, q, v)
        pin.impulseDynamics(model, data, q, v, J, 0.0)
        worst["impact"] = max(worst["impact"], rel(imp.v_plus, data.dq_after), rel(imp.impulse, data.impulse_c))
    print({k: f"{w:.1e}" for k, w in worst.items()})
    assert max(worst["M"], worst["nle"], worst["frames"]) < 1e-10 and max(worst["qdd"], worst["lam"], worst["impact"]) < 1e-9, worst


def kkt_inverse(M, A):
    """``[M A^T; A 0]^-1`` by numpy, from Pinocchio's ``M`` and contact rows."""
    n, c = M.shape[0], A.shape[0]
    return np.linalg.inv(np.block([[M, A.T], [A, np.zeros((c, c))]])), n


@pytest.mark.parametrize("variant", ["as_shipped", "massless_shins"])
def test_kkt_blocks_are_the_inverse_of_pinocchios_kkt_matrix(tmp_path, variant):
    """``kkt`` gives the blocks of ``[M A^T; A 0]^-1`` (thesis 5.2), against numpy's inverse of
    the matrix assembled from Pinocchio's ``M`` and contact rows: on four feet (with massless
    shins ``M`` is singular, the KKT matrix regular), and on three with the massless fourth
    shin in the air, where its free rate is left out (zero rows and columns) and the rest is
    the inverse on the other rates. The blocks give ``dynamics``'s ``qdd`` and ``lam``."""
    suffixes, scale = VARIANTS[variant][0], VARIANTS[variant][1]
    ours, model, data = both(scaled_urdf(tmp_path, suffixes, scale) if suffixes else QUADRUPED)
    rng = np.random.default_rng(13)
    worst = dict(blocks=0.0, dynamics=0.0)
    for contacts in (FEET, FEET[1:]):
        for _ in range(5):
            q, v, tau = random_state(rng, model.nq, model.nv)
            out = ours.kkt(contacts, q)
            m_dagger_, a_dagger_, lambda_, a_ = out  # unpacks as the planar robots' kkt
            assert m_dagger_ is out.m_dagger and lambda_ is out.Lambda and a_ is out.A
            free = out.free_rates
            # the FL knee's rate, its massless shin in the air
            assert free == ([8] if variant == "massless_shins" and contacts == FEET[1:] else [])
            assert all(ours.joint_names[k - 5] == "FL_knee" for k in free)  # joint 0 has rates 0..5
            kept = [i for i in range(model.nv) if i not in free]
            J, gamma = contact_rows(model, data, q, v, contacts)
            M = pin_mass_matrix(model, data, q)
            inverse, n = kkt_inverse(M[np.ix_(kept, kept)], J[:, kept])
            m_dagger = np.zeros((model.nv, model.nv))
            m_dagger[np.ix_(kept, kept)] = inverse[:n, :n]
            a_dagger = np.zeros((J.shape[0], model.nv))
            a_dagger[:, kept] = inverse[n:, :n]
            scale_ = max(1.0, np.abs(inverse).max())
            worst["blocks"] = max(worst["blocks"], np.abs(out.m_dagger - m_dagger).max() / scale_,
                                  np.abs(out.a_dagger - a_dagger).max() / scale_,
                                  np.abs(out.Lambda - inverse[n:, n:]).max() / scale_)
            if free:
                continue
            d = ours.dynamics(contacts, q, v, tau)
            h = ours.bias_forces(q, v)
            qdd = out.m_dagger @ (tau - h) - out.a_dagger.T @ d.drift
            lam = -out.a_dagger @ (tau - h) + out.Lambda @ d.drift
            worst["dynamics"] = max(worst["dynamics"], rel(qdd, d.qdd), rel(lam, d.lam))
    print(variant, {k: f"{w:.1e}" for k, w in worst.items()})
    assert worst["blocks"] < 1e-9 and worst["dynamics"] < 1e-9, worst
    # dependent rows: the quadruped's four feet with a fifth row on a foot already held
    with pytest.raises(SingularKktError):
        ours.kkt(FEET + ["FL_foot:frictionless"], ours.neutral())
