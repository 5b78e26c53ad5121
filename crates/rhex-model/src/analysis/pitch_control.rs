//! Pitch control in leaping (thesis 4.3.3): the splay derivative of the normal-force
//! imbalance (4.61, Result C.2), single-leg pitch dynamics (4.62)–(4.63, Result C.3), and the
//! takeoff-speed bound with a torque–speed motor (4.64)–(4.66, Result C.4, Figs. 4.10–4.12).
//!
//! The takeoff bound at one state, its maxima over leg angle or gear ratio (Figs. 4.11/4.12:
//! not convex, grid then golden section) and the single-leg pitch acceleration are the
//! generic ones of [`selfmanip_sim::analysis::one_leg`], here on RHex's rear leg with
//! X-RHex's motor ([`xrhex_line`]).
use super::{bad, check_finite};
use crate::params::{LegShape, RhexParams};
use crate::{Rhex, RhexError};
use selfmanip_core::{ContactMode, Model};
use selfmanip_sim::analysis::double_stance::{splay_derivative as generic_splay, splay_stance};
pub use selfmanip_sim::analysis::maximise::{golden_max, grid_golden_max};
pub use selfmanip_sim::analysis::one_leg::{
    best_takeoff_over_theta2, optimal_gear_ratio, rear_stance_q, rear_takeoff_speed,
    single_leg_pitch_accel,
};
pub use selfmanip_sim::analysis::takeoff::{takeoff_bound, TakeoffBound, TorqueSpeedLine};
use selfmanip_sim::analysis::takeoff_maps::{self, best_takeoffs, best_takeoffs_by_ratio};
use serde::Serialize;

/// X-RHex's motor (catalog `x-rhex`, gearbox efficiency of `x-rhex-28`) at gear ratio
/// `ratio`, two motors per planar leg.
pub fn xrhex_line(ratio: f64) -> Result<TorqueSpeedLine, RhexError> {
    Ok(TorqueSpeedLine::from_catalog(
        &motor::Catalog::thesis(),
        "x-rhex",
        "x-rhex-28",
        ratio,
        2.0,
    )?)
}

/// Leg geometry for the takeoff analyses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum TakeoffLeg {
    /// Point toe at `ρ` (stick leg, (4.65)).
    Stick,
    /// RHex's half-circle leg: rolls for `−π < θ − φ < 0`, on its toe otherwise.
    HalfCircle,
    /// A full circle of diameter `ρ` through hip and toe: rolls at every angle — the rolling
    /// contact assumed by (4.66) and Figs. 4.10–4.12 over their whole range.
    Rolling,
}

/// The RHex model (massless legs, Table 4.2 unless `params` given) with the chosen legs.
pub fn takeoff_model(params: Option<RhexParams>, leg: TakeoffLeg) -> Result<Model, RhexError> {
    let mut p = params.unwrap_or_default();
    p.leg_shape = match leg {
        TakeoffLeg::Stick => LegShape::Stick,
        _ => LegShape::HalfCircle,
    };
    p.validate()?;
    let mut d = p.description();
    if leg == TakeoffLeg::Rolling {
        takeoff_maps::rolling_legs(&mut d);
    }
    Ok(d.build()?)
}

/// Closed forms (4.65) (stick, `inertia_factor = 1`) and (4.66) (rolling, `= 1/2`) at
/// mid-stance `θ₂ = φ = 0`: `ẋ = (−κ_b + √(κ_b² + 4 I κ_c)) / (2I)`, `I = factor · I_b`,
/// `κ_b = ℓ₂ κ_G² κ_P`, `κ_c = κ_b ρ₂ (1/κ_G − φ̇) + ρ₂ g I_b` (re-derived, see errata).
#[allow(non_snake_case)]
pub fn midstance_closed_form(
    p: &RhexParams,
    line: &TorqueSpeedLine,
    phi_dot: f64,
    inertia_factor: f64,
) -> f64 {
    let kb = p.l2 * line.kappa_g().powi(2) * line.kappa_p();
    let kc = kb * p.rho2 * (1.0 / line.kappa_g() - phi_dot) + p.rho2 * p.g * p.I_b;
    let i = inertia_factor * p.I_b;
    (-kb + (kb * kb + 4.0 * i * kc).sqrt()) / (2.0 * i)
}

/// One sample of Figs. 4.10–4.12 (the generic [`takeoff_maps::TakeoffSample`] with RHex's
/// legs).
pub type TakeoffSample = takeoff_maps::TakeoffSample<TakeoffLeg>;

/// Fig. 4.10: `|ẋ|` at rear-leg takeoff over `(θ₂, φ)` for stick and rolling legs, `φ̇ = 0`,
/// X-RHex motor at gear ratio `ratio` ([`takeoff_maps::takeoff_map`]).
pub fn fig_4_10(
    params: Option<RhexParams>,
    theta2_range: [f64; 2],
    phi_range: [f64; 2],
    n: usize,
    ratio: f64,
) -> Result<Vec<TakeoffSample>, RhexError> {
    let n = super::grid_points(n)?;
    let line = xrhex_line(ratio)?;
    let mut out = Vec::new();
    for leg in [TakeoffLeg::Stick, TakeoffLeg::Rolling] {
        let model = takeoff_model(params.clone(), leg)?;
        let map = takeoff_maps::takeoff_map(&model, &line, ratio, leg, theta2_range, phi_range, n);
        out.extend(map?);
    }
    Ok(out)
}

/// Fig. 4.11: best `|ẋ|` over `θ₂` for each gear ratio and pitch (rolling legs, `φ̇ = 0`,
/// [`best_takeoffs_by_ratio`]).
pub fn fig_4_11(
    params: Option<RhexParams>,
    ratios: &[f64],
    phis: &[f64],
    theta2_range: [f64; 2],
) -> Result<Vec<TakeoffSample>, RhexError> {
    let model = takeoff_model(params, TakeoffLeg::Rolling)?;
    let leg = TakeoffLeg::Rolling;
    best_takeoffs_by_ratio(&model, ratios, xrhex_line, leg, phis, theta2_range)
}

/// Fig. 4.12: best `|ẋ|` over `θ₂` for each pitch rate and pitch (rolling legs, ratio `ratio`).
pub fn fig_4_12(
    params: Option<RhexParams>,
    phi_dots: &[f64],
    phis: &[f64],
    theta2_range: [f64; 2],
    ratio: f64,
) -> Result<Vec<TakeoffSample>, RhexError> {
    let model = takeoff_model(params, TakeoffLeg::Rolling)?;
    let line = xrhex_line(ratio)?;
    let leg = TakeoffLeg::Rolling;
    Ok(best_takeoffs(
        &model,
        &line,
        ratio,
        leg,
        phi_dots,
        phis,
        theta2_range,
    ))
}

/// The height (z down) from which RHex's double stance is solved: near its standing height.
const STANCE_Z_GUESS_M: f64 = -0.17;

/// Both stick toes down at `θ = (θ_m + θ_d, θ_m − θ_d)`: body height and pitch solved from the
/// base constraints (4.41); velocity along the free motion with `y = θ_m` (4.46) at rate
/// `theta_m_dot` ([`splay_stance`]). Returns `(q, q̇, mode)` for mode `0101`.
pub fn double_stance_state(
    rhex: &Rhex,
    theta_m: f64,
    theta_d: f64,
    theta_m_dot: f64,
) -> Result<(Vec<f64>, Vec<f64>, ContactMode), RhexError> {
    let mode = stance_mode(rhex, &[theta_m, theta_d, theta_m_dot])?;
    let (q, qd) = splay_stance(
        &rhex.model,
        mode,
        [theta_m, theta_d],
        theta_m_dot,
        STANCE_Z_GUESS_M,
    )?;
    Ok((q, qd, mode))
}

/// The mode `0101` of a two-pair model, its inputs `theta` finite.
fn stance_mode(rhex: &Rhex, theta: &[f64]) -> Result<ContactMode, RhexError> {
    check_finite("theta", theta)?;
    if rhex.model.n_joints() != 2 {
        return Err(bad("pairs", "double stance needs exactly two leg pairs"));
    }
    rhex.mode("0101")
}

/// Result C.2 / (4.61): `∂((Uλ)_2n − (Uλ)_1n)/∂θ_d` at `θ_d = 0` by central differences of
/// the general dynamics (the generic [`splay_derivative`](generic_splay) on RHex's stance).
pub fn splay_derivative(
    rhex: &Rhex,
    theta_m: f64,
    theta_m_dot: f64,
    tau: f64,
) -> Result<f64, RhexError> {
    let mode = stance_mode(rhex, &[theta_m, 0.0, theta_m_dot])?;
    let z = STANCE_Z_GUESS_M;
    Ok(generic_splay(
        &rhex.model,
        mode,
        theta_m,
        theta_m_dot,
        tau,
        z,
    )?)
}
