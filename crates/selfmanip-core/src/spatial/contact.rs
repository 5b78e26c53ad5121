//! Point contacts and the constrained dynamics of a spatial robot: the KKT system of thesis
//! (5.2) for the rows of a contact set, solved by the planar core's null-space block inverse
//! ([`crate::kkt::KktFactorization`], (5.3)–(5.4)), which needs `A` of full row rank and `M`
//! positive definite only on `ker A` (Lemma 5.1), never `M` invertible: massless limbs are
//! exact. Plastic impact is (5.10).
//!
//! Sign convention (Pinocchio's): `M q̈ + h = τ + Aᵀλ`, `λ` the ground's force on the robot
//! along the rows' world directions — for a contact with friction `[t₁, t₂, n]`, tangents
//! first, `n` the ground normal pointing out of the ground (so a pushing normal force is
//! positive); a frictionless contact has the row `n` alone. In the thesis's form (5.2),
//! `M̄q̈ + Aᵀλ_thesis = Υ − C̄q̇ − N̄` with `λ_thesis = −λ`.
#![allow(non_snake_case)]
use super::error::{SpatialError, SpatialResult};
use super::kinematics::{
    forward_kinematics_velocity, frame_jacobian, frame_linear_drift, ReferenceFrame, SpatialData,
};
use super::model::SpatialModel;
use super::rigid_body::{bias_forces_from_kinematics, mass_matrix_from_kinematics};
use crate::error::check_result;
use crate::error::check_vector;
use nalgebra::{DVector, DVectorView, Vector3};

/// A point of a frame touching the ground.
#[derive(Debug, Clone, PartialEq)]
pub struct PointContact {
    /// The frame whose origin touches.
    pub frame: usize,
    /// With friction (3 rows: two tangents, then the normal) or frictionless (the normal).
    pub friction: bool,
    /// Unit ground normal in the world, pointing out of the ground.
    pub normal: Vector3<f64>,
}

impl PointContact {
    /// A contact at the origin of the frame named `frame_name` on flat z-up ground.
    pub fn new(model: &SpatialModel, frame_name: &str, friction: bool) -> SpatialResult<Self> {
        Self::with_normal(model, frame_name, friction, Vector3::z())
    }

    /// A contact on ground of normal `normal` (normalized).
    pub fn with_normal(
        model: &SpatialModel,
        frame_name: &str,
        friction: bool,
        normal: Vector3<f64>,
    ) -> SpatialResult<Self> {
        let frame = model.frame_id(frame_name)?;
        check_vector("normal", normal.as_slice(), 3)?;
        if normal.norm() < 1e-12 {
            return Err(SpatialError::InvalidArgument {
                field: "normal".into(),
                reason: "zero normal".into(),
            });
        }
        Ok(Self {
            frame,
            friction,
            normal: normal.normalize(),
        })
    }

    pub fn n_rows(&self) -> usize {
        if self.friction {
            3
        } else {
            1
        }
    }

    /// The row directions, the first [`Self::n_rows`] entries: `[t₁, t₂, n]` with friction,
    /// `[n]` without. `t₁` is the world `x` axis projected on the ground plane (the `y` axis if
    /// `n` is near `x`), `t₂ = n × t₁`: on flat z-up ground the rows are world `x, y, z`.
    pub fn directions(&self) -> [Vector3<f64>; 3] {
        let n = self.normal;
        if !self.friction {
            return [n, Vector3::zeros(), Vector3::zeros()];
        }
        let e = if n.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let t1 = (e - n * n.dot(&e)).normalize();
        [t1, n.cross(&t1), n]
    }
}

/// The contact Jacobian `A` (rows of the contact points' world linear Jacobians along the
/// row directions) and its drift `Ȧq̇` (the points' classical accelerations at `q̈ = 0` along
/// the same directions) into `data.A`, `data.A_drift`, after the velocity kinematics.
fn contact_rows(model: &SpatialModel, data: &mut SpatialData, contacts: &[PointContact]) {
    let c: usize = contacts.iter().map(PointContact::n_rows).sum();
    if data.A.nrows() != c {
        data.A = nalgebra::DMatrix::zeros(c, model.nv);
        data.A_drift = DVector::zeros(c);
        data.lam = DVector::zeros(c);
        data.rhs_g = DVector::zeros(c);
    }
    let mut row = 0;
    for contact in contacts {
        frame_jacobian(
            model,
            data,
            contact.frame,
            ReferenceFrame::LocalWorldAligned,
        );
        let drift = frame_linear_drift(model, data, contact.frame);
        for d in &contact.directions()[..contact.n_rows()] {
            for c in 0..model.nv {
                data.A[(row, c)] = d.dot(&data.J.fixed_view::<3, 1>(0, c));
            }
            data.A_drift[row] = d.dot(&drift);
            row += 1;
        }
    }
}

/// `M`, `h`, `A`, `Ȧq̇` at `(q, v)` and the KKT factorization of `[M Aᵀ; A 0]`.
fn prepare(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
    v: &[f64],
) -> SpatialResult<()> {
    forward_kinematics_velocity(model, data, q, v)?;
    mass_matrix_from_kinematics(model, data);
    bias_forces_from_kinematics(model, data);
    contact_rows(model, data, contacts);
    data.kkt.factor(&data.M, &data.A)?;
    Ok(())
}

/// Constrained forward dynamics, thesis (5.3)–(5.4): `q̈` and `λ` into `data.qdd`,
/// `data.lam` from `[M Aᵀ; A 0][q̈; −λ] = [τ − h; −Ȧq̇]`, with `tau` the nv generalized forces
/// (zero on a free flyer's six rates for an unactuated base).
pub fn forward_dynamics(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
    v: &[f64],
    tau: &[f64],
) -> SpatialResult<()> {
    check_vector("tau", tau, model.nv)?;
    prepare(model, data, contacts, q, v)?;
    for (f, (t, h)) in data.rhs_f.iter_mut().zip(tau.iter().zip(data.h.iter())) {
        *f = t - h;
    }
    for (g, d) in data.rhs_g.iter_mut().zip(data.A_drift.iter()) {
        *g = -d;
    }
    data.kkt.solve(
        data.rhs_f.as_slice(),
        data.rhs_g.as_slice(),
        data.qdd.as_mut_slice(),
        data.lam.as_mut_slice(),
    );
    data.lam.neg_mut();
    check_result("q̈", data.qdd.as_slice())?;
    check_result("λ", data.lam.as_slice())?;
    Ok(())
}

/// The outcome of a plastic impact.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialImpact {
    /// Post-impact rates `q̇⁺` (nv).
    pub v_plus: DVector<f64>,
    /// The ground's impulse on the robot along the rows (N·s), same sign as `λ`.
    pub impulse: DVector<f64>,
}

/// Plastic impact, thesis (5.10): `[M Aᵀ; A 0][Δq̇; −P] = [0; −A q̇⁻]`, `q̇⁺ = q̇⁻ + Δq̇`, so
/// `A q̇⁺ = 0` and `M(q̇⁺ − q̇⁻) = Aᵀ P`.
pub fn impact(
    model: &SpatialModel,
    data: &mut SpatialData,
    contacts: &[PointContact],
    q: &[f64],
    v_minus: &[f64],
) -> SpatialResult<SpatialImpact> {
    prepare(model, data, contacts, q, v_minus)?;
    data.rhs_f.fill(0.0);
    let v = DVectorView::from_slice(v_minus, model.nv);
    data.rhs_g.gemv(-1.0, &data.A, &v, 0.0);
    data.kkt.solve(
        data.rhs_f.as_slice(),
        data.rhs_g.as_slice(),
        data.qdd.as_mut_slice(),
        data.lam.as_mut_slice(),
    );
    let v_plus = DVector::from_column_slice(v_minus) + &data.qdd;
    let impulse = -&data.lam;
    check_result("q̇⁺", v_plus.as_slice())?;
    check_result("P", impulse.as_slice())?;
    Ok(SpatialImpact { v_plus, impulse })
}
