//! Analyses of thesis section 4.3 that take any robot (`Model`): the free motions of a
//! contact mode (4.20), contact gaps and contact poses (4.41)–(4.43), the quasi-static pitch
//! on level ground (4.44),
//!
//! - [`standing`]: reactive standing (4.3.1): the mean/difference torque split (4.45)–(4.49)
//!   and the quasi-static "generalized damper" controller (4.50)–(4.54), with contact normals
//!   that need not be vertical;
//! - [`leg_tail`]: legs as inertial tails in flight (4.67)–(4.68): the momentum route and the
//!   flight-dynamics route;
//! - [`takeoff`]: the takeoff-speed bound of a leg with a torque–speed motor (4.64)–(4.66);
//! - [`one_leg`]: the stance on the rear-most leg, its takeoff speed and the best over leg
//!   angle and gear ratio, its pitch acceleration (4.63);
//! - [`liftoff`]: the largest speed along a direction before a contact lifts (Fig. 4.8's
//!   linear program);
//! - [`maximise`]: golden-section, grid-then-golden and pattern-search maximisation (for
//!   the non-convex searches over leg angle, gear ratio and the joint torus);
//! - [`roots`]: a secant search over one input of a run (a leap's touchdown timing).
//!
//! The RHex instances of these (Results A.1–A.3, C.5) and RHex's own analyses (sensor sweep,
//! pitch control) are in `rhex-model`.
#![allow(non_snake_case)]
pub mod balance_map;
pub mod double_stance;
pub mod leg_tail;
pub mod liftoff;
pub mod maximise;
pub mod one_leg;
pub mod pose_rates;
pub mod roots;
pub mod seeded;
pub mod standing;
pub mod takeoff;
pub mod takeoff_maps;

use crate::error::SimError;
use nalgebra::DMatrix;
use selfmanip_core::contact::{contact_geometry, RowDirection, TouchKind};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::model::ContactShape;
use selfmanip_core::{ContactMode, Data, FlatGround, Model, Terrain};
use std::cmp::Ordering;

pub(crate) fn bad(field: &str, reason: impl Into<String>) -> SimError {
    crate::error::invalid(field, reason)
}

/// Every entry of `v` finite, else an invalid value naming `field`.
pub fn check_finite(field: &str, v: &[f64]) -> Result<(), SimError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(bad(field, "must be finite"))
    }
}

/// A configuration `q` of `model`: the right length and finite (errors name `q`).
pub(crate) fn check_configuration(model: &Model, q: &[f64]) -> Result<(), SimError> {
    let nq = model.nq();
    if q.len() != nq {
        return Err(bad(
            "q",
            format!("expected {nq} coordinates, got {}", q.len()),
        ));
    }
    check_finite("q", q)
}

/// The free motions of thesis (4.20): `H = [A; Y]⁻¹ [0; I_e]` at `q` (`Y`: e×q).
pub fn free_motion_basis(
    model: &Model,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    y_map: &DMatrix<f64>,
) -> Result<DMatrix<f64>, SimError> {
    let nq = model.nq();
    check_configuration(model, q)?;
    let mut data = Data::new(model);
    data.prepare_geometry(model, terrain, mode, q, &vec![0.0; nq])?;
    let a = &data.constraints.a;
    let c = a.nrows();
    let e = nq - c;
    if y_map.shape() != (e, nq) {
        return Err(bad(
            "Y",
            format!(
                "must be {e}×{nq} (e = q − c), got {}×{}",
                y_map.nrows(),
                y_map.ncols()
            ),
        ));
    }
    let mut ay = DMatrix::zeros(nq, nq);
    ay.view_mut((0, 0), (c, nq)).copy_from(a);
    ay.view_mut((c, 0), (e, nq)).copy_from(y_map);
    let sv = ay.clone().svd(false, false).singular_values;
    let (smin, smax) = (sv.min(), sv.max());
    if smin.is_nan() || smax.is_nan() || smin <= 1e-10 * smax {
        return Err(bad(
            "Y",
            "[A; Y] is singular: y does not parameterize the free motion here",
        ));
    }
    let mut rhs = DMatrix::zeros(nq, e);
    rhs.view_mut((c, 0), (e, e)).fill_with_identity();
    Ok(ay.lu().solve(&rhs).expect("checked invertible"))
}

/// Indices (into λ) of the normal rows of `mode`, in row order.
pub fn normal_rows(data: &Data) -> Vec<usize> {
    data.constraints
        .rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.direction == RowDirection::Normal)
        .map(|(i, _)| i)
        .collect()
}

/// Gaps `a_k(q)` of the listed contacts (heights above their ground planes).
pub fn contact_gaps(
    model: &Model,
    terrain: &dyn Terrain,
    contacts: &[usize],
    q: &[f64],
) -> Vec<f64> {
    let mut kin = Kinematics::default();
    kin.compute(model, q, &vec![0.0; q.len()]);
    contacts
        .iter()
        .map(|&k| contact_geometry(model, &kin, terrain, k).gap_m)
        .collect()
}

/// The angle of coordinate `coord` (a joint) at which contact `contact`'s gap reaches zero
/// with the rest of `q` held, between `clear_rad` (gap positive) and `through_rad` (gap
/// negative), by bisection on the contact geometry (any contact shape) to 10⁻¹⁵ rad (at
/// most 200 halvings); the clear end of the last bracket. `None` when the gap does not
/// change sign from `clear_rad` to `through_rad` that way.
pub fn angle_to_ground(
    model: &Model,
    terrain: &dyn Terrain,
    q: &[f64],
    coord: usize,
    contact: usize,
    clear_rad: f64,
    through_rad: f64,
) -> Option<f64> {
    let mut kin = Kinematics::default();
    let zero = vec![0.0; q.len()];
    let mut qq = q.to_vec();
    let mut gap = |theta: f64| {
        qq[coord] = theta;
        kin.compute(model, &qq, &zero);
        contact_geometry(model, &kin, terrain, contact).gap_m
    };
    let (mut clear, mut through) = (clear_rad, through_rad);
    if !(gap(clear) > 0.0 && gap(through) < 0.0) {
        return None;
    }
    for _ in 0..200 {
        let mid = 0.5 * (clear + through);
        if gap(mid) > 0.0 {
            clear = mid;
        } else {
            through = mid;
        }
        if (clear - through).abs() < 1e-15 {
            break;
        }
    }
    Some(clear)
}

/// The lowest of a side's contacts: which one, its depth (world `z`, down) and how it
/// touches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SideSupport {
    pub contact: usize,
    pub depth_m: f64,
    pub touch: TouchKind,
}

/// The lowest of `sites` in the pose `kin` (the first of equals).
fn lowest(model: &Model, kin: &Kinematics, sites: &[usize]) -> SideSupport {
    let at = |k: usize| {
        let g = contact_geometry(model, kin, &FlatGround, k);
        SideSupport {
            contact: k,
            depth_m: g.point.y,
            touch: g.touch,
        }
    };
    let mut best = at(sites[0]);
    for &k in &sites[1..] {
        let s = at(k);
        if matches!(
            best.depth_m.partial_cmp(&s.depth_m),
            None | Some(Ordering::Less)
        ) {
            best = s;
        }
    }
    best
}

/// The quasi-static pitch on level ground (thesis section 4.2.2, (4.44)): with the body at
/// `x = z = 0` and the other coordinates of `q`, the pitch `φ ∈ (−π/2, π/2)` at which the
/// lowest of the `front` contacts and the lowest of the `rear` ones are equally deep
/// (`depth_front − depth_rear` falls as the nose rises: bisection to 10⁻¹⁴ rad), with those
/// two supports there. `None` where no such pitch exists or a side has no contact.
pub fn balance_pitch(
    model: &Model,
    q: &[f64],
    front: &[usize],
    rear: &[usize],
) -> Option<(f64, SideSupport, SideSupport)> {
    if front.is_empty() || rear.is_empty() {
        return None;
    }
    let mut kin = Kinematics::default();
    let zero = vec![0.0; q.len()];
    let mut qq = q.to_vec();
    qq[model.ix_x()] = 0.0;
    qq[model.ix_z()] = 0.0;
    let mut eval = |phi: f64| {
        qq[model.ix_phi()] = phi;
        kin.compute(model, &qq, &zero);
        let (f, r) = (lowest(model, &kin, front), lowest(model, &kin, rear));
        (f.depth_m - r.depth_m, f, r)
    };
    let (mut lo, mut hi) = (
        -std::f64::consts::FRAC_PI_2 + 1e-9,
        std::f64::consts::FRAC_PI_2 - 1e-9,
    );
    let (glo, ghi) = (eval(lo).0, eval(hi).0);
    if !(glo >= 0.0 && ghi <= 0.0) {
        return None;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if eval(mid).0 > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-14 {
            break;
        }
    }
    let phi = 0.5 * (lo + hi);
    let (_, f, r) = eval(phi);
    Some((phi, f, r))
}

/// Puts the listed contacts on the ground by Newton's method on the coordinates `free`
/// (as many as contacts), starting from `q`: solves the base constraints (4.41)–(4.43)
/// `a_k(q) = 0` for, e.g., the body height and pitch.
pub fn solve_contact_pose(
    model: &Model,
    terrain: &dyn Terrain,
    contacts: &[usize],
    free: &[usize],
    q: &[f64],
) -> Result<Vec<f64>, SimError> {
    if contacts.len() != free.len() || contacts.is_empty() {
        return Err(bad("free", "need one free coordinate per contact"));
    }
    check_finite("q", q)?;
    let mut q = q.to_vec();
    for _ in 0..60 {
        let g = contact_gaps(model, terrain, contacts, &q);
        let err = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if err < 1e-13 {
            return Ok(q);
        }
        let m = contacts.len();
        let mut jac = DMatrix::zeros(m, m);
        for (j, &i) in free.iter().enumerate() {
            let h = 1e-7;
            let mut qp = q.clone();
            qp[i] += h;
            let mut qm = q.clone();
            qm[i] -= h;
            let gp = contact_gaps(model, terrain, contacts, &qp);
            let gm = contact_gaps(model, terrain, contacts, &qm);
            for r in 0..m {
                jac[(r, j)] = (gp[r] - gm[r]) / (2.0 * h);
            }
        }
        let step = jac
            .lu()
            .solve(&nalgebra::DVector::from_vec(g.clone()))
            .ok_or_else(|| bad("q", "contact pose: singular constraint Jacobian"))?;
        for (j, &i) in free.iter().enumerate() {
            q[i] -= step[j].clamp(-0.2, 0.2);
        }
    }
    let g = contact_gaps(model, terrain, contacts, &q);
    if g.iter().all(|v| v.abs() < 1e-9) {
        Ok(q)
    } else {
        Err(bad(
            "q",
            "contact pose: Newton did not converge (no such stance?)",
        ))
    }
}

/// Selector rows `Y` (k×q) picking the coordinates `idx`.
pub fn selector_rows(nq: usize, idx: &[usize]) -> DMatrix<f64> {
    let mut y = DMatrix::zeros(idx.len(), nq);
    for (r, &i) in idx.iter().enumerate() {
        y[(r, i)] = 1.0;
    }
    y
}

/// How far `model`, level, reaches from its body centre along the body's `x` on the side
/// `side` (`+1` ahead, `−1` behind) with a leg turned straight that way: the farthest of each
/// leg's hip plus its links' lengths and of each body contact's extent (m).
pub fn body_reach_m(model: &Model, side: f64) -> f64 {
    let leg = |l: usize| -> f64 {
        let links = model.joints.iter().filter(|j| j.leg == l);
        side * model.legs[l].hip_m.x + links.map(|j| j.length_m).sum::<f64>()
    };
    let body = model.contacts.iter().filter(|c| c.link.is_none());
    let extent = body.map(|c| match c.shape {
        ContactShape::Point { position_m } => side * position_m.x,
        ContactShape::Arc {
            center_m, radius_m, ..
        } => side * center_m.x + radius_m,
    });
    (0..model.legs.len())
        .map(leg)
        .chain(extent)
        .fold(f64::NEG_INFINITY, f64::max)
}
