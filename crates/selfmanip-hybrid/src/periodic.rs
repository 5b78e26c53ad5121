//! Periodic hybrid orbits: the return map of a Poincaré section, its Jacobian from the
//! engine's sensitivities ([`crate::sensitivity`]), Newton shooting for its fixed point, the
//! monodromy matrix and the Floquet multipliers. Generic over any [`Model`], terrain and
//! [`Controller`]; the derivation is in `docs/periodic-orbits.md`.
//!
//! **Section and return map.** The section is the apex of a flight, `Σ = {ż = 0, z̈ > 0}`
//! (z down: the body's centre stops rising). From `x₀ ∈ Σ` in flight, a run with
//! [`HybridOptions::stop_at_apex`] goes through its events (touchdown, stance, liftoff, …)
//! and stops at the next apex: `P(x₀) = x(τ(x₀))`, `τ` the return time. Its Jacobian over the
//! whole state is what the engine's chain gives for such a run,
//! `DP = Ξ_apex Φ_k Ξ_k ⋯ Ξ_1 Φ_0` with the terminal apex projection
//! `Ξ_apex = I − f D_xg / (D_xg f)`, `g = −ż`. `P` is constant along the flow
//! (`P(φ_s(x)) = P(x)`), so `DP f(x₀) = 0`: **one multiplier of `DP` is 0**, with the flow as
//! its eigenvector; and the row of `ż` is zero (`P` lands on `Σ`). The other multipliers are
//! those of the map restricted to the section.
//!
//! **Phase and symmetries.** Newton works on the *section coordinates*: the state without
//! `ż` (fixed at 0 by the section: this is the phase condition) and without the *cyclic*
//! coordinates, those the dynamics do not depend on (on flat ground the body's `x`: a
//! gait may advance by a stride per period; its advance is reported as
//! [`PeriodicOrbit::drift`]). With `u` those coordinates, `r(u) = S P(E u) − u` and
//! `∂r/∂u = S DP E − I`, `E` the embedding (`ż = 0`, cyclic coordinates at the guess's) and
//! `S` the selection. A conserved quantity the user did not declare (e.g. a body's angular
//! momentum when no force has a moment about its centre of mass) leaves `∂r/∂u` singular: the
//! step is the least-squares one of minimum norm (singular values below
//! [`PeriodicOptions::rank_rtol`] of the largest dropped), and [`PeriodicOrbit::rank_deficiency`]
//! says how many directions the fixed point is free along (a family of orbits).
//!
//! **Newton.** `u ← u + λ δ`, `δ = −(∂r/∂u)⁺ r`, `λ` halved from 1 until `|r|∞` decreases
//! (at most [`PeriodicOptions::max_halvings`] times; a trial run that does not return counts
//! as no decrease), at most [`PeriodicOptions::max_iterations`] iterations and
//! [`PeriodicOptions::max_runs`] return runs in all. Every run is bounded by the engine's
//! budgets and [`PeriodicOptions::max_period_s`]; what does not converge ends with a typed
//! [`PeriodicError`].
//!
//! **Several guards at once** (a pronk's feet landing and lifting off together): where the
//! return map's derivative depends on the order a perturbation makes the guards fire
//! ([`crate::sensitivity::SaltationStatus::OneSided`]), its Jacobian is the piece of the
//! Bouligand derivative of each event's first order — an element of the B-subdifferential,
//! which Newton converges with as on a smooth map, and the derivative itself on the
//! perturbations that keep the guards simultaneous; [`PeriodicOrbit::one_sided`] lists
//! those events.
//!
//! **Monodromy.** At the fixed point `x*`, [`PeriodicOrbit::monodromy`] is `DP` (multipliers
//! `{0} ∪ λ_Σ`), and [`PeriodicOrbit::period_monodromy`] the Jacobian of the time-`T` flow
//! map, `M_T = ∂x(T)/∂x₀ = DP − f(x*) ∇τ` (since `DP = M_T + f ∇τ`, `∇τ = −D_xg M_T / (D_xg f)`
//! the apex time's gradient), whose multipliers are `{1} ∪ λ_Σ`: the trivial 1 is the flow
//! direction (`M_T f = f`). The orbit is stable when every section multiplier lies inside the
//! unit circle ([`Stability`]).
//!
//! **Controllers.** Each run starts a fresh copy of the controller at `t = 0`, so the map is
//! that of the periodic orbit only if the controller is autonomous: a function of the state
//! and of the phase its events select, the same at every apex (no clock, nothing remembered
//! from the initial state). The multi-period tests check this by running several periods in
//! one execution.
use crate::controller::Controller;
use crate::error::HybridError;
use crate::event::EventKind;
use crate::execution::{Execution, Termination};
use crate::flow::Flow;
use crate::options::HybridOptions;
use crate::sensitivity::{execution_sensitivity, SaltationStatus, SensitivityError};
use crate::simulate::simulate;
use crate::StepOptions;
use nalgebra::{Complex, DMatrix, DVector, RowDVector};
use selfmanip_core::{ContactMode, Model, Terrain};
use std::sync::Arc;

/// Options of a periodic-orbit search.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicOptions {
    /// Options of every return run (`stop_at_apex` is set by the search).
    pub hybrid: HybridOptions,
    /// A return run that has not reached the section by this time fails (s).
    pub max_period_s: f64,
    /// Coordinates (indices into `q`) the dynamics do not depend on: left out of the
    /// fixed-point condition, their advance per period reported. `None`: the body's `x`
    /// (horizontal translation, right on flat ground; pass `Some(vec![])` on a terrain that
    /// changes along `x`).
    pub cyclic: Option<Vec<usize>>,
    /// Convergence: `|P(x) − x|∞` over the section coordinates (SI units: m, rad, m/s, rad/s).
    pub tol: f64,
    pub max_iterations: usize,
    /// Step halvings of the line search per iteration.
    pub max_halvings: usize,
    /// Return runs of the whole search (each a simulation, the Jacobian's with its
    /// sensitivities): what bounds its cost.
    pub max_runs: usize,
    /// Singular values of `∂r/∂u` below this fraction of the largest are dropped.
    pub rank_rtol: f64,
    /// Multipliers within this distance of the unit circle count as neutral.
    pub unit_circle_tol: f64,
}

impl Default for PeriodicOptions {
    /// Tolerances tight enough that the return map is smooth to ~1e-10 (a fixed point to
    /// 1e-9): DOPRI5 at `rtol = 1e-11`, events located to 1e-13 s.
    fn default() -> Self {
        PeriodicOptions {
            hybrid: HybridOptions {
                step: StepOptions {
                    rtol: 1e-11,
                    atol: 1e-13,
                    ..StepOptions::default()
                },
                event_tol_s: 1e-13,
                ..HybridOptions::default()
            },
            max_period_s: 10.0,
            cyclic: None,
            tol: 1e-9,
            max_iterations: 30,
            max_halvings: 12,
            max_runs: 100,
            rank_rtol: 1e-8,
            unit_circle_tol: 1e-6,
        }
    }
}

/// Why a periodic-orbit computation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PeriodicError {
    /// A bad argument (the field is named).
    #[error("invalid {field}: {reason}")]
    InvalidInput { field: &'static str, reason: String },
    #[error(transparent)]
    Hybrid(#[from] HybridError),
    #[error(transparent)]
    Sensitivity(#[from] SensitivityError),
    /// The run from a state did not reach the section: it ended otherwise (a fall, a
    /// budget, [`PeriodicOptions::max_period_s`]).
    #[error("the run from the section did not return to it: it ended at t = {t} s: {termination}")]
    NoReturn { termination: Termination, t: f64 },
    /// The return map has no Jacobian at this state (an event whose saltation matrix is not
    /// defined: grazing, simultaneous, not covered; see [`crate::sensitivity`]).
    #[error("the return map is not differentiable here: {reason}")]
    NotDifferentiable { reason: String },
    /// The iteration budget ran out.
    #[error("Newton did not converge in {iterations} iterations (residual {residual:e})")]
    NotConverged {
        iterations: usize,
        residual: f64,
        /// The best state found (on the section).
        best: Vec<f64>,
    },
    /// The search used [`PeriodicOptions::max_runs`] return runs.
    #[error("the search used its {runs} return runs (residual {residual:e})")]
    RunBudget {
        runs: usize,
        residual: f64,
        best: Vec<f64>,
    },
    /// No step along the Newton direction decreased the residual.
    #[error("the line search failed at iteration {iteration} (residual {residual:e})")]
    LineSearchFailed {
        iteration: usize,
        residual: f64,
        best: Vec<f64>,
    },
}

/// One application of the return map.
#[derive(Debug, Clone)]
pub struct ReturnMap {
    /// The state on the section the run started from (`ż = 0`).
    pub x0: Vec<f64>,
    /// `P(x0)`: the state at the next apex.
    pub x1: Vec<f64>,
    /// The return time `τ(x0)` (s).
    pub period_s: f64,
    /// `DP` over the whole state (`2nq × 2nq`), when asked for.
    pub jacobian: Option<DMatrix<f64>>,
    /// `∇τ = dτ/dx0`, when the Jacobian was asked for.
    pub time_gradient: Option<RowDVector<f64>>,
    /// The events at which several guards fired at once and the derivative depends on
    /// their order ([`SaltationStatus::OneSided`]): `jacobian` and `time_gradient` are then
    /// the one-sided ones for the perturbations that keep each such event's first order
    /// (`orders[0]`), and on the perturbations that keep its guards simultaneous the
    /// derivative itself.
    pub one_sided: Vec<OneSidedEvent>,
    /// The run.
    pub execution: Execution,
}

/// An event of a return run at which several guards fired at once and whose derivative
/// depends on the order a perturbation makes them fire in.
#[derive(Debug, Clone, PartialEq)]
pub struct OneSidedEvent {
    pub t: f64,
    pub kind: EventKind,
    /// The contacts whose guards fired.
    pub guards: Vec<usize>,
    /// The orders whose one-sided derivatives were formed; the Jacobians given are those
    /// of the first.
    pub orders: Vec<Vec<usize>>,
}

/// The stability of a periodic orbit, from its section multipliers `λ_Σ`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stability {
    /// Every `|λ_Σ| < 1 − tol`: perturbations decay.
    Stable,
    /// The largest `|λ_Σ|` is within `tol` of 1 (a conserved quantity or a family of orbits).
    Neutral,
    /// Some `|λ_Σ| > 1 + tol`: perturbations along it grow.
    Unstable,
}

/// A periodic orbit through the apex section.
#[derive(Debug, Clone)]
pub struct PeriodicOrbit {
    /// The fixed point `x*` (full state, `ż = 0`).
    pub x: Vec<f64>,
    /// The period `T = τ(x*)` (s).
    pub period_s: f64,
    /// Cyclic coordinates (indices into `q`) and their advance per period.
    pub cyclic: Vec<usize>,
    pub drift: Vec<f64>,
    /// The events of one period, the terminal apex last.
    pub events: Vec<(EventKind, ContactMode)>,
    /// `DP` at `x*` (`2nq × 2nq`).
    pub monodromy: DMatrix<f64>,
    /// `M_T = DP − f(x*) ∇τ`, the time-`T` flow map's Jacobian.
    pub period_monodromy: DMatrix<f64>,
    /// Eigenvalues of `monodromy`, by decreasing modulus.
    pub multipliers: Vec<Complex<f64>>,
    /// The section coordinates (indices into the state `(q, q̇)`).
    pub section_coordinates: Vec<usize>,
    /// `S DP E`: the return map's Jacobian in section coordinates.
    pub section_jacobian: DMatrix<f64>,
    /// Its eigenvalues, by decreasing modulus.
    pub section_multipliers: Vec<Complex<f64>>,
    pub stability: Stability,
    /// Newton iterations used and the final residual `|P(x*) − x*|∞`.
    pub iterations: usize,
    pub residual: f64,
    /// Dimensions of the family the fixed point lies on (singular values dropped).
    pub rank_deficiency: usize,
    /// Events of the period at which several guards fire at once and the derivative
    /// depends on their order ([`ReturnMap::one_sided`]): the monodromies and multipliers
    /// are then those of one piece of the return map's Bouligand derivative, the one whose
    /// perturbations keep each event's `orders[0]`; on perturbations that keep the guards
    /// simultaneous (in a mirror-symmetric gait, the symmetric ones) every piece is the
    /// derivative. Empty where the map is differentiable.
    pub one_sided: Vec<OneSidedEvent>,
}

/// Eigenvalues of a square matrix by decreasing modulus (ties: by real part, then
/// imaginary part, decreasing), from nalgebra's real Schur form ([`crate::eigen`]: a
/// matrix holding inf/NaN, or a QR iteration past its cap, is
/// [`PeriodicError::NotDifferentiable`] rather than a loop without end).
pub fn floquet_multipliers(m: &DMatrix<f64>) -> Result<Vec<Complex<f64>>, PeriodicError> {
    let mut ev =
        crate::eigen::eigenvalues(m.clone()).ok_or_else(|| PeriodicError::NotDifferentiable {
            reason: "the multipliers of a Jacobian that is not finite, or whose QR iteration \
                     did not converge, are not defined"
                .into(),
        })?;
    ev.sort_by(|a, b| {
        b.norm()
            .total_cmp(&a.norm())
            .then(b.re.total_cmp(&a.re))
            .then(b.im.total_cmp(&a.im))
    });
    Ok(ev)
}

/// The verdict from section multipliers (see [`Stability`]).
pub fn stability(section_multipliers: &[Complex<f64>], tol: f64) -> Stability {
    let rho = section_multipliers
        .iter()
        .map(|l| l.norm())
        .fold(0.0, f64::max);
    if rho > 1.0 + tol {
        Stability::Unstable
    } else if rho < 1.0 - tol {
        Stability::Stable
    } else {
        Stability::Neutral
    }
}

fn check_state(model: &Model, x: &[f64], field: &'static str) -> Result<(), PeriodicError> {
    let n2 = 2 * model.nq();
    if x.len() != n2 {
        return Err(PeriodicError::InvalidInput {
            field,
            reason: format!("expected {n2} entries (q, q̇), got {}", x.len()),
        });
    }
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return Err(PeriodicError::InvalidInput {
            field,
            reason: format!("entry {i} is not finite"),
        });
    }
    Ok(())
}

fn check_options(model: &Model, opts: &PeriodicOptions) -> Result<Vec<usize>, PeriodicError> {
    let bad = |field, reason: &str| PeriodicError::InvalidInput {
        field,
        reason: reason.into(),
    };
    if !(opts.max_period_s.is_finite() && opts.max_period_s > 0.0) {
        return Err(bad("max_period_s", "must be finite and positive"));
    }
    if !(opts.tol.is_finite() && opts.tol > 0.0) {
        return Err(bad("tol", "must be finite and positive"));
    }
    if !(opts.rank_rtol.is_finite() && (0.0..1.0).contains(&opts.rank_rtol)) {
        return Err(bad("rank_rtol", "must lie in [0, 1)"));
    }
    if !(opts.unit_circle_tol.is_finite() && opts.unit_circle_tol >= 0.0) {
        return Err(bad("unit_circle_tol", "must be finite and non-negative"));
    }
    if opts.max_iterations == 0 {
        return Err(bad("max_iterations", "must be at least 1"));
    }
    if opts.max_runs == 0 {
        return Err(bad("max_runs", "must be at least 1"));
    }
    opts.hybrid.validate(opts.max_period_s)?;
    let cyclic = opts.cyclic.clone().unwrap_or_else(|| vec![model.ix_x()]);
    for &c in &cyclic {
        if c >= model.nq() {
            return Err(PeriodicError::InvalidInput {
                field: "cyclic",
                reason: format!("coordinate {c} is not below nq = {}", model.nq()),
            });
        }
        if c == model.ix_z() {
            return Err(bad("cyclic", "z cannot be cyclic (gravity depends on it)"));
        }
    }
    Ok(cyclic)
}

/// The return map of the apex section at `x0` (its `ż` is set to 0: the section fixes it),
/// starting in flight with a fresh copy of `controller`; with its Jacobian if `jacobian`.
pub fn return_map(
    model: &Model,
    terrain: &dyn Terrain,
    controller: &dyn Controller,
    x0: &[f64],
    jacobian: bool,
    opts: &PeriodicOptions,
) -> Result<ReturnMap, PeriodicError> {
    check_state(model, x0, "x0")?;
    check_options(model, opts)?;
    let section = ApexSection {
        model,
        terrain,
        controller,
        opts,
    };
    section.map(x0, jacobian)
}

/// The apex section of a system: [`return_map`] without the checks of its inputs (made once
/// by the caller).
#[derive(Clone, Copy)]
struct ApexSection<'a> {
    model: &'a Model,
    terrain: &'a dyn Terrain,
    controller: &'a dyn Controller,
    opts: &'a PeriodicOptions,
}

impl ApexSection<'_> {
    fn map(self, x0: &[f64], jacobian: bool) -> Result<ReturnMap, PeriodicError> {
        let ApexSection {
            model,
            terrain,
            controller,
            opts,
        } = self;
        let nq = model.nq();
        let mut x0 = x0.to_vec();
        x0[nq + model.ix_z()] = 0.0;
        let hybrid = HybridOptions {
            stop_at_apex: true,
            ..opts.hybrid
        };
        let exec = simulate(
            model,
            terrain,
            controller,
            ContactMode::FLIGHT,
            &x0[..nq],
            &x0[nq..],
            opts.max_period_s,
            hybrid,
        )?;
        if exec.termination != Termination::Apex {
            return Err(PeriodicError::NoReturn {
                termination: exec.termination.clone(),
                t: exec.t,
            });
        }
        let x1: Vec<f64> = exec.q.iter().chain(&exec.qd).copied().collect();
        let (mut jac, mut tg, mut one_sided) = (None, None, Vec::new());
        if jacobian {
            let s = execution_sensitivity(model, terrain, &exec)?;
            one_sided = s
                .events
                .iter()
                .filter_map(|e| match &e.status {
                    SaltationStatus::OneSided { guards } => Some(OneSidedEvent {
                        t: e.t,
                        kind: e.kind,
                        guards: guards.clone(),
                        orders: e.one_sided.iter().map(|p| p.order.clone()).collect(),
                    }),
                    _ => None,
                })
                .collect();
            let Some(j) = s.state_jacobian.or(s.one_sided_state_jacobian) else {
                let reason = s
                    .events
                    .iter()
                    .find(|e| e.saltation.is_none())
                    .map(|e| {
                        let why = e.status.reason().unwrap_or_default();
                        format!("{} at t = {} s: {why}", e.kind.name(), e.t)
                    })
                    .unwrap_or_else(|| "a segment end without an event".into());
                return Err(PeriodicError::NotDifferentiable { reason });
            };
            jac = Some(j);
            tg = s.events.last().and_then(|e| e.time_gradient.clone());
        }
        Ok(ReturnMap {
            x0,
            x1,
            period_s: exec.t,
            jacobian: jac,
            time_gradient: tg,
            one_sided,
            execution: exec,
        })
    }
}

/// The section coordinates: every state index but `ż` and the cyclic positions.
fn section_coordinates(model: &Model, cyclic: &[usize]) -> Vec<usize> {
    let zd = model.nq() + model.ix_z();
    (0..2 * model.nq())
        .filter(|&i| i != zd && !cyclic.contains(&i))
        .collect()
}

fn residual(rm: &ReturnMap, idx: &[usize]) -> DVector<f64> {
    DVector::from_iterator(idx.len(), idx.iter().map(|&i| rm.x1[i] - rm.x0[i]))
}

/// Finds the periodic orbit through the apex section near `guess` (full state; its `ż` is
/// ignored) by damped Newton shooting on the section coordinates (module docs).
pub fn find_periodic_orbit(
    model: &Model,
    terrain: &dyn Terrain,
    controller: &dyn Controller,
    guess: &[f64],
    opts: &PeriodicOptions,
) -> Result<PeriodicOrbit, PeriodicError> {
    check_state(model, guess, "guess")?;
    let cyclic = check_options(model, opts)?;
    let idx = section_coordinates(model, &cyclic);
    let n2 = 2 * model.nq();
    let mut x = guess.to_vec();
    x[model.nq() + model.ix_z()] = 0.0;
    let section = ApexSection {
        model,
        terrain,
        controller,
        opts,
    };
    let mut rm = section.map(&x, true)?;
    let mut runs = 1;
    let mut r = residual(&rm, &idx);
    for it in 0..opts.max_iterations {
        let jac = rm.jacobian.as_ref().expect("asked for");
        // a state near the largest f64 (a guess of 1e308) returns inf/NaN: no Newton step,
        // SVD or eigenvalue is defined on it (and nalgebra's would not return)
        if !r.iter().chain(jac.iter()).all(|v| v.is_finite()) {
            return Err(PeriodicError::NotDifferentiable {
                reason: format!(
                    "the return map or its Jacobian is not finite at iteration {it} (a state \
                     too large for f64 arithmetic)"
                ),
            });
        }
        let rnorm = r.amax();
        let mut a = DMatrix::zeros(idx.len(), idx.len());
        for (i, &ri) in idx.iter().enumerate() {
            for (j, &cj) in idx.iter().enumerate() {
                a[(i, j)] = jac[(ri, cj)];
            }
        }
        let dr = &a - DMatrix::identity(idx.len(), idx.len());
        let svd = dr.clone().svd(true, true);
        let smax = svd.singular_values.amax();
        let cut = opts.rank_rtol * smax;
        let rank_deficiency = svd.singular_values.iter().filter(|&&s| s <= cut).count();
        if rnorm <= opts.tol {
            return orbit(
                model,
                terrain,
                rm,
                a,
                cyclic,
                idx,
                it,
                rnorm,
                rank_deficiency,
                opts,
            );
        }
        let delta = -svd
            .pseudo_inverse(cut.max(f64::MIN_POSITIVE))
            .expect("U and V were computed")
            * &r;
        // damped step: halve until the residual decreases (the full step with its Jacobian,
        // which Newton accepts near the orbit; shorter ones without, the Jacobian after)
        let mut lambda = 1.0;
        let mut accepted = None;
        for h in 0..=opts.max_halvings {
            if runs >= opts.max_runs {
                return Err(PeriodicError::RunBudget {
                    runs,
                    residual: rnorm,
                    best: x,
                });
            }
            let mut trial = x.clone();
            for (k, &i) in idx.iter().enumerate() {
                trial[i] += lambda * delta[k];
            }
            runs += 1;
            if let Ok(t) = section.map(&trial, h == 0) {
                let rt = residual(&t, &idx);
                if rt.amax() < rnorm {
                    accepted = Some((trial, t, rt));
                    break;
                }
            }
            lambda *= 0.5;
        }
        let accepted = match accepted {
            Some((xt, t, rt)) if t.jacobian.is_none() => {
                runs += 1;
                let t = section.map(&xt, true)?;
                Some((xt, t, rt))
            }
            other => other,
        };
        let Some((xt, rmt, rt)) = accepted else {
            return Err(PeriodicError::LineSearchFailed {
                iteration: it,
                residual: rnorm,
                best: x,
            });
        };
        debug_assert_eq!(xt.len(), n2);
        (x, rm, r) = (xt, rmt, rt);
    }
    Err(PeriodicError::NotConverged {
        iterations: opts.max_iterations,
        residual: r.amax(),
        best: x,
    })
}

/// The orbit's data at a converged return map.
#[allow(clippy::too_many_arguments)]
fn orbit(
    model: &Model,
    terrain: &dyn Terrain,
    rm: ReturnMap,
    section_jacobian: DMatrix<f64>,
    cyclic: Vec<usize>,
    idx: Vec<usize>,
    iterations: usize,
    residual: f64,
    rank_deficiency: usize,
    opts: &PeriodicOptions,
) -> Result<PeriodicOrbit, PeriodicError> {
    let dp = rm.jacobian.clone().expect("asked for");
    let tg = rm
        .time_gradient
        .clone()
        .expect("a defined Jacobian has the apex time's gradient");
    // f(x*) at the apex, with the controller the last segment ran with
    let last = rm.execution.segments.last().expect("a run has a segment");
    let mut flow = Flow::new(model, terrain, Arc::clone(&last.controller));
    let mut f = DVector::zeros(rm.x1.len());
    let period_monodromy = match flow.rhs(rm.period_s, last.mode, &rm.x1, f.as_mut_slice()) {
        Ok(()) => &dp - &f * &tg,
        Err(_) => DMatrix::from_element(dp.nrows(), dp.ncols(), f64::NAN),
    };
    let multipliers = floquet_multipliers(&dp)?;
    let section_multipliers = floquet_multipliers(&section_jacobian)?;
    let drift = cyclic.iter().map(|&c| rm.x1[c] - rm.x0[c]).collect();
    Ok(PeriodicOrbit {
        x: rm.x0.clone(),
        period_s: rm.period_s,
        drift,
        cyclic,
        events: rm
            .execution
            .events
            .iter()
            .map(|e| (e.kind, e.mode_after))
            .collect(),
        monodromy: dp,
        period_monodromy,
        multipliers,
        section_coordinates: idx,
        stability: stability(&section_multipliers, opts.unit_circle_tol),
        section_jacobian,
        section_multipliers,
        iterations,
        residual,
        rank_deficiency,
        one_sided: rm.one_sided,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Multipliers of a matrix with known eigenvalues (a rotation by 0.3 scaled by 0.5, and
    /// 2): sorted by modulus, the complex pair with conjugate parts.
    #[test]
    fn multipliers_of_a_known_matrix() {
        let (c, s) = (0.5 * 0.3f64.cos(), 0.5 * 0.3f64.sin());
        let m = DMatrix::from_row_slice(3, 3, &[c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 2.0]);
        let ev = floquet_multipliers(&m).unwrap();
        assert!((ev[0] - Complex::new(2.0, 0.0)).norm() < 1e-14);
        assert!((ev[1] - Complex::new(c, s)).norm() < 1e-14, "{ev:?}");
        assert!((ev[2] - Complex::new(c, -s)).norm() < 1e-14, "{ev:?}");
        assert_eq!(stability(&ev, 1e-6), Stability::Unstable);
        assert_eq!(stability(&ev[1..], 1e-6), Stability::Stable);
        assert_eq!(
            stability(&[Complex::new(1.0 - 1e-9, 0.0)], 1e-6),
            Stability::Neutral
        );
    }
}
