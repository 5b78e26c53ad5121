//! Maps of the rear leg's takeoff speed for any planar robot whose contacts are listed front
//! to rear ([`super::one_leg`]): over a grid of leg angle and pitch (thesis Fig. 4.10), and
//! its best over the leg angle at each pitch for a set of pitch rates (Figs. 4.11/4.12); the
//! grids' size bound ([`MAX_FIGURE_GRID`]); legs made to roll at every angle ([`rolling_legs`]). RHex's figures (its legs, X-RHex's motor) are in
//! `rhex-model`.
use super::bad;
use super::one_leg::{best_takeoff_over_theta2, rear_takeoff_speed};
use super::takeoff::TorqueSpeedLine;
use crate::error::SimError;
use selfmanip_core::description::{RobotDescription, ShapeDescription};
use selfmanip_core::Model;
use serde::Serialize;

/// The most points per axis of a figure's grid (Figs. 4.8, 4.10): 512² poses, each a
/// contact problem (Fig. 4.8 solves a linear program per point), are minutes of work; the
/// figures use 13–25.
pub const MAX_FIGURE_GRID: usize = 512;

/// `n` points per axis of a figure's grid, 2 to [`MAX_FIGURE_GRID`] (else an error naming `n`).
pub fn grid_points(n: usize) -> Result<usize, SimError> {
    if (2..=MAX_FIGURE_GRID).contains(&n) {
        Ok(n)
    } else {
        Err(bad(
            "n",
            format!("a figure's grid has 2 to {MAX_FIGURE_GRID} points per axis, got {n}"),
        ))
    }
}

/// `n` evenly spaced points from `r[0]` to `r[1]` (both ends; one point: `r[0]`).
pub fn linspace(r: [f64; 2], n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| r[0] + (r[1] - r[0]) * i as f64 / (n.max(2) - 1) as f64)
        .collect()
}

/// Legs that roll at every angle: each arc contact of `d` becomes the full circle it lies on
/// (the rolling contact that (4.66) and Figs. 4.10–4.12 assume over their whole range).
pub fn rolling_legs(d: &mut RobotDescription) {
    for c in d.contacts.iter_mut() {
        if let ShapeDescription::Arc {
            center_m, radius_m, ..
        } = c.shape
        {
            c.shape = ShapeDescription::Circle { center_m, radius_m };
        }
    }
}

/// One sample of a takeoff map, with the caller's tag `leg` for the legs it was taken with.
#[derive(Debug, Clone, Serialize)]
pub struct TakeoffSample<L> {
    pub theta2: f64,
    pub phi: f64,
    /// Output name `phidot` (`docs/conventions.md`).
    #[serde(rename = "phidot")]
    pub phi_dot: f64,
    pub gear_ratio: f64,
    pub leg: L,
    /// `|ẋ|` at takeoff (m/s); `None` where the leg cannot hold contact even at rest. Output
    /// name `xdot`.
    #[serde(rename = "xdot")]
    pub x_dot: Option<f64>,
}

/// Fig. 4.10's map: `|ẋ|` at rear-leg takeoff over an `n × n` grid of `(θ₂, φ)` (`θ₂`
/// slowest), `φ̇ = 0`, with the motor `line` of gear ratio `gear_ratio`.
pub fn takeoff_map<L: Copy>(
    model: &Model,
    line: &TorqueSpeedLine,
    gear_ratio: f64,
    leg: L,
    theta2_range: [f64; 2],
    phi_range: [f64; 2],
    n: usize,
) -> Result<Vec<TakeoffSample<L>>, SimError> {
    let n = grid_points(n)?;
    let mut out = Vec::with_capacity(n * n);
    for &theta2 in &linspace(theta2_range, n) {
        for &phi in &linspace(phi_range, n) {
            let b = rear_takeoff_speed(model, theta2, phi, 0.0, line)?;
            out.push(TakeoffSample {
                theta2,
                phi,
                phi_dot: 0.0,
                gear_ratio,
                leg,
                x_dot: b.map(|b| b.x_dot.abs()),
            });
        }
    }
    Ok(out)
}

/// Fig. 4.11's samples: [`best_takeoffs`] at pitch rate 0 for each gear ratio of `ratios`
/// (slowest), each with its motor `line(G)`.
pub fn best_takeoffs_by_ratio<L: Copy, E>(
    model: &Model,
    ratios: &[f64],
    line: impl Fn(f64) -> Result<TorqueSpeedLine, E>,
    leg: L,
    phis: &[f64],
    theta2_range: [f64; 2],
) -> Result<Vec<TakeoffSample<L>>, E> {
    let mut out = Vec::with_capacity(ratios.len() * phis.len());
    for &g in ratios {
        out.extend(best_takeoffs(
            model,
            &line(g)?,
            g,
            leg,
            &[0.0],
            phis,
            theta2_range,
        ));
    }
    Ok(out)
}

/// Figs. 4.11/4.12's samples: the best `|ẋ|` over `θ₂ ∈ theta2_range`
/// ([`best_takeoff_over_theta2`]) for each pitch rate and pitch (pitch rate slowest), with the
/// motor `line` of gear ratio `gear_ratio`.
pub fn best_takeoffs<L: Copy>(
    model: &Model,
    line: &TorqueSpeedLine,
    gear_ratio: f64,
    leg: L,
    phi_dots: &[f64],
    phis: &[f64],
    theta2_range: [f64; 2],
) -> Vec<TakeoffSample<L>> {
    let mut out = Vec::with_capacity(phi_dots.len() * phis.len());
    for &phi_dot in phi_dots {
        for &phi in phis {
            let (theta2, v) = best_takeoff_over_theta2(model, phi, phi_dot, line, theta2_range);
            out.push(TakeoffSample {
                theta2,
                phi,
                phi_dot,
                gear_ratio,
                leg,
                x_dot: Some(v),
            });
        }
    }
    out
}
