//! What a stance allows at one pose, for any planar robot (the quantities of thesis 4.3.2's
//! pitching sensor sweep): the joint torques that hold it against gravity ((4.21)–(4.23)),
//! the free motion led by one joint ((4.20), the other free joints those of unloaded legs),
//! the lead joint's rate per unit pitch rate along it (4.59), and the largest lead speed
//! before a contact lifts (Fig. 4.8). RHex's sweep over its quasi-static poses is in
//! `rhex-model`.
use super::liftoff::{free_leg_parameterization, liftoff_speed};
use super::{bad, free_motion_basis};
use crate::error::SimError;
use nalgebra::DMatrix;
use selfmanip_core::quasistatic::quasi_static;
use selfmanip_core::{ContactMode, Data, FlatGround, Model};

/// The joint torques that balance gravity at `q` in `mode` on level ground (the particular
/// solution of (4.21)–(4.23)). A stance with as many constraint rows as body coordinates is
/// determinate; with one more on a two-joint robot the internal force is fixed by
/// `t_dᵀτ = 0`, `t_d = (½, −½)` (the difference condition of 4.3.1); any other is an error
/// naming `mode`.
pub fn holding_torque(model: &Model, mode: ContactMode, q: &[f64]) -> Result<Vec<f64>, SimError> {
    let n = model.n_joints();
    let c = mode.n_rows();
    let t = match c.checked_sub(model.nq() - n) {
        Some(0) => DMatrix::zeros(n, 0),
        Some(1) if n == 2 => DMatrix::from_column_slice(2, 1, &[0.5, -0.5]),
        _ => return Err(bad("mode", format!("{c} rows: not a determinate stance"))),
    };
    let mut data = Data::new(model);
    let qs = quasi_static(model, &mut data, &FlatGround, mode, q, &t)?;
    Ok(qs.balance.tau_particular.iter().cloned().collect())
}

/// The free motion of `mode` at `q` per unit rate of joint `lead` (the column of `H` of
/// (4.20) with `y = [lead, the joints of unloaded legs]`, those at rest), on level ground.
pub fn lead_motion(
    model: &Model,
    mode: ContactMode,
    q: &[f64],
    lead: usize,
) -> Result<Vec<f64>, SimError> {
    let y = free_leg_parameterization(model, mode, lead);
    let h = free_motion_basis(model, &FlatGround, mode, q, &y)?;
    Ok(h.column(0).iter().cloned().collect())
}

/// (4.59): the rate of joint `lead` per unit pitch rate along its free motion,
/// `1/H_φ` ([`lead_motion`]); an error naming `theta` where the pitch does not move with it.
pub fn pitch_rate_gain(
    model: &Model,
    mode: ContactMode,
    q: &[f64],
    lead: usize,
) -> Result<f64, SimError> {
    let h_phi = lead_motion(model, mode, q, lead)?[model.ix_phi()];
    if h_phi.abs() < 1e-12 {
        return Err(bad(
            "theta",
            "H_φ = 0: the pitch does not move with θ₁ here (extremum)",
        ));
    }
    Ok(1.0 / h_phi)
}

/// Fig. 4.8's quantity: the largest rate of joint `lead` along its free motion
/// ([`lead_motion`]) before a contact lifts at zero torque ([`liftoff_speed`]); `Ok(None)`
/// where none lifts (or the linear program fails), an error where the motion is undefined.
pub fn lead_liftoff_speed(
    model: &Model,
    mode: ContactMode,
    q: &[f64],
    lead: usize,
) -> Result<Option<f64>, SimError> {
    let dir = lead_motion(model, mode, q, lead)?;
    let tau = vec![0.0; model.n_joints()];
    Ok(liftoff_speed(model, &FlatGround, mode, q, &dir, &tau)
        .ok()
        .and_then(|l| l.speed))
}
