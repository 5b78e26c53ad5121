//! Wrench bases `B`, the self-manipulation grasp map `G_s` (4.13–4.15) and the hand
//! Jacobian `J_h` (4.16), built with planar adjoints exactly as the thesis defines them.
//!
//! This is a second route to the constraint: thesis (4.17) says
//! `A = [−J_h, G_sᵀ R_wpᵀ]` (the converted text prints `R_pwᵀ`, a slip: `V^b_op = R_wpᵀ ẋ`).
//! [`crate::constraint`] builds `A` directly from point Jacobians; the tests check both agree.
//!
//! Force convention here is the thesis's chapter-4 one: `f_c` is the force the robot
//! exerts on the ground (`f_c = −λ`), `G_s f_c` is the wrench on the body in body
//! coordinates, `J_hᵀ f_c` the joint torques it needs (massless legs).
#![allow(non_snake_case)]
use crate::contact::{contact_geometry, ConstraintRow, ContactMode, RowDirection, Terrain};
use crate::frames::{adjoint, rot, rotate};
use crate::kinematics::{Kinematics, Part};
use crate::model::Model;
use nalgebra::{DMatrix, Matrix3, Vector2, Vector3};

/// `G_s` (3×c), `J_h` (c×n) and the row layout for one mode.
#[derive(Debug, Clone)]
pub struct GraspMaps {
    pub rows: Vec<ConstraintRow>,
    pub g_s: DMatrix<f64>,
    pub j_h: DMatrix<f64>,
}

/// Wrench basis column of a row in contact coordinates (4.75), (4.77): `(f_t, f_n, m)`.
pub fn wrench_basis(dir: RowDirection) -> Vector3<f64> {
    match dir {
        RowDirection::Tangential => Vector3::new(1.0, 0.0, 0.0),
        RowDirection::Normal => Vector3::new(0.0, 1.0, 0.0),
    }
}

/// Angle `β_c` of a contact frame whose x axis is the tangent `t` and z axis the normal `n`.
fn contact_frame_angle(t: Vector2<f64>) -> f64 {
    // R(β)(1, 0) = (cos β, −sin β) = t
    (-t.y).atan2(t.x)
}

pub fn grasp_maps(
    model: &Model,
    kin: &Kinematics,
    terrain: &dyn Terrain,
    mode: ContactMode,
) -> GraspMaps {
    let rows: Vec<ConstraintRow> = mode.rows().collect();
    let c = rows.len();
    let n = model.n_joints();
    let mut g_s = DMatrix::zeros(3, c);
    let mut j_h = DMatrix::zeros(c, n);
    for (r, row) in rows.iter().enumerate() {
        let geo = contact_geometry(model, kin, terrain, row.contact);
        let beta_c = contact_frame_angle(geo.plane.tangent());
        let b = wrench_basis(row.direction);
        // g_CP: the palm frame P seen from the contact frame C.
        let p_cp = rotate(-beta_c, kin.body_pos - geo.point);
        let ad_cp: Matrix3<f64> = adjoint(p_cp, kin.phi - beta_c);
        // G = [Ad_{g_cp}ᵀ B], G_s = −G (4.14)–(4.15)
        let col = -(ad_cp.transpose() * b);
        g_s.set_column(r, &col);
        // J_h = Bᵀ Ad_{g_sc}⁻¹ J^s_sf (4.16): spatial twists of the leg joints in the hip
        // frame S, moved to C with Ad_{g_cs} = Ad_{g_sc}⁻¹.
        if let Part::Link(j) = geo.part {
            let leg = &model.legs[model.joints[j].leg];
            let hip = kin.body_pos + rotate(kin.phi, leg.hip_m); // S: at the hip, body-aligned
            let p_cs = rotate(-beta_c, hip - geo.point);
            let ad_cs = adjoint(p_cs, kin.phi - beta_c);
            for k in model.chain(j) {
                // revolute twist about joint k at o_k (S coordinates): (−ω S(o)… ) = ω ŷ × (−o)
                let o_s = rot(kin.phi).transpose() * (kin.origin[k] - hip);
                let w = model.joints[k].axis_sign;
                let xi = Vector3::new(-w * o_s.y, w * o_s.x, w);
                j_h[(r, k)] = b.dot(&(ad_cs * xi));
            }
        }
    }
    GraspMaps { rows, g_s, j_h }
}
