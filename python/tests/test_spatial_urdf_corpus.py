"""Robots we did not design for (issue 32): every URDF of Pinocchio's own robot collection,
`example-robot-data` (in the test extra) — quadrupeds, humanoids, arms, hands, drones — loaded
by ``SpatialRobot.from_urdf`` and by Pinocchio, with the root link free-flying, planar (in the
world's x-z plane; Pinocchio's composite root joint of PX, PZ, RY) and fixed.

Each one either matches Pinocchio — the same joints in the same order, so that
``from_pinocchio`` passes arrays across, and at random states ``M``, ``nle``, every frame's
placement and Jacobian (world, local and local-world-aligned) to 1e-10 of their scale,
``neutral`` and ``q ⊕ v``; for the legged ones, the constrained dynamics and the plastic
impact on their feet to 1e-9 and the quasi-static standing against Pinocchio's gravity — or
is refused with a typed error naming a field that a check of our own, from the XML, finds
invalid: a rotational inertia with a negative eigenvalue beyond round-off (which Pinocchio
takes as it is), or a file without a link (a xacro left unexpanded, which Pinocchio refuses
too)."""

from __future__ import annotations

import importlib.metadata
import pathlib
import pickle
import re
import xml.etree.ElementTree as ET
import zlib

import numpy as np
import pytest

from selfmanip import SpatialRobot
from selfmanip.errors import InvalidInputError, SingularKktError

pin = pytest.importorskip("pinocchio", reason="Pinocchio (`pip install pin`, in the test extra) is the independent route")

from pinocchio_routes import contact_rows, frame_id, planar_root_joint, rel  # noqa: E402


def robots_dir() -> pathlib.Path | None:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    return pathlib.Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))


ROBOTS = robots_dir()
URDFS = sorted(ROBOTS.rglob("*.urdf")) if ROBOTS else []
pytestmark = pytest.mark.skipif(not URDFS, reason="`pip install example-robot-data` (in the test extra)")


def pinocchio_model(path: pathlib.Path, base: str = "free_flyer"):
    """Pinocchio's model of ``path`` with its root link free-flying, planar or fixed, or None
    where it cannot read the file."""
    try:
        if base == "fixed":
            return pin.buildModelFromUrdf(str(path))
        root = planar_root_joint() if base == "planar" else pin.JointModelFreeFlyer()
        return pin.buildModelFromUrdf(str(path), root)
    except (RuntimeError, ValueError):
        return None


def refusal_is_due(path: pathlib.Path, message: str) -> bool:
    """Whether the XML itself shows what a refusal names (read here, not by the engine)."""
    root = ET.parse(path).getroot()
    if "the URDF has no link" in message:
        return root.find("link") is None
    field = re.search(r"link\[([^\]]+)\]\.inertial\.inertia", message)
    if field:
        link = next(l for l in root.iter("link") if l.get("name") == field.group(1))
        a = {k: float(v) for k, v in link.find("inertial/inertia").attrib.items()}
        mass = float(link.find("inertial/mass").get("value"))
        inertia = np.array([[a["ixx"], a["ixy"], a["ixz"]],
                            [a["ixy"], a["iyy"], a["iyz"]],
                            [a["ixz"], a["iyz"], a["izz"]]])
        # a negative eigenvalue well beyond round-off of the entries or of m·(1 m)²
        return np.linalg.eigvalsh(inertia).min() < -1e-9 * max(abs(inertia).max(), mass)
    return False


def random_state(model, path: pathlib.Path):
    """A configuration within the URDF's joint limits (±1 rad or m where it gives none, at
    most ±3) and a velocity, from a generator seeded by the file's name."""
    seed = zlib.crc32(path.name.encode())
    rng = np.random.default_rng(seed)
    pin.seed(seed)
    lower = np.where(np.isfinite(model.lowerPositionLimit), model.lowerPositionLimit, -1.0)
    upper = np.where(np.isfinite(model.upperPositionLimit), model.upperPositionLimit, 1.0)
    lower, upper = np.maximum(lower, -3.0), np.minimum(upper, 3.0)
    while True:
        yield pin.randomConfiguration(model, lower, upper), rng.normal(size=model.nv), rng.normal(size=model.nv)


@pytest.mark.parametrize("base", ["free_flyer", "planar", "fixed"])
@pytest.mark.parametrize("path", URDFS, ids=lambda p: str(p.relative_to(ROBOTS)) if ROBOTS else str(p))
def test_a_third_party_urdf_matches_pinocchio_or_is_refused_by_field(path: pathlib.Path, base: str):
    # what Pinocchio cannot read (urdfdom refuses a file without a link) we refuse too
    model = pinocchio_model(path, base)
    try:
        ours = SpatialRobot.from_urdf(path, base=base)
    except InvalidInputError as e:
        assert refusal_is_due(path, str(e)), f"refused, and the XML shows no reason: {e}"
        return
    assert model is not None, "Pinocchio refuses this URDF and we read it"
    data = model.createData()
    assert ours.joint_names == list(model.names)[1:]
    assert ours.nv == model.nv
    states = random_state(model, path)
    for _ in range(2):
        qp, vp, _ = next(states)
        q, v = ours.from_pinocchio(qp, vp)
        mp = pin.crba(model, data, qp)
        mp = np.triu(mp) + np.triu(mp, 1).T
        m = ours.mass_matrix(q)
        assert rel(m, mp) < 1e-10
        hp = pin.nonLinearEffects(model, data, qp, vp)
        h = ours.bias_forces(q, v)
        assert rel(h, hp) < 1e-10
        pin.framesForwardKinematics(model, data, qp)
        pin.computeJointJacobians(model, data, qp)
        reach = max(1.0, max(np.abs(f.translation).max() for f in data.oMf))
        for name in ours.frame_names:
            fid = frame_id(model, name)
            placement = ours.frame_placement(q, name)
            assert np.allclose(placement, data.oMf[fid].homogeneous, rtol=0, atol=1e-10 * reach), name
            for frame, ref in (("world", pin.WORLD), ("local", pin.LOCAL),
                               ("local_world_aligned", pin.LOCAL_WORLD_ALIGNED)):
                jacobian = ours.frame_jacobian(q, name, frame=frame)
                if model.nv == 0:
                    # a single body welded to the world (Pinocchio crashes on this one)
                    assert jacobian.shape == (6, 0)
                    continue
                expected = pin.getFrameJacobian(model, data, fid, ref)
                assert np.allclose(jacobian, expected, rtol=0, atol=1e-10 * reach), (name, frame)
        # the configuration group: q ⊕ v and back, in Pinocchio's layout
        q1, _ = ours.to_pinocchio(ours.integrate(q, vp), vp)
        assert np.allclose(q1, pin.integrate(model, qp, vp), rtol=0, atol=1e-12 * max(1.0, np.abs(qp).max(initial=0.0)))
    q0, _ = ours.to_pinocchio(ours.neutral(), np.zeros(model.nv))
    assert np.array_equal(q0, pin.neutral(model))


def feet(model) -> list[str]:
    """A legged robot's feet, read off Pinocchio's model: the links named `…foot` or `…sole`
    (`…_link`), one per joint they hang from (iCub's `l_foot` and `l_sole` are one body)."""
    named = [f for f in model.frames if f.type == pin.FrameType.BODY
             and re.search(r"(foot|sole)(_link)?$", f.name, re.I)]
    by_joint = {}
    for f in named:
        by_joint.setdefault(f.parentJoint, f.name)
    return list(by_joint.values())


def loads(path: pathlib.Path) -> bool:
    try:
        SpatialRobot.from_urdf(path)
    except InvalidInputError:
        return False
    return True


# the robots with two feet or more that both read (the test above checks the refusals)
LEGGED = [p for p in URDFS if (m := pinocchio_model(p)) is not None and len(feet(m)) >= 2 and loads(p)]


def massless_rates(model, contacts) -> list[int]:
    """The rates of the joints whose whole subtree carries no mass and no contact, read off
    Pinocchio's model (which takes such links as they are and cannot solve with them)."""
    feet_joints = {model.frames[frame_id(model, c.partition(":")[0])].parentJoint for c in contacts}
    rates = []
    for j in range(1, model.njoints):
        subtree = model.subtrees[j]
        if all(model.inertias[k].mass == 0 and not model.inertias[k].inertia.any() for k in subtree) \
                and not feet_joints.intersection(subtree):
            rates.extend(range(model.idx_vs[j], model.idx_vs[j] + model.nvs[j]))
    return sorted(rates)


def tolerance(m: np.ndarray) -> float:
    """1e-9, or what the conditioning of ``M`` allows two sound solvers to differ by (iCub's
    point-mass links make it 5e9)."""
    return 1e-9 + 100 * np.linalg.cond(m) * np.finfo(float).eps


# a floating base's rates, and a foot's rows with friction (world x, y, z; x, z in the plane)
FLOATING = {"free_flyer": (6, (0, 1, 2)), "planar": (3, (0, 2))}


@pytest.mark.parametrize("base", list(FLOATING))
@pytest.mark.parametrize("path", LEGGED, ids=lambda p: str(p.relative_to(ROBOTS)) if ROBOTS else str(p))
def test_a_third_party_robot_on_its_feet_matches_pinocchio(path: pathlib.Path, base: str):
    """On its feet, each as a point with friction, then all but one frictionless: ``q̈`` and
    ``λ`` against ``pin.forwardDynamics``, the plastic impact against ``pin.impulseDynamics``,
    with the same contact Jacobian and drift, free-flying and in the plane. A massless limb in the air (Romeo's fingers)
    follows the accelerations given for it (zero here), and the rest of the robot is
    Pinocchio's with that limb welded; a set of feet whose rows are dependent (Solo's
    two-joint legs) is refused as redundant where Pinocchio's Jacobian is rank deficient."""
    full = pinocchio_model(path, base)
    ours = SpatialRobot.from_urdf(path, base=base)
    rows = FLOATING[base][1]
    names = feet(full)
    states = random_state(full, path)
    compared = 0
    for contacts in (names, [n + ":frictionless" for n in names[1:]] + names[:1]):
        free = massless_rates(full, contacts)
        assert ours.free_rates(contacts) == free
        locked = sorted({j for j in range(1, full.njoints) if full.idx_vs[j] in free})
        kept = [i for i in range(full.nv) if i not in free]
        for _ in range(2):
            qp, vp, tau = next(states)
            q, v = ours.from_pinocchio(qp, vp)
            # Pinocchio's robot: the massless limbs welded where they are
            model = pin.buildReducedModel(full, locked, qp) if locked else full
            data = model.createData()
            qr = np.concatenate([qp[full.idx_qs[j]:full.idx_qs[j] + full.nqs[j]]
                                 for j in range(1, full.njoints) if j not in locked])
            vr, taur = vp[kept], tau[kept]
            J, gamma = contact_rows(model, data, qr, vr, contacts, friction_rows=rows)
            if np.linalg.matrix_rank(J) < J.shape[0]:
                with pytest.raises(SingularKktError) as refused:
                    ours.dynamics(contacts, q, v, tau, np.zeros(len(free)) if free else None)
                assert refused.value.kind == "RedundantConstraints"
                continue
            out = ours.dynamics(contacts, q, v, tau, np.zeros(len(free)) if free else None)
            qdd = pin.forwardDynamics(model, data, qr, vr, taur, J, gamma)
            tol = tolerance(pin.crba(model, data, qr))
            assert rel(out.qdd[kept], qdd) < tol and rel(out.lam, data.lambda_c) < tol
            assert not out.qdd[free].any()
            imp = ours.impact(contacts, q, v)
            pin.impulseDynamics(model, data, qr, vr, J, 0.0)
            assert rel(imp.v_plus[kept], data.dq_after) < tol and rel(imp.impulse, data.impulse_c) < tol
            compared += 1
    assert compared > 0


@pytest.mark.parametrize("base", list(FLOATING))
@pytest.mark.parametrize("path", LEGGED, ids=lambda p: str(p.relative_to(ROBOTS)) if ROBOTS else str(p))
def test_a_third_party_robot_stands_against_pinocchios_gravity(path: pathlib.Path, base: str):
    """Quasi-static standing on its feet (thesis 4.21-4.22) against Pinocchio's generalized
    gravity ``g(q)``: at rest ``g = [0; τ] + Jᵀλ`` for the external forces and their torques,
    and every internal force ``n`` pushes nothing into the base (``J_bᵀ n = 0``) and takes the
    torques ``−J_jᵀ n``. Where the feet cannot hold the base (two point feet cannot resist a
    moment about the line through them: the bipeds), it is refused naming ``contacts``, and
    the least squares of ``J_bᵀ λ = g_b`` leave a residual."""
    model = pinocchio_model(path, base)
    data = model.createData()
    ours = SpatialRobot.from_urdf(path, base=base)
    nb, rows = FLOATING[base]
    names = feet(model)
    qp, _, _ = next(random_state(model, path))
    q, _ = ours.from_pinocchio(qp, np.zeros(model.nv))
    J, _ = contact_rows(model, data, qp, np.zeros(model.nv), names, friction_rows=rows)
    g = pin.computeGeneralizedGravity(model, data, qp)
    scale = max(1.0, abs(g).max())
    try:
        qs = ours.quasi_static(names, q)
    except InvalidInputError as e:
        assert e.field == "contacts"
        lam, *_ = np.linalg.lstsq(J[:, :nb].T, g[:nb], rcond=None)
        assert abs(J[:, :nb].T @ lam - g[:nb]).max() > 1e-6 * scale
        return
    held = np.concatenate([np.zeros(nb), qs.tau_external]) + J.T @ qs.lam_external
    assert abs(held - g).max() < 1e-10 * scale
    pushed = J.T @ qs.internal_basis
    assert abs(pushed[:nb]).max() < 1e-12 * max(1.0, abs(J).max())
    assert abs(pushed[nb:] + qs.internal_torques).max() < 1e-12 * max(1.0, abs(J).max())


def sole_corners(model, sole: str, half_length_m: float = 0.08, half_width_m: float = 0.04):
    """Four corners of a flat foot about the sole frame ``sole``, as added frames."""
    return {f"{sole}_{x}_{y}": {"parent": sole, "xyz_m": [sx * half_length_m, sy * half_width_m, 0.0]}
            for x, sx in (("toe", 1), ("heel", -1)) for y, sy in (("left", 1), ("right", -1))}


BIPEDS = [p for p in LEGGED if len(feet(pinocchio_model(p))) == 2]


@pytest.mark.parametrize("path", BIPEDS, ids=lambda p: str(p.relative_to(ROBOTS)) if ROBOTS else str(p))
def test_a_biped_stands_on_the_corners_of_its_feet(path: pathlib.Path):
    """A biped refused on two point feet stands on the four corners of each sole, frames added
    to its URDF (``frames=``): the added frames are Pinocchio's operational frames at the same
    placements (placements and Jacobians), and the quasi-static forces and torques on the eight
    corners balance Pinocchio's generalized gravity. The added frames survive a pickle."""
    model = pinocchio_model(path)
    names = feet(model)
    added = {k: v for sole in names for k, v in sole_corners(model, sole).items()}
    ours = SpatialRobot.from_urdf(path, frames=added)
    for name, spec in added.items():
        parent = model.frames[frame_id(model, spec["parent"])]
        placement = parent.placement * pin.SE3(np.eye(3), np.array(spec["xyz_m"]))
        model.addFrame(pin.Frame(name, parent.parentJoint, placement, pin.FrameType.OP_FRAME))
    data = model.createData()
    qp, _, _ = next(random_state(model, path))
    q, _ = ours.from_pinocchio(qp, np.zeros(model.nv))
    pin.framesForwardKinematics(model, data, qp)
    pin.computeJointJacobians(model, data, qp)
    for name in added:
        fid = frame_id(model, name)
        assert rel(ours.frame_placement(q, name), data.oMf[fid].homogeneous) < 1e-12
        expected = pin.getFrameJacobian(model, data, fid, pin.WORLD)
        assert rel(ours.frame_jacobian(q, name, frame="world"), expected) < 1e-12
    corners = list(added)
    J, _ = contact_rows(model, data, qp, np.zeros(model.nv), corners)
    g = pin.computeGeneralizedGravity(model, data, qp)
    qs = ours.quasi_static(corners, q)
    held = np.concatenate([np.zeros(6), qs.tau_external]) + J.T @ qs.lam_external
    assert abs(held - g).max() < 1e-10 * max(1.0, abs(g).max())
    copy = pickle.loads(pickle.dumps(ours))
    assert np.array_equal(copy.frame_placement(q, corners[0]), ours.frame_placement(q, corners[0]))


def test_added_frames_name_their_bad_fields():
    path = next(p for p in URDFS if p.name == "solo12.urdf")
    cases = [({"toe": {"parent": "nowhere"}}, "frames[toe].parent"),
             ({"toe": {}}, "frames[toe].parent"),
             ({"FL_FOOT": {"parent": "base_link"}}, "frames[FL_FOOT]"),
             ({"toe": {"parent": "FL_FOOT", "xyz_m": [0, 0]}}, "frames[toe].xyz_m"),
             ({"toe": {"parent": "FL_FOOT", "xyz_m": [0, float("nan"), 0]}}, "frames[toe].xyz_m"),
             ({"toe": {"parent": "FL_FOOT", "offset": [0, 0, 0]}}, "frames[toe].offset")]
    for frames, field in cases:
        with pytest.raises(InvalidInputError) as bad:
            SpatialRobot.from_urdf(path, frames=frames)
        assert bad.value.field == field, (frames, bad.value)
    with pytest.raises(TypeError):
        SpatialRobot.from_urdf(path, frames=["toe"])
