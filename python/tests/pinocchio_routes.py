"""Pinocchio's side of the spatial comparisons: its contact rows for ours, the kinematics and
rigid-body terms compared, its planar root joint, and the relative error the comparisons
bound. Imported by tests that have first skipped where Pinocchio (`pip
install pin`, in the test extra) is missing."""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def frame_id(model, name: str) -> int:
    """The frame Pinocchio names ``name`` (a link's body frame where a joint shares it)."""
    ids = [i for i, f in enumerate(model.frames) if f.name == name]
    assert ids, f"Pinocchio has no frame `{name}`"
    body = [i for i in ids if model.frames[i].type == pin.FrameType.BODY]
    return (body or ids)[0]


def contact_rows(model, data, q, v, contacts, friction_rows=(0, 1, 2)):
    """Pinocchio's contact Jacobian and drift for our rows: the frames' LOCAL_WORLD_ALIGNED
    linear Jacobians (world x, y, z: two tangents and the normal on flat z-up ground;
    ``friction_rows=(0, 2)``, x and z, on a planar base; the normal alone for a
    ``name:frictionless`` contact) and their classical accelerations at zero joint
    acceleration."""
    pin.computeJointJacobians(model, data, q)
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    pin.updateFramePlacements(model, data)
    J, gamma = [], []
    for spec in contacts:
        name, _, kind = spec.partition(":")
        fid = frame_id(model, name)
        rows = [2] if kind == "frictionless" else list(friction_rows)
        J.append(pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3][rows])
        gamma.append(pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear[rows])
    return np.vstack(J), np.concatenate(gamma)


def kinematics_errors(ours, model, data, q, v, frames, pinocchio_state=None) -> dict[str, float]:
    """Our ``M``, ``nle``, frame placements and Jacobians (world, local, local-world-aligned)
    at ``(q, v)`` against Pinocchio's at ``pinocchio_state`` (the same arrays by default), as
    ``rel`` errors by quantity."""
    qp, vp = pinocchio_state if pinocchio_state is not None else (q, v)
    M = pin.crba(model, data, qp)
    errors = dict(M=rel(ours.mass_matrix(q), np.triu(M) + np.triu(M, 1).T),
                  nle=rel(ours.bias_forces(q, v), pin.nonLinearEffects(model, data, qp, vp)),
                  placement=0.0, jacobian=0.0)
    pin.computeJointJacobians(model, data, qp)
    pin.updateFramePlacements(model, data)
    for name in frames:
        fid = model.getFrameId(name)
        errors["placement"] = max(errors["placement"], rel(ours.frame_placement(q, name), data.oMf[fid].homogeneous))
        for ref, pref in [("local", pin.LOCAL), ("world", pin.WORLD), ("local_world_aligned", pin.LOCAL_WORLD_ALIGNED)]:
            J = pin.getFrameJacobian(model, data, fid, pref)
            errors["jacobian"] = max(errors["jacobian"], rel(ours.frame_jacobian(q, name, ref), J))
    return errors


def dynamics_errors(ours, model, data, contacts, q, v, tau, pinocchio_state=None,
                    friction_rows=(0, 1, 2)) -> dict[str, float]:
    """Our contact rows, drift, constrained ``q̈`` and ``λ``, and plastic impact at ``(q, v, τ)``
    against Pinocchio's ``forwardDynamics`` and ``impulseDynamics`` with its rows of the same
    contacts (``contact_rows``) at ``pinocchio_state`` (the same arrays by default), as ``rel``
    errors by quantity."""
    qp, vp = pinocchio_state if pinocchio_state is not None else (q, v)
    J, gamma = contact_rows(model, data, qp, vp, contacts, friction_rows)
    out = ours.dynamics(contacts, q, v, tau)
    errors = dict(A=rel(out.A, J), drift=rel(out.drift, gamma),
                  qdd=rel(out.qdd, pin.forwardDynamics(model, data, qp, vp, tau, J, gamma)),
                  lam=rel(out.lam, data.lambda_c))
    imp = ours.impact(contacts, q, v)
    pin.impulseDynamics(model, data, qp, vp, J, 0.0)
    errors |= dict(v_plus=rel(imp.v_plus, data.dq_after), impulse=rel(imp.impulse, data.impulse_c))
    return errors


def planar_root_joint():
    """Pinocchio's planar base as ours: a composite root joint translating along the world's
    x and z, then turning about y, with ``q = [x, z, theta]`` and ``v = dq/dt``."""
    joint = pin.JointModelComposite()
    for sub in (pin.JointModelPX(), pin.JointModelPZ(), pin.JointModelRY()):
        joint.addJoint(sub)
    return joint


def rel(a, b) -> float:
    """``max |a − b|`` over ``max(1, max |b|)`` (0 for two empty arrays)."""
    a, b = np.asarray(a), np.asarray(b)
    if b.size == 0:
        return 0.0 if a.size == 0 else np.inf
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))
