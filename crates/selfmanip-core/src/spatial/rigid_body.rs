//! Joint-space inertia by the composite-rigid-body algorithm and inverse dynamics by the
//! recursive Newton–Euler algorithm, in world coordinates (Featherstone 2008, §5.3 and §6.2;
//! Pinocchio's `crba` and `rnea`/`nonLinearEffects`). Both are exact for massless bodies:
//! nothing is ever divided by a mass, so a zero-mass link gives the zero rows and columns of
//! `M` it should (thesis §5.1: the singular `M̄` of massless limbs).
#![allow(non_snake_case)]
use super::error::SpatialResult;
use super::kinematics::{
    forward_kinematics, forward_kinematics_velocity, joint_motion, LimbJoint, SpatialData,
};
use super::model::{JointKind, SpatialModel};
use super::motion::{Force, Motion};
use super::se3::skew;
use crate::error::check_vector;
use nalgebra::{DVector, Vector6};

/// `M(q)` into `data.M` (Featherstone 2008, Table 6.2, with world-frame composite inertias
/// `⁰Yᶜᵢ = ⁰Yᵢ + Σ_children ⁰Yᶜ` at the world origin, [`super::inertia::OriginInertia`]): `M[λ*, i] = ⁰Sⱼᵀ ⁰Yᶜᵢ ⁰Sᵢ` for each `j` supporting `i`.
pub fn crba(model: &SpatialModel, data: &mut SpatialData, q: &[f64]) -> SpatialResult<()> {
    forward_kinematics(model, data, q)?;
    mass_matrix_from_kinematics(model, data);
    Ok(())
}

/// The CRBA sweep on the kinematics already in `data`.
pub(crate) fn mass_matrix_from_kinematics(model: &SpatialModel, data: &mut SpatialData) {
    data.oIc.copy_from_slice(&data.oI);
    for i in (0..model.joints.len()).rev() {
        mass_columns(model, data, i);
        if let Some(p) = model.joints[i].parent {
            // parents come first: p < i
            let x = data.oIc[i];
            data.oIc[p].add(&x);
        }
    }
}

/// Joint `i`'s columns of `M` from its composite inertia `⁰Yᶜᵢ` (complete once its children
/// are added): the force column `F = ⁰Yᶜᵢ ⁰S_c` of each of its rates `c`, projected on every
/// column supporting it — its own joint's up to `c`, then each ancestor's: `⁰S_rᵀ F` for
/// each of its rates `r`, a free flyer's six at once as `Ad(⁰Mⱼ)ᵀ F` (its columns are `Ad(⁰Mⱼ)`,
/// [`super::kinematics::forward_kinematics`]). Only the entries on the tree's sparsity (a
/// rate and its ancestors) are written: the others are zero from `SpatialData::new` and stay
/// so ([`SpatialData::M`]).
fn mass_columns(model: &SpatialModel, data: &mut SpatialData, i: usize) {
    let joint = &model.joints[i];
    let nv = model.nv;
    if joint.kind == JointKind::FreeFlyer && joint.parent.is_none() {
        return root_block(data, joint.idx_v, nv, i);
    }
    if let Some(limb) = data.limb_joints[i] {
        return match limb.n_above {
            0 => limb_column::<0>(data, nv, i, &limb),
            1 => limb_column::<1>(data, nv, i, &limb),
            _ => limb_column::<2>(data, nv, i, &limb),
        };
    }
    let (s, m) = (data.oS.as_slice().as_chunks::<6>().0, data.M.as_mut_slice());
    let y = &data.oIc[i];
    let mut put = |r: usize, c: usize, x: f64| {
        m[r + c * nv] = x;
        m[c + r * nv] = x;
    };
    for c in joint.idx_v..joint.idx_v + joint.kind.nv() {
        let force = y.apply(&Motion::from_vector(&Vector6::from(s[c])));
        let F: [f64; 6] = force.to_vector().into();
        (joint.idx_v..=c).for_each(|r| put(r, c, dot6(&s[r], &F)));
        let mut ancestor = joint.parent;
        while let Some(a) = ancestor {
            let aj = &model.joints[a];
            if aj.kind == JointKind::FreeFlyer {
                let [lin, ang] = free_flyer_rows(&data.oMi[a], &force);
                let r = aj.idx_v;
                put(r, c, lin.x);
                put(r + 1, c, lin.y);
                put(r + 2, c, lin.z);
                put(r + 3, c, ang.x);
                put(r + 4, c, ang.y);
                put(r + 5, c, ang.z);
            } else {
                // a one-rate joint's row, or each of a planar base's three
                let rates = aj.idx_v..aj.idx_v + aj.kind.nv();
                for (r, column) in rates.clone().zip(&s[rates]) {
                    put(r, c, dot6(column, &F));
                }
            }
            ancestor = aj.parent;
        }
    }
}

/// `⁰Sᵀ F` for one spatial column `⁰S` and force `F` (stacked, linear first), summed in index
/// order from zero (as nalgebra's `dot` of six entries).
fn dot6(s: &[f64; 6], f: &[f64; 6]) -> f64 {
    s.iter().zip(f).fold(0.0, |x, (a, b)| x + a * b)
}

/// A free flyer's six entries `Ad(g)ᵀ F` of a force column: `Ad(g)ᵀ [f; n] = [Rᵀ f; Rᵀ (n − p × f)]`
/// (its columns are `Ad(g)`, `g = ⁰Mⱼ`).
fn free_flyer_rows(g: &super::se3::SE3, force: &Force) -> [nalgebra::Vector3<f64>; 2] {
    let n = force.angular - g.translation.cross(&force.linear);
    [g.rotation.tr_mul(&force.linear), g.rotation.tr_mul(&n)]
}

/// [`mass_columns`] for a [`LimbJoint`] `i` with `D` one-rate joints above it: its column `c`
/// holds `⁰Sᵣᵀ F` on its own rate and the `D` above, and the root's `Ad(g)ᵀ F`, `F = ⁰Yᶜᵢ
/// ⁰S_c` — the general route's entries, written through the column's slice and mirrored into
/// row `c` of the columns before it.
fn limb_column<const D: usize>(data: &mut SpatialData, nv: usize, i: usize, limb: &LimbJoint) {
    let s = data.oS.as_slice().as_chunks::<6>().0;
    let c = limb.rate;
    let force = data.oIc[i].apply(&Motion::from_vector(&Vector6::from(s[c])));
    let F: [f64; 6] = force.to_vector().into();
    let [lin, ang] = free_flyer_rows(&data.oMi[limb.root], &force);
    let above: [usize; D] = std::array::from_fn(|k| limb.above[k]);
    let own = dot6(&s[c], &F);
    let dots: [f64; D] = std::array::from_fn(|k| dot6(&s[above[k]], &F));
    let (before, column) = data.M.as_mut_slice().split_at_mut(c * nv);
    let column = &mut column[..nv];
    column[c] = own;
    let r0 = limb.root_v;
    column[r0..r0 + 6].copy_from_slice(&[lin.x, lin.y, lin.z, ang.x, ang.y, ang.z]);
    for (r, x) in (r0..r0 + 6).zip(column[r0..r0 + 6].iter()) {
        before[c + r * nv] = *x;
    }
    for (&r, &x) in above.iter().zip(&dots) {
        column[r] = x;
        before[c + r * nv] = x;
    }
}

/// A free-flying root's `6 × 6` block of `M`, `Ad(g)ᵀ ⁰Yᶜ Ad(g)` (`g = ⁰M₀`): its composite
/// inertia in its own frame, `[m 1, −[h]ₓ; [h]ₓ, I]` with the first moment `h = Rᵀ (h₀ − m p)`
/// and `I = Rᵀ I_p R` about its origin, `I_p = I₀ + [h₀]ₓ[p]ₓ + [p]ₓ[h₀]ₓ − m [p]ₓ²`
/// (the parallel-axis theorem in first moments) — the same entries as its six columns'
/// projections, [`mass_columns`]'s route for other joints, in about a fifth of the products.
fn root_block(data: &mut SpatialData, r: usize, nv: usize, i: usize) {
    let (y, g) = (&data.oIc[i], &data.oMi[i]);
    let (rot, p) = (&g.rotation, &g.translation);
    let (px, hx) = (skew(p), skew(&y.first_moment));
    let ip = y.rotational + hx * px + px * hx - px * px * y.mass;
    let inertia = rot.tr_mul(&ip) * rot;
    let h = skew(&rot.tr_mul(&(y.first_moment - p * y.mass)));
    // the lower triangle, mirrored: M symmetric to the bit
    let entry = |k: usize, c: usize| match (k < 3, c < 3) {
        (true, _) => f64::from(u8::from(k == c)) * y.mass,
        (false, true) => h[(k - 3, c)],
        (false, false) => inertia[(k - 3, c - 3)],
    };
    let m = data.M.as_mut_slice();
    for c in 0..6 {
        for k in c..6 {
            let x = entry(k, c);
            m[r + k + (r + c) * nv] = x;
            m[r + c + (r + k) * nv] = x;
        }
    }
}

/// `M` and the bias forces `h` (the RNEA at `q̈ = 0`) on the velocities already in `data`, in
/// one backward sweep: a joint's composite inertia and its subtree's force are complete at
/// the same time, so both algorithms share the pass (Featherstone 2008, Tables 5.1 and 6.2;
/// the same operations, in the same order, as [`mass_matrix_from_kinematics`] then
/// [`bias_forces_from_kinematics`]).
pub(crate) fn mass_matrix_and_bias_from_kinematics(model: &SpatialModel, data: &mut SpatialData) {
    let a0 = gravity_acceleration(model);
    for i in 0..model.joints.len() {
        data.of[i] = body_force(&data.oI[i], data.ov[i], a0 + data.oa_drift[i]);
        data.oa[i] = Motion::zero();
    }
    data.oIc.copy_from_slice(&data.oI);
    for i in (0..model.joints.len()).rev() {
        mass_columns(model, data, i);
        subtree_force(model, data, i, None);
        if let Some(p) = model.joints[i].parent {
            let x = data.oIc[i];
            data.oIc[p].add(&x);
        }
    }
}

/// `⁰a₀ = −g`: gravity as an acceleration of the world (Featherstone 2008, §5.3).
fn gravity_acceleration(model: &SpatialModel) -> Motion {
    Motion::new(-model.gravity, nalgebra::Vector3::zeros())
}

/// A body's force `⁰Yᵢ ⁰aᵢ + ⁰vᵢ ×* ⁰Yᵢ ⁰vᵢ` at its acceleration `acc` and velocity `v`.
fn body_force(y: &super::inertia::OriginInertia, v: Motion, acc: Motion) -> Force {
    y.apply(&acc) + v.cross_force(&y.apply(&v))
}

/// The backward step of the RNEA at joint `i` (its subtree's force `⁰fᵢ` complete):
/// `τ_c = ⁰S_cᵀ ⁰fᵢ` for its rates into `tau` (`data.h` when `None`), then `⁰fᵢ` added to
/// its parent's.
#[inline]
fn subtree_force(
    model: &SpatialModel,
    data: &mut SpatialData,
    i: usize,
    tau: Option<&mut DVector<f64>>,
) {
    let joint = &model.joints[i];
    let f: [f64; 6] = data.of[i].to_vector().into();
    let s = data.oS.as_slice().as_chunks::<6>().0;
    let tau = tau.unwrap_or(&mut data.h).as_mut_slice();
    let rates = joint.idx_v..joint.idx_v + joint.kind.nv();
    for (t, column) in tau[rates.clone()].iter_mut().zip(&s[rates]) {
        *t = dot6(column, &f);
    }
    if let Some(p) = joint.parent {
        let fi = data.of[i];
        data.of[p] += fi;
    }
}

/// The RNEA sweeps on the velocities already in `data` with joint accelerations `a` (or none):
/// `⁰aᵢ = ⁰a_λ(i) + ⁰Sᵢ q̈ᵢ + ⁰vᵢ × ⁰Sᵢ q̇ᵢ` from `⁰a₀ = −g`, `⁰fᵢ = ⁰Yᵢ ⁰aᵢ + ⁰vᵢ ×* ⁰Yᵢ ⁰vᵢ`,
/// `τᵢ = ⁰Sᵢᵀ Σ_subtree ⁰f` (Featherstone 2008, Table 5.1, gravity as a base acceleration).
fn rnea_sweeps(
    model: &SpatialModel,
    data: &mut SpatialData,
    a: Option<&[f64]>,
    gravity: bool,
    tau: &mut DVector<f64>,
) {
    let a0 = if gravity {
        gravity_acceleration(model)
    } else {
        Motion::zero()
    };
    for (i, joint) in model.joints.iter().enumerate() {
        // oa_drift already holds Σ v × S q̇ down the chain; oa accumulates Σ S q̈
        let parent = joint.parent.map_or(Motion::zero(), |p| data.oa[p]);
        data.oa[i] = match a {
            Some(a) => parent + joint_motion(model, data, i, a),
            None => parent,
        };
        let acc = a0 + data.oa_drift[i] + data.oa[i];
        data.of[i] = body_force(&data.oI[i], data.ov[i], acc);
    }
    for i in (0..model.joints.len()).rev() {
        subtree_force(model, data, i, Some(tau));
    }
}

/// Inverse dynamics `τ = M(q) q̈ + h(q, v)` by the RNEA.
pub fn rnea(
    model: &SpatialModel,
    data: &mut SpatialData,
    q: &[f64],
    v: &[f64],
    a: &[f64],
) -> SpatialResult<DVector<f64>> {
    forward_kinematics_velocity(model, data, q, v)?;
    check_vector("a", a, model.nv)?;
    let mut tau = DVector::zeros(model.nv);
    rnea_sweeps(model, data, Some(a), true, &mut tau);
    Ok(tau)
}

/// The bias forces `h(q, v) = C(q, v) v + g(q)` (Pinocchio's `nle`) into `data.h`: the RNEA
/// at `q̈ = 0`.
pub fn nonlinear_effects(
    model: &SpatialModel,
    data: &mut SpatialData,
    q: &[f64],
    v: &[f64],
) -> SpatialResult<()> {
    forward_kinematics_velocity(model, data, q, v)?;
    bias_forces_from_kinematics(model, data);
    Ok(())
}

/// The RNEA at `q̈ = 0` on the velocities already in `data`, into `data.h`.
pub(crate) fn bias_forces_from_kinematics(model: &SpatialModel, data: &mut SpatialData) {
    let mut h = std::mem::take(&mut data.h);
    rnea_sweeps(model, data, None, true, &mut h);
    data.h = h;
}

/// Kinetic energy `½ vᵀ M v = ½ Σ ⁰vᵢᵀ ⁰Yᵢ ⁰vᵢ` (Featherstone 2008, (2.72)), summed over the
/// bodies (after [`super::kinematics::forward_kinematics_velocity`]).
pub fn kinetic_energy(model: &SpatialModel, data: &SpatialData) -> f64 {
    (0..model.joints.len())
        .map(|i| {
            let v = data.ov[i];
            0.5 * v.dot(&data.oI[i].apply(&v))
        })
        .sum()
}

/// Potential energy `−Σ mᵢ g·cᵢ` of the bodies in the model's gravity (after
/// [`forward_kinematics`]).
pub fn potential_energy(model: &SpatialModel, data: &SpatialData) -> f64 {
    (0..model.joints.len())
        .map(|i| {
            let y = &model.inertias[i];
            -y.mass * model.gravity.dot(&data.oMi[i].act_point(&y.com))
        })
        .sum()
}
