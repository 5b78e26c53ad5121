#!/usr/bin/env python3
"""Pinocchio's (and MuJoCo's) timings on the quadruped of `benches/spatial.rs`, beside ours.

Times Pinocchio's constrained forward dynamics (`pin.constraintDynamics`, four 3-D foot
contacts: kinematics, CRBA, bias forces, contact Jacobians and the KKT solve in one C++ call),
`pin.crba` and `pin.nonLinearEffects` on `tests/data/urdf/quadruped12.urdf` at the standing,
moving state of the bench (and the quadruped on a planar base, and the six-legged RHex),
and prints them with the matching criterion estimates of
`cargo bench --bench spatial` (run that first) and the ratio. Python's call overhead
(about 0.1–0.5 µs a call, measured here on an empty binding call) is reported, not subtracted.

    cargo bench --bench spatial && python3 scripts/bench-pinocchio.py
"""
import json
import math
import pathlib
import timeit

import numpy as np
import pinocchio as pin

ROOT = pathlib.Path(__file__).resolve().parent.parent
URDF = ROOT / "tests/data/urdf/quadruped12.urdf"
CRITERION = ROOT / "target/criterion/spatial_quadruped"
FEET = ["FL_foot", "FR_foot", "HL_foot", "HR_foot"]


def standing_state(model, planar=False):
    """The bench's state: base at 0.4 m, level; legs bent by 0.5 rad; a small motion. On a
    free-flying base ``q = [p, quat, legs]``, on a planar one ``q = [x, z, theta, legs]``."""
    height, legs, base_rates = (1, 3, 3) if planar else (2, 7, 6)
    q = pin.neutral(model)
    q[height] = 0.4
    for leg in range(4):
        q[legs + 3 * leg + 1] = 0.5
        q[legs + 3 * leg + 2] = -1.0
    v = np.array([0.1 * math.sin(0.7 * i) for i in range(model.nv)])
    tau = np.array([0.0 if i < base_rates else 2.0 * math.cos(1.3 * i) for i in range(model.nv)])
    return q, v, tau


def kkt_forward_dynamics_us(model, data, q, v, tau, frames, rows):
    """Pinocchio's KKT forward dynamics (``computeAllTerms``, then ``forwardDynamics``) with the
    ``rows`` (world axes) of the frames' LOCAL_WORLD_ALIGNED linear Jacobians and drift, the
    rows computed once outside the timing: for contacts Pinocchio has no model of."""
    pin.computeJointJacobians(model, data, q)
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    pin.updateFramePlacements(model, data)
    ids = [model.getFrameId(f) for f in frames]
    J = np.vstack([pin.getFrameJacobian(model, data, i, pin.LOCAL_WORLD_ALIGNED)[list(rows)] for i in ids])
    gamma = np.concatenate([pin.getFrameClassicalAcceleration(model, data, i, pin.LOCAL_WORLD_ALIGNED).linear[list(rows)]
                            for i in ids])

    def fd():
        pin.computeAllTerms(model, data, q, v)
        return pin.forwardDynamics(model, data, tau, J, gamma)

    return per_call_us(fd)


def per_call_us(fn, repeat=7):
    timer = timeit.Timer(fn)
    n, _ = timer.autorange()
    return 1e6 * min(timer.repeat(repeat=repeat, number=n)) / n


def criterion_us(name):
    path = CRITERION / name.replace("/", "_") / "new/estimates.json"
    if not path.exists():
        return None
    return json.loads(path.read_text())["median"]["point_estimate"] / 1e3


def main():
    model = pin.buildModelFromUrdf(str(URDF), pin.JointModelFreeFlyer())
    data = model.createData()
    q, v, tau = standing_state(model)
    contacts = pin.StdVec_RigidConstraintModel()
    for foot in FEET:
        frame = model.frames[model.getFrameId(foot)]
        contacts.append(
            pin.RigidConstraintModel(
                pin.ContactType.CONTACT_3D, model, frame.parentJoint, frame.placement, pin.LOCAL_WORLD_ALIGNED
            )
        )
    contact_datas = pin.StdVec_RigidConstraintData()
    for c in contacts:
        contact_datas.append(c.createData())
    pin.initConstraintDynamics(model, data, contacts, contact_datas)
    rows = [
        ("forward_dynamics_4_feet/massive_legs", lambda: pin.constraintDynamics(model, data, q, v, tau, contacts, contact_datas)),
        ("crba", lambda: pin.crba(model, data, q)),
        ("nonlinear_effects", lambda: pin.nonLinearEffects(model, data, q, v)),
    ]
    overhead = per_call_us(lambda: model.nq)
    print(f"Pinocchio {pin.__version__}, {URDF.name}: nq {model.nq}, nv {model.nv}; "
          f"Python call overhead ≈ {overhead:.2f} µs")
    print(f"{'quantity':40s} {'Pinocchio µs':>13s} {'selfmanip µs':>13s} {'ratio':>7s}")
    for name, fn in rows:
        theirs = per_call_us(fn)
        ours = criterion_us(name)
        ratio = f"{ours / theirs:7.2f}" if ours else "      -"
        ours_s = f"{ours:13.2f}" if ours else "  (no bench)"
        print(f"{name:40s} {theirs:13.2f} {ours_s} {ratio}")
    ours = criterion_us("forward_dynamics_4_feet/massless_shins")
    if ours:
        print(f"{'forward_dynamics_4_feet/massless_shins':40s} {'(singular M)':>13s} {ours:13.2f}")
    planar()
    rhex()
    mujoco_flight(q, v, tau)


def mujoco_flight(q, v, tau):
    """MuJoCo's ``mj_forward`` on the same URDF through its own compiler, on a free joint, with
    its constraints off: kinematics, ``M`` and its factorization, the bias forces and ``q̈`` in
    flight, against ``forward_dynamics_flight``. (MuJoCo's contacts are soft, solved by an
    optimization: its constrained step is no KKT solve to time against ours.) The state is
    the bench's, mapped to MuJoCo's layout: quaternion ``w`` first, free-joint velocity
    ``[R v_lin, ω]``, joints by name."""
    try:
        import mujoco
    except ImportError:
        print("mujoco not installed: `pip install mujoco` for its row")
        return
    spec = mujoco.MjSpec.from_file(str(URDF))
    spec.worldbody.first_body().add_freejoint()
    m = spec.compile()
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    d = mujoco.MjData(m)
    model = pin.buildModelFromUrdf(str(URDF), pin.JointModelFreeFlyer())
    d.qpos[:3] = q[:3]
    d.qpos[3:7] = [q[6], q[3], q[4], q[5]]
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, d.qpos[3:7])
    d.qvel[:3] = R.reshape(3, 3) @ v[:3]
    d.qvel[3:6] = v[3:6]
    for i, name in enumerate(list(model.names)[2:]):
        j = m.joint(name)
        d.qpos[j.qposadr[0]] = q[7 + i]
        d.qvel[j.dofadr[0]] = v[6 + i]
        d.qfrc_applied[j.dofadr[0]] = tau[6 + i]
    theirs = per_call_us(lambda: mujoco.mj_forward(m, d))
    ours = criterion_us("forward_dynamics_flight")
    name = f"forward_dynamics_flight (MuJoCo {mujoco.__version__})"
    print(f"{name:40s} {theirs:13.2f} " + (f"{ours:13.2f} {ours / theirs:7.2f}" if ours else "  (no bench)"))


def planar():
    """The quadruped on a planar base (Pinocchio's composite root joint of PX, PZ, RY), its
    feet held in the plane (rows world x, z; Pinocchio has no two-row contact model)."""
    root = pin.JointModelComposite()
    for sub in (pin.JointModelPX(), pin.JointModelPZ(), pin.JointModelRY()):
        root.addJoint(sub)
    model = pin.buildModelFromUrdf(str(URDF), root)
    q, v, tau = standing_state(model, planar=True)
    theirs = kkt_forward_dynamics_us(model, model.createData(), q, v, tau, FEET, (0, 2))
    ours = criterion_us("forward_dynamics_4_feet/planar_base")
    name = "forward_dynamics_4_feet/planar_base"
    print(f"{name:40s} {theirs:13.2f} " + (f"{ours:13.2f} {ours / theirs:7.2f}" if ours else "  (no bench)"))


def rhex():
    """The six-legged RHex of `benches/spatial.rs` (`tests/data/urdf/rhex6.urdf`, Table 4.2's
    legs) on six frictionless toes (one row each; Pinocchio has no one-row contact model)."""
    model = pin.buildModelFromUrdf(str(ROOT / "tests/data/urdf/rhex6.urdf"), pin.JointModelFreeFlyer())
    q = pin.neutral(model)
    q[2] = 0.17 * math.cos(0.3)
    q[7:] = 0.3
    v = np.array([0.1 * math.sin(0.7 * i) for i in range(model.nv)])
    tau = np.array([0.0 if i < 6 else 1.0 for i in range(model.nv)])
    toes = [f"{p}_{s}_toe" for p in ("front", "middle", "rear") for s in ("left", "right")]
    theirs = kkt_forward_dynamics_us(model, model.createData(), q, v, tau, toes, (2,))
    path = ROOT / "target/criterion/spatial_rhex/forward_dynamics_6_toes_table_4_2_legs/new/estimates.json"
    ours = json.loads(path.read_text())["median"]["point_estimate"] / 1e3 if path.exists() else None
    name = "rhex6 forward_dynamics_6_toes/table_4_2_legs"
    print(f"{name:40s} {theirs:13.2f} " + (f"{ours:13.2f} {ours / theirs:7.2f}" if ours else "  (no bench)"))


if __name__ == "__main__":
    main()
