//! Mass matrix `M̄` (4.25–4.26), Coriolis `C̄` (4.30) and gravity `N̄` (4.31).
//!
//! `M̄ = Σ_i J_iᵀ M_i J_i` over the body and every link, with `J_i` the Jacobian of the
//! part's centre of mass and angle. This equals (4.26): `M̄ = diag(I, R_wp) M̂ diag(I, R_wpᵀ)`
//! is the same kinetic energy written in body twists. Massless links contribute nothing.
//!
//! The Coriolis matrix used on the hot path is `C̄ = Σ_i J_iᵀ M_i J̇_i`. It differs from the
//! Christoffel form (4.30) as a matrix but gives the same vector `C̄ q̇`, and keeps
//! `dM̄/dt − 2C̄` skew-symmetric. [`coriolis_christoffel`] builds (4.30) itself.
//!
//! **Armature.** A joint's armature `a_j` ([`crate::model::Joint::armature_kg_m2`], the
//! reflected inertia `n J G²` of its drive's rotors) adds the constant `a_j` to `M̄_jj`, and
//! `½ a_j θ̇_j²` to the kinetic energy `½ q̇ᵀM̄q̇`; being constant it adds nothing to `∂M̄/∂q`,
//! `C̄` or `N̄` (MuJoCo's `armature`: the rotor's coupling with the parent's rotation is
//! dropped).
use crate::kinematics::{Kinematics, Part};
use crate::model::Model;
use nalgebra::{DMatrix, DVector, Vector2};

/// Parts with mass: the body and every massive link, with (mass, inertia, COM local).
fn massive_parts(model: &Model) -> impl Iterator<Item = (Part, f64, f64, Vector2<f64>)> + '_ {
    std::iter::once((
        Part::Body,
        model.body_mass_kg,
        model.body_inertia_kg_m2,
        Vector2::zeros(),
    ))
    .chain(
        model
            .joints
            .iter()
            .enumerate()
            // a link with neither mass nor inertia adds nothing (its joint's armature, if
            // any, is added on its own)
            .filter(|(_, j)| j.mass_kg != 0.0 || j.inertia_kg_m2 != 0.0)
            .map(|(i, j)| (Part::Link(i), j.mass_kg, j.inertia_kg_m2, j.com_m)),
    )
}

/// Scratch rows reused by the inertia computations.
#[derive(Debug, Clone, Default)]
pub struct InertiaScratch {
    jx: Vec<f64>,
    jz: Vec<f64>,
    jw: Vec<f64>,
    jdx: Vec<f64>,
    jdz: Vec<f64>,
    /// The current part's Jacobian columns at its chain's joints, ascending (φ's, the other
    /// column that rotates it, is kept apart).
    cols: Vec<PartColumn>,
}

impl InertiaScratch {
    fn resize(&mut self, nq: usize) {
        for v in [
            &mut self.jx,
            &mut self.jz,
            &mut self.jw,
            &mut self.jdx,
            &mut self.jdz,
        ] {
            v.resize(nq, 0.0);
        }
    }
}

/// Column `k` of a part's Jacobians: `J e_k` (its COM) and `J_ω e_k`.
#[derive(Debug, Clone, Copy)]
struct PartColumn {
    k: usize,
    j: Vector2<f64>,
    w: f64,
}

/// `J_ω e_φ`: φ turns every part.
const W_PHI: f64 = 1.0;

const EX: Vector2<f64> = Vector2::new(1.0, 0.0);
const EZ: Vector2<f64> = Vector2::new(0.0, 1.0);

/// Writes `M̄`, `C̄ q̇` and `N̄` (the latter two as vectors) for the current kinematics, the
/// joints' armature on `M̄`'s diagonal.
///
/// A part's Jacobians vanish outside its support (its chain and `x, z, φ`: for RHex's body,
/// 3 of 5 coordinates), so each part's sums run over its nonzero columns only. Of these the
/// columns of `x` and `z` are constants — `J e_x = (1, 0)`, `J e_z = (0, 1)`, no rotation, no
/// rate — so their entries are written in closed form (`m`, `m J_x`, `m J_z`, `m (J̇q̇)_x`,
/// `m g`): the terms of the general sums they stand for differ from these by added or
/// multiplied zeros, so every entry is the same number, and each part adds its terms to the
/// sums in the same order, part by part.
pub fn mass_coriolis_gravity(
    model: &Model,
    kin: &Kinematics,
    qd: &[f64],
    s: &mut InertiaScratch,
    m_bar: &mut DMatrix<f64>,
    c_qd: &mut DVector<f64>,
    n_bar: &mut DVector<f64>,
) {
    let nq = model.nq();
    let (ix, iz) = (model.ix_x(), model.ix_z());
    let (mb, c_qd, n_bar) = (
        m_bar.as_mut_slice(),
        c_qd.as_mut_slice(),
        n_bar.as_mut_slice(),
    );
    debug_assert_eq!(mb.len(), nq * nq);
    mb.fill(0.0);
    c_qd.fill(0.0);
    n_bar.fill(0.0);
    let g = model.gravity_m_s2;
    let iphi = model.ix_phi();
    // the entries of x, z, φ alone, which every part adds to: M̄_xx (= M̄_zz), M̄_xφ, M̄_zφ,
    // M̄_φφ, C̄q̇ and N̄ at x, z, φ (N̄_x = 0)
    let (mut m_xx, mut m_xphi, mut m_zphi, mut m_phiphi) = (0.0, 0.0, 0.0, 0.0);
    let (mut c_x, mut c_z, mut c_phi, mut n_z, mut n_phi) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (part, m, inertia, com) in massive_parts(model) {
        let p = kin.point(part, com);
        let pd = kin.material_velocity(part, p);
        // the columns that rotate the part: its chain's joints, ascending, then φ; and
        // J̇ q̇ over them (planar: J̇_ω = 0; J̇ e_x = J̇ e_z = 0)
        let cols = &mut s.cols;
        cols.clear();
        let (mut ax, mut az) = (0.0, 0.0);
        let (phi, phi_rate) = kin.rotation_columns(model, part, p, pd, |k, j, jd, w| {
            ax += jd.x * qd[k];
            az += jd.y * qd[k];
            cols.push(PartColumn { k, j, w })
        });
        ax += phi_rate.x * qd[iphi];
        az += phi_rate.y * qd[iphi];
        // M̄ += m Jᵀ J + I J_ωᵀ J_ω, each term added to an entry and to its mirror image
        // (M̄ is exactly symmetric: both hold the same number before and after); the
        // columns ascend
        let mut add = |at: usize, mirror: usize, v: f64| {
            let sum = mb[at] + v;
            mb[at] = sum;
            mb[mirror] = sum;
        };
        for (ib, b) in cols.iter().enumerate() {
            let row = b.k * nq;
            add(
                row + b.k,
                row + b.k,
                m * (b.j.x * b.j.x + b.j.y * b.j.y) + inertia * b.w * b.w,
            );
            for a in &cols[ib + 1..] {
                let v = m * (a.j.x * b.j.x + a.j.y * b.j.y) + inertia * a.w * b.w;
                add(row + a.k, a.k * nq + b.k, v);
            }
            // … with φ, and on x, z: m Jᵀ J with J e_x = (1, 0), J e_z = (0, 1)
            let v = m * (phi.x * b.j.x + phi.y * b.j.y) + inertia * W_PHI * b.w;
            add(row + iphi, iphi * nq + b.k, v);
            add(row + ix, ix * nq + b.k, m * b.j.x);
            add(row + iz, iz * nq + b.k, m * b.j.y);
            // C̄ q̇ += m Jᵀ (J̇ q̇); N̄ = ∂V/∂q with V = −m g z_com (z down)
            c_qd[b.k] += m * (b.j.x * ax + b.j.y * az);
            n_bar[b.k] -= m * g * b.j.y;
        }
        m_phiphi += m * (phi.x * phi.x + phi.y * phi.y) + inertia * W_PHI * W_PHI;
        m_xphi += m * phi.x;
        m_zphi += m * phi.y;
        m_xx += m;
        c_x += m * ax;
        c_z += m * az;
        c_phi += m * (phi.x * ax + phi.y * az);
        n_z -= m * g;
        n_phi -= m * g * phi.y;
    }
    mb[ix * nq + ix] = m_xx;
    mb[iz * nq + iz] = m_xx;
    mb[iphi * nq + iphi] = m_phiphi;
    mb[iphi * nq + ix] = m_xphi;
    mb[ix * nq + iphi] = m_xphi;
    mb[iphi * nq + iz] = m_zphi;
    mb[iz * nq + iphi] = m_zphi;
    c_qd[ix] = c_x;
    c_qd[iz] = c_z;
    c_qd[iphi] = c_phi;
    n_bar[iz] = n_z;
    n_bar[iphi] = n_phi;
    // M̄_jj += a_j   (armature: the drive's rotors reflected to the joint)
    for (j, joint) in model.joints.iter().enumerate() {
        if joint.armature_kg_m2 != 0.0 {
            mb[j * nq + j] += joint.armature_kg_m2;
        }
    }
}

/// The matrix `C̄ = Σ m J_pᵀ J̇_p` (same `C̄ q̇` as (4.30)).
pub fn coriolis_matrix(model: &Model, kin: &Kinematics) -> DMatrix<f64> {
    let nq = model.nq();
    let mut s = InertiaScratch::default();
    s.resize(nq);
    let mut c = DMatrix::zeros(nq, nq);
    for_each_mass_rows(model, kin, &mut s, |m, s| {
        for a in 0..nq {
            for b in 0..nq {
                c[(a, b)] += m * (s.jx[a] * s.jdx[b] + s.jz[a] * s.jdz[b]);
            }
        }
    });
    c
}

/// Calls `f(m, s)` for every massive part with `s.jx`, `s.jz` its centre of mass's rows
/// `J_p` (x, z) and `s.jdx`, `s.jdz` their rates `J̇_p` at the velocity of `kin`.
fn for_each_mass_rows(
    model: &Model,
    kin: &Kinematics,
    s: &mut InertiaScratch,
    mut f: impl FnMut(f64, &InertiaScratch),
) {
    for (part, m, _inertia, com) in massive_parts(model) {
        let p = kin.point(part, com);
        let pd = kin.material_velocity(part, p);
        kin.point_jacobian_row(model, part, p, EX, &mut s.jx);
        kin.point_jacobian_row(model, part, p, EZ, &mut s.jz);
        kin.point_jacobian_rate_row(model, part, pd, EX, &mut s.jdx);
        kin.point_jacobian_rate_row(model, part, pd, EZ, &mut s.jdz);
        f(m, s);
    }
}

/// `∂M̄/∂q_k` for every `k`, exactly: `J̇` evaluated at `q̇ = e_k` is `∂J/∂q_k` (the
/// joints' armature is constant and does not appear).
pub fn mass_matrix_partials(model: &Model, q: &[f64]) -> Vec<DMatrix<f64>> {
    let nq = model.nq();
    let mut kin = Kinematics::default();
    let mut s = InertiaScratch::default();
    s.resize(nq);
    let mut out = Vec::with_capacity(nq);
    for k in 0..nq {
        let mut e = vec![0.0; nq];
        e[k] = 1.0;
        kin.compute(model, q, &e);
        let mut dm = DMatrix::zeros(nq, nq);
        for_each_mass_rows(model, &kin, &mut s, |m, s| {
            for a in 0..nq {
                for b in 0..nq {
                    dm[(a, b)] += m
                        * (s.jdx[a] * s.jx[b]
                            + s.jx[a] * s.jdx[b]
                            + s.jdz[a] * s.jz[b]
                            + s.jz[a] * s.jdz[b]);
                }
            }
        });
        out.push(dm);
    }
    out
}

/// The Christoffel-symbol Coriolis matrix of thesis (4.30):
/// `C̄_ij = ½ Σ_k (∂M̄_ij/∂q_k + ∂M̄_ik/∂q_j − ∂M̄_kj/∂q_i) q̇_k`.
pub fn coriolis_christoffel(model: &Model, q: &[f64], qd: &[f64]) -> DMatrix<f64> {
    let nq = model.nq();
    let dm = mass_matrix_partials(model, q);
    let mut c = DMatrix::zeros(nq, nq);
    for i in 0..nq {
        for j in 0..nq {
            let mut acc = 0.0;
            for k in 0..nq {
                acc += 0.5 * (dm[k][(i, j)] + dm[j][(i, k)] - dm[i][(k, j)]) * qd[k];
            }
            c[(i, j)] = acc;
        }
    }
    c
}

/// Potential energy `V` (4.27): `−Σ m g z_com` (z down).
pub fn potential_energy(model: &Model, kin: &Kinematics) -> f64 {
    massive_parts(model)
        .map(|(part, m, _, com)| -m * model.gravity_m_s2 * kin.point(part, com).y)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RobotDescription;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The general sums of `M̄`, `C̄ q̇` and `N̄` over every nonzero column of every massive
    /// part (the `x, z` columns included), part by part: the route
    /// [`mass_coriolis_gravity`] writes the translations of in closed form.
    fn by_all_columns(model: &Model, kin: &Kinematics, qd: &[f64]) -> [Vec<f64>; 3] {
        /// Column `k` of a part's Jacobians: `J e_k` (its COM), `J̇ e_k` and `J_ω e_k`.
        struct Column {
            k: usize,
            j: Vector2<f64>,
            jd: Vector2<f64>,
            w: f64,
        }
        let nq = model.nq();
        let (mut mb, mut c_qd, mut n_bar) = (vec![0.0; nq * nq], vec![0.0; nq], vec![0.0; nq]);
        let g = model.gravity_m_s2;
        for (part, m, inertia, com) in massive_parts(model) {
            let p = kin.point(part, com);
            let pd = kin.material_velocity(part, p);
            let mut cols: Vec<Column> = Vec::new();
            kin.point_jacobian_columns(model, part, p, |k, j| {
                cols.push(Column {
                    k,
                    j,
                    jd: Vector2::zeros(),
                    w: 0.0,
                })
            });
            let at = |cols: &[Column], k: usize| cols.iter().position(|c| c.k == k).unwrap();
            kin.point_jacobian_rate_columns(model, part, pd, |k, jd| {
                let i = at(&cols, k);
                cols[i].jd = jd;
            });
            kin.angular_jacobian_entries(model, part, |k, w| {
                let i = at(&cols, k);
                cols[i].w = w;
            });
            for (ib, b) in cols.iter().enumerate() {
                for a in &cols[ib..] {
                    let mab = m * (a.j.x * b.j.x + a.j.y * b.j.y) + inertia * a.w * b.w;
                    mb[b.k * nq + a.k] += mab;
                    if a.k != b.k {
                        mb[a.k * nq + b.k] += mab;
                    }
                }
            }
            let (mut ax, mut az) = (0.0, 0.0);
            for c in &cols {
                ax += c.jd.x * qd[c.k];
                az += c.jd.y * qd[c.k];
            }
            for c in &cols {
                c_qd[c.k] += m * (c.j.x * ax + c.j.y * az);
                n_bar[c.k] -= m * g * c.j.y;
            }
        }
        for (j, joint) in model.joints.iter().enumerate() {
            mb[j * nq + j] += joint.armature_kg_m2;
        }
        [mb, c_qd, n_bar]
    }

    /// [`mass_coriolis_gravity`] gives the general sums bit for bit, on a robot with legs of
    /// one to three links, massless, massive, inertia only and armature only links, both axis
    /// signs and offset centres of mass, at random states.
    #[test]
    fn translations_in_closed_form_match_the_general_sums_bit_for_bit() {
        let model = RobotDescription::from_toml_str(
            r#"
            name = "mixed"
            [body]
            mass_kg = 2.3
            inertia_kg_m2 = 0.031
            [[legs]]
            name = "a"
            hip_m = [0.21, -0.02]
            links = [{ length_m = 0.13, mass_kg = 0.2, inertia_kg_m2 = 3e-4 },
                     { length_m = 0.11, mass_kg = 0.15, inertia_kg_m2 = 2e-4, axis = "-y", com_m = [0.01, 0.04] },
                     { length_m = 0.07 }]
            [[legs]]
            name = "b"
            hip_m = [-0.19, 0.01]
            links = [{ length_m = 0.12 }, { length_m = 0.1, mass_kg = 0.3, inertia_kg_m2 = 1e-4 }]
            [[legs]]
            name = "c"
            hip_m = [0.0, 0.03]
            links = [{ length_m = 0.1, inertia_kg_m2 = 5e-4, axis = "-y" },
                     { length_m = 0.1, armature_kg_m2 = 0.01 }]
            "#,
        )
        .unwrap()
        .build()
        .unwrap();
        let nq = model.nq();
        let mut rng = ChaCha8Rng::seed_from_u64(30);
        let (mut kin, mut s) = (Kinematics::default(), InertiaScratch::default());
        let mut m_bar = DMatrix::zeros(nq, nq);
        let (mut c_qd, mut n_bar) = (DVector::zeros(nq), DVector::zeros(nq));
        for _ in 0..200 {
            let q: Vec<f64> = (0..nq).map(|_| rng.gen_range(-4.0..4.0)).collect();
            let qd: Vec<f64> = (0..nq).map(|_| rng.gen_range(-30.0..30.0)).collect();
            kin.compute(&model, &q, &qd);
            mass_coriolis_gravity(&model, &kin, &qd, &mut s, &mut m_bar, &mut c_qd, &mut n_bar);
            let [mb, c, n] = by_all_columns(&model, &kin, &qd);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(m_bar.as_slice()),
                bits(&mb),
                "M̄ at q = {q:?}, q̇ = {qd:?}"
            );
            assert_eq!(
                bits(c_qd.as_slice()),
                bits(&c),
                "C̄q̇ at q = {q:?}, q̇ = {qd:?}"
            );
            assert_eq!(
                bits(n_bar.as_slice()),
                bits(&n),
                "N̄ at q = {q:?}, q̇ = {qd:?}"
            );
        }
    }
}
