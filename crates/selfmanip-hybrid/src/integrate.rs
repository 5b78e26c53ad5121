//! Dormand–Prince 5(4) with its 4th-order-accurate dense output (Hairer, Nørsett & Wanner,
//! *Solving ODEs I*, II.5 / DOPRI5): adaptive steps, FSAL, and a continuous interpolant on
//! every accepted step, on which guards are located by root finding ([`crate::guard`],
//! [`crate::locate`]). Written once here because the maintained Rust ODE crates either lack
//! event location on the dense output or misplace events (see `shared/ECOSYSTEM.md`).
//!
//! One step from $(t, y)$ of size $h$ evaluates the seven stages
//! $k_s = f(t + c_s h,\ y + h \sum_{j \lt s} a_{sj} k_j)$ (the last at the step's end point, reused
//! as the next step's first: FSAL), advances $y_{n+1} = y + h \sum_s b_s k_s$, and estimates
//! the error by $h \sum_s (b_s - \hat b_s) k_s$. The continuous extension on $[t, t + h]$ is
//! the quartic in $\theta = (t' - t)/h$
//! $$ y(t') = r_0 + \theta \big(r_1 + (1-\theta)(r_2 + \theta (r_3 + (1-\theta) r_4))\big), $$
//! fourth-order accurate (Hairer, Nørsett & Wanner, II.6, eq. (6.12)).
//!
//! [`DenseOutput`] keeps a run of accepted steps in one flat buffer that grows by doubling:
//! recording a step allocates nothing once the buffer has grown to the run's size.

pub use crate::ode_system::OdeSystem;
use crate::rosenbrock::Rodas4;

/// Butcher tableau of DOPRI5.
pub(crate) const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
pub(crate) const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// Error coefficients `b − b̂`.
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];
/// Dense output coefficients.
const D: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

/// Tolerances and step limits.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepOptions {
    pub rtol: f64,
    pub atol: f64,
    pub h_initial_s: f64,
    pub h_max_s: f64,
    pub h_min_s: f64,
    /// Switch to the linearly implicit RODAS4 ([`crate::rosenbrock`]) where DOPRI5's
    /// stiffness test finds the step held by its stability region, and back where an
    /// explicit step of the implicit one's size would be stable (see [`Dopri5`]). On (the
    /// default); the sensitivity pass integrates the tangent over an implicit step of the
    /// record with a RODAS4 step of its own ([`crate::sensitivity`]). Off: DOPRI5 throughout.
    #[serde(default = "stiff_switch_default")]
    pub stiff_switch: bool,
    /// How a mechanical state's velocities share the absolute tolerance `atol`
    /// ([`VelocityTolerance`]; default [`VelocityTolerance::Uniform`], a scenario's
    /// `selfmanip_sim::SimOptions` [`VelocityTolerance::KineticEnergy`]).
    #[serde(default)]
    pub velocity_tolerance: VelocityTolerance,
}

/// The absolute tolerance of each velocity of a mechanical state `y = [q; q̇]` (the positions
/// always have `atol`).
///
/// Below `atol / rtol` a component's error is measured against `atol` alone, so a velocity
/// passing through zero is resolved to `atol` whatever it carries. After an impact, a servo's
/// fast transient on a light link (`k_d / M̄ᵢᵢ` of 10⁴–10⁵ /s) then sets the step for tens of
/// steps although its error moves next to no energy: the error of a velocity changes the
/// kinetic energy by `δT = q̇ᵀ M̄ δq̇ ≤ √(2T) ‖δq̇‖_M̄` (Cauchy–Schwarz in the kinetic-energy
/// metric), so the metric, not the coordinate, says how much a velocity's error weighs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VelocityTolerance {
    /// Every velocity has `atol`.
    #[default]
    Uniform,
    /// Velocity `i` has `atol √(M̄_max / M̄ᵢᵢ)`, `M̄ᵢᵢ` the mass matrix's diagonal at the
    /// segment's start and `M̄_max` its largest entry ([`Self::scales`]): the velocities'
    /// errors measured in the diagonal of the kinetic-energy metric, the heaviest coordinate
    /// at `atol`, none looser than [`MAX_VELOCITY_ATOL_SCALE`] times it (a coordinate lighter
    /// than a millionth of the heaviest, massless ones included, counts as that millionth).
    KineticEnergy,
}

/// The largest factor [`VelocityTolerance::KineticEnergy`] loosens a velocity's absolute
/// tolerance by: `√(10⁶)`, a coordinate a millionth as heavy as the heaviest.
pub const MAX_VELOCITY_ATOL_SCALE: f64 = 1e3;

impl VelocityTolerance {
    /// The factors on `atol` of the state `[q; q̇]` (`scales.len() = 2 nq`) from the mass
    /// matrix's diagonal `mass_diagonal` (`nq` entries, kg or kg m²): 1 for the positions,
    /// [`Self`]'s rule for the velocities. A diagonal with no positive entry (or a
    /// non-finite one) leaves every factor 1.
    pub fn scales(self, mass_diagonal: impl Iterator<Item = f64> + Clone, scales: &mut [f64]) {
        scales.fill(1.0);
        if self == VelocityTolerance::Uniform {
            return;
        }
        let heaviest = mass_diagonal.clone().fold(0.0, f64::max);
        if !(heaviest > 0.0 && heaviest.is_finite()) {
            return;
        }
        let nq = scales.len() / 2;
        let lightest = heaviest / (MAX_VELOCITY_ATOL_SCALE * MAX_VELOCITY_ATOL_SCALE);
        for (s, m) in scales[nq..].iter_mut().zip(mass_diagonal) {
            *s = (heaviest / m.max(lightest)).sqrt();
        }
    }
}

impl Default for StepOptions {
    fn default() -> Self {
        StepOptions {
            rtol: 1e-9,
            atol: 1e-11,
            h_initial_s: 1e-4,
            h_max_s: 1e-2,
            h_min_s: 1e-14,
            stiff_switch: stiff_switch_default(),
            velocity_tolerance: VelocityTolerance::default(),
        }
    }
}

/// [`StepOptions::stiff_switch`]'s default (also where a serialized `StepOptions` omits it).
fn stiff_switch_default() -> bool {
    true
}

/// The continuous extension of one accepted step `[t0, t0 + h]`.
#[derive(Debug, Clone, Default)]
pub struct DenseStep {
    pub t0: f64,
    pub h: f64,
    /// Whether the step is RODAS4's (linearly implicit, [`crate::rosenbrock`]) rather than
    /// DOPRI5's: its interpolant is cubic (`r₄ = 0`), and an explicit tangent step of its
    /// size need not be stable.
    pub implicit: bool,
    /// The five coefficient vectors `r₀ … r₄` of the interpolant, one after the other (one
    /// allocation per stored step).
    r: Vec<f64>,
}

impl DenseStep {
    pub fn t1(&self) -> f64 {
        self.t0 + self.h
    }

    /// `y(t)` for `t` in the step.
    pub fn eval(&self, t: f64, y: &mut [f64]) {
        self.as_view().eval(t, y);
    }

    /// The step as a view, as [`DenseOutput`] hands out its steps.
    pub fn as_view(&self) -> StepView<'_> {
        StepView {
            t0: self.t0,
            h: self.h,
            implicit: self.implicit,
            r: &self.r,
        }
    }
}

/// One accepted step's continuous extension, borrowed from a [`DenseStep`] or a
/// [`DenseOutput`].
#[derive(Debug, Clone, Copy)]
pub struct StepView<'a> {
    pub t0: f64,
    pub h: f64,
    /// Whether the step is RODAS4's ([`DenseStep::implicit`]).
    pub implicit: bool,
    r: &'a [f64],
}

impl StepView<'_> {
    pub fn t1(&self) -> f64 {
        self.t0 + self.h
    }

    /// `y(t)` for `t` in the step: the quartic interpolant of the module docs.
    pub fn eval(&self, t: f64, y: &mut [f64]) {
        let n = y.len();
        debug_assert_eq!(self.r.len(), 5 * n);
        let s = (t - self.t0) / self.h;
        let s1 = 1.0 - s;
        let (r0, rest) = self.r.split_at(n);
        let (r1, rest) = rest.split_at(n);
        let (r2, rest) = rest.split_at(n);
        let (r3, r4) = rest.split_at(n);
        for i in 0..n {
            y[i] = r0[i] + s * (r1[i] + s1 * (r2[i] + s * (r3[i] + s1 * r4[i])));
        }
    }
}

/// The continuous extensions of consecutive accepted steps, in one flat buffer (no
/// allocation per recorded step once it has grown).
#[derive(Debug, Clone, Default)]
pub struct DenseOutput {
    /// Start time and size of each step.
    t0: Vec<f64>,
    h: Vec<f64>,
    /// Whether each step is RODAS4's ([`DenseStep::implicit`]).
    implicit: Vec<bool>,
    /// Each step's five coefficient vectors, step after step.
    r: Vec<f64>,
}

impl DenseOutput {
    /// An empty output with room for `steps` steps of a state of `n` numbers: as many
    /// appended without growing its buffers.
    pub fn with_capacity(steps: usize, n: usize) -> Self {
        DenseOutput {
            t0: Vec::with_capacity(steps),
            h: Vec::with_capacity(steps),
            implicit: Vec::with_capacity(steps),
            r: Vec::with_capacity(5 * n * steps),
        }
    }

    /// Appends a step (which must start where the last one ended).
    #[inline]
    pub fn push(&mut self, step: &DenseStep) {
        debug_assert!(self.t0.is_empty() || step.r.len() * self.t0.len() == self.r.len());
        self.t0.push(step.t0);
        self.h.push(step.h);
        self.implicit.push(step.implicit);
        self.r.extend_from_slice(&step.r);
    }

    pub fn len(&self) -> usize {
        self.t0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t0.is_empty()
    }

    /// Step `i`.
    pub fn step(&self, i: usize) -> StepView<'_> {
        let w = self.r.len() / self.t0.len();
        StepView {
            t0: self.t0[i],
            h: self.h[i],
            implicit: self.implicit[i],
            r: &self.r[i * w..(i + 1) * w],
        }
    }

    /// Whether any step is RODAS4's ([`DenseStep::implicit`]).
    pub fn has_implicit_steps(&self) -> bool {
        self.implicit.iter().any(|&b| b)
    }

    /// The steps in time order.
    pub fn steps(&self) -> impl Iterator<Item = StepView<'_>> {
        (0..self.len()).map(|i| self.step(i))
    }

    /// `y(t)` from the step that contains `t` (the first or last step beyond the ends).
    /// Must not be empty.
    pub fn eval(&self, t: f64, y: &mut [f64]) {
        // the first step that ends at or after t (binary search: the ends are increasing)
        let (mut lo, mut hi) = (0, self.len());
        while lo < hi {
            let mid = (lo + hi) / 2;
            if self.t0[mid] + self.h[mid] < t {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        self.step(lo.min(self.len() - 1)).eval(t, y);
    }
}

/// The right-hand side `ẏ = f(t, y)`, written into its third argument; it may fail.
pub type Rhs<'f, E> = dyn FnMut(f64, &[f64], &mut [f64]) -> Result<(), E> + 'f;

/// Consecutive positive stiffness tests that switch to RODAS4 (Hairer's DOPRI5: 15).
const STIFF_POSITIVES: u32 = 15;
/// Negative tests after which the positives are forgotten (DOPRI5: 6).
const STIFF_NEGATIVES: u32 = 6;
/// The stiffness test runs on every this many accepted explicit steps until it is first
/// positive, then on every step: nearly free where nothing is stiff.
const STIFF_TEST_EVERY: u32 = 8;
/// `h |λ|` beyond which DOPRI5's step is taken to be held by its stability region. The
/// region reaches about −3.3 on the negative real axis (the code DOPRI5, which only warns,
/// tests against 3.25), but the test's estimate `‖k₇ − k₆‖ / ‖y₇ − y₆‖` is a quotient along
/// one direction, at most the spectral radius: where several modes mix, it sits below it.
/// On a stability-held stretch the step controller cycles (the step grows until the error
/// of the unstable mode rejects or shrinks it) and the estimate follows the cycle, e.g.
/// 2.4–3.1 in the flight of run 70 of the user-robot sweep (massive legs, stiff servos):
/// against 3.25 it is positive on too few tests in a row, and DOPRI5 keeps its 45 µs steps.
/// Steps set by accuracy at the engine's tolerances (a 5th-order method at `rtol = 5·10⁻⁹`)
/// keep the estimate below 0.5 on 92 % of run 70's tests and below 1.0 on 97 %, so 2.0
/// tells the two apart with a margin on both sides; RODAS4 hands back where its own step would be stable
/// explicitly ([`EXPLICIT_HLAMBDA`]). The RHex leaps run with the switch off.
const STIFF_HLAMBDA: f64 = 2.0;
/// RODAS4 hands back to DOPRI5 where its next step times the Jacobian's spectral radius is
/// below this: an explicit step of that size is stable with a margin.
const EXPLICIT_HLAMBDA: f64 = 2.5;
/// The spectral radius is estimated on every this many RODAS4 steps since the switch or the
/// last restart.
const EXPLICIT_CHECK_EVERY: u32 = 5;
/// The most times the stiffness test's count of positives is doubled (up to `16 × 15` tests
/// in a row): the **switch backoff**. A switch to RODAS4 pays where RODAS4's accuracy allows
/// steps longer than DOPRI5's stability did (LSODA switches only where the other method's
/// step is the longer). Where DOPRI5's step is held near where its stability and its
/// accuracy bind alike (`h |λ|` estimates of 2–3), the stiffness test fires, RODAS4 takes
/// steps no longer than DOPRI5's (its error estimate is of order 3), and hands back at its
/// first check: a cycle of about 20 explicit and 5 implicit steps, 30 times in the stance of
/// run 178 of the user-robot sweep. A stretch of RODAS4 whose mean step was no longer than
/// the last explicit step before it doubles the positives the next switch needs; a stretch
/// that paid sets them back to [`STIFF_POSITIVES`].
const MAX_BACKOFF: u32 = 4;

/// The state of DOPRI5's stiffness test (Hairer, Nørsett & Wanner, *Solving ODEs I*, IV.2 and
/// the code DOPRI5): on an accepted step, `h λ ≈ h ‖k₇ − k₆‖ / ‖y₇ − y₆‖` (the last two stages
/// are at `t + h` from two nearby states, so their difference quotient estimates the dominant
/// eigenvalue along the flow) beyond [`STIFF_HLAMBDA`] on [`STIFF_POSITIVES`] tests in a row
/// switches to RODAS4.
#[derive(Debug, Clone, Copy, Default)]
struct StiffnessTest {
    positives: u32,
    negatives: u32,
    since_test: u32,
}

/// An integrator for `ẏ = f(t, y)`: DOPRI5, switching to the L-stable RODAS4
/// ([`crate::rosenbrock`]) on stiff stretches and back (LSODA-style automatic stiffness
/// switching; [`StepOptions::stiff_switch`]). The right-hand side is passed to every
/// [`Self::step`] (not stored), so that its owner can use the same workspace between steps,
/// e.g. to evaluate guards where the last stage left its results.
///
/// The switch: DOPRI5's stiffness test ([`StiffnessTest`]) finds its steps held by the
/// stability region; RODAS4 then takes the steps its accuracy allows (a Jacobian by
/// differences each step, `n + 1` evaluations), and every few steps compares its step with
/// the largest stable explicit one (`EXPLICIT_HLAMBDA / ρ(J)`): smaller, DOPRI5 takes over
/// again. The choice is kept over restarts (a new segment usually has the same stiff link).
/// Both methods keep the contract of [`Self::step`]: the last evaluation of an accepted step
/// is at its end point, and the dense output has one format ([`DenseStep::implicit`] tells
/// them apart).
pub struct Dopri5 {
    pub opts: StepOptions,
    k: [Vec<f64>; 7],
    ytmp: Vec<f64>,
    ynew: Vec<f64>,
    /// Each component's squared scaled error of the trial step ([`Self::error_norm`]).
    err_terms: Vec<f64>,
    h: f64,
    fsal_valid: bool,
    /// Weight of each component in the error norm (1: counted, 0: ignored).
    weights: Vec<f64>,
    /// `Σ weights` (at least 1).
    counted: f64,
    /// Each component's factor on `opts.atol` (1 unless set: [`Self::set_atol_scales`]).
    atol_scales: Vec<f64>,
    /// Largest step the components left out of the error norm stay stable at (s).
    h_stable: f64,
    /// Size and error norm (at least 1e-2) of the last accepted step since the last reset.
    last_accepted: Option<(f64, f64)>,
    /// Size of the last trial step (0 before the first trial of a step: a failure of the
    /// right-hand side at the step's start, which no smaller step avoids).
    trial_h: f64,
    stiffness: StiffnessTest,
    /// RODAS4's buffers (allocated on the run's first stiff stretch) and whether it takes
    /// the steps now.
    rodas: Option<Box<Rodas4>>,
    implicit: bool,
    /// RODAS4 steps since the switch or the last restart.
    implicit_steps: u32,
    /// The last explicit step before the switch to RODAS4 (s), and the sum and count of
    /// RODAS4's accepted steps since: whether the stretch paid ([`MAX_BACKOFF`]).
    switch_h: f64,
    stretch: (f64, u32),
    /// How many times [`STIFF_POSITIVES`] the stiffness test needs, as a power of 2.
    backoff: u32,
}

impl Dopri5 {
    pub fn new(n: usize, opts: StepOptions) -> Self {
        Dopri5 {
            opts,
            k: std::array::from_fn(|_| vec![0.0; n]),
            ytmp: vec![0.0; n],
            ynew: vec![0.0; n],
            err_terms: vec![0.0; n],
            h: opts.h_initial_s,
            fsal_valid: false,
            weights: vec![1.0; n],
            counted: n.max(1) as f64,
            atol_scales: vec![1.0; n],
            h_stable: f64::INFINITY,
            last_accepted: None,
            trial_h: 0.0,
            stiffness: StiffnessTest::default(),
            rodas: None,
            implicit: false,
            implicit_steps: 0,
            switch_h: 0.0,
            stretch: (0.0, 0),
            backoff: 0,
        }
    }

    /// Whether the next step is RODAS4's ([`Self`]).
    pub fn is_implicit(&self) -> bool {
        self.implicit
    }

    /// The size the next step will try (s).
    pub fn next_step_size(&self) -> f64 {
        self.h
    }

    /// Leaves the components whose weight is 0 out of the step-size control (e.g. the
    /// prescribed motion of free massless joints, which feeds back into nothing); 1 counts a
    /// component fully. Wrong length: ignored.
    pub fn set_error_weights(&mut self, weights: &[f64]) {
        if weights.len() == self.weights.len() {
            self.weights.copy_from_slice(weights);
            self.counted = self.weights.iter().sum::<f64>().max(1.0);
        }
    }

    /// Each component's absolute tolerance as a factor on `opts.atol` (all 1 at first;
    /// e.g. [`VelocityTolerance::scales`]). Wrong length: ignored.
    pub fn set_atol_scales(&mut self, scales: &[f64]) {
        if scales.len() == self.atol_scales.len() {
            self.atol_scales.copy_from_slice(scales);
        }
    }

    /// Caps every step at `h_s` (s; `f64::INFINITY`: no cap): the components out of the error
    /// norm ([`Self::set_error_weights`]) are integrated stably only where `h |λ|` is inside
    /// the method's stability region, which nothing else checks for them.
    pub fn set_stability_cap(&mut self, h_s: f64) {
        self.h_stable = h_s;
    }

    /// After a step failed in its right-hand side at a trial stage (`Err(Rhs)`): the next
    /// step tries `factor` times the failed trial's size, keeping the stored derivative at
    /// the start. `false` (nothing changed) when the failure was at the start itself or the
    /// smaller step would fall below `h_min`.
    pub fn retry_smaller(&mut self, factor: f64) -> bool {
        let h = self.trial_h * factor;
        if self.trial_h == 0.0 || h < self.opts.h_min_s {
            return false;
        }
        self.h = h;
        true
    }

    /// Forgets the stored derivative (call after the state jumps); the next step tries
    /// `h_s`.
    pub fn reset(&mut self, h_s: f64) {
        self.fsal_valid = false;
        self.h = h_s;
        self.last_accepted = None;
        self.implicit_steps = 0;
        bump(RESTARTS);
    }

    /// One accepted step of `ẏ = f(t, y)` from `(t, y)` not past `t_end`; advances `y` and
    /// returns the dense output. The last call of `f` in an accepted step is at its end point,
    /// `(t + h, y_new)` exactly (FSAL). `Err(Rhs(e))` if the right-hand side failed,
    /// `Err(StepTooSmall(h))` if the step size fell below `h_min`. Kept out of line: inlined
    /// into the segment loop (as one change of unrelated code made the compiler do) it cost
    /// the default leap +0.7 % instructions. `f` is any [`Rhs`] closure, or a system that
    /// gives its Jacobian ([`OdeSystem`]) to the linearly implicit steps.
    #[inline(never)]
    pub fn step<E, S: OdeSystem<E> + ?Sized>(
        &mut self,
        f: &mut S,
        t: f64,
        y: &mut [f64],
        t_end: f64,
        dense: &mut DenseStep,
    ) -> Result<(), StepError<E>> {
        let n = y.len();
        self.trial_h = 0.0;
        if !self.fsal_valid {
            f.rhs(t, y, &mut self.k[0]).map_err(StepError::Rhs)?;
            self.fsal_valid = true;
        }
        if self.implicit {
            if let Some(r) = self.step_implicit(f, t, y, t_end, dense) {
                return r;
            }
            // back to DOPRI5 (stable at RODAS4's step size, or no Jacobian here); a stretch
            // whose steps were no longer than DOPRI5's before it did not pay (MAX_BACKOFF)
            let (sum, count) = self.stretch;
            if count > 0 {
                self.backoff = if sum <= self.switch_h * f64::from(count) {
                    (self.backoff + 1).min(MAX_BACKOFF)
                } else {
                    0
                };
            }
            self.implicit = false;
            self.last_accepted = None;
            self.stiffness = StiffnessTest::default();
        }
        let mut rejected = false;
        loop {
            let h = self
                .h
                .min(self.opts.h_max_s)
                .min(self.h_stable)
                .min(t_end - t);
            if h < self.opts.h_min_s && t_end - t > self.opts.h_min_s {
                return Err(StepError::StepTooSmall(h));
            }
            self.trial_h = h;
            for (s, c) in C.iter().enumerate().skip(1) {
                stage_point(s, &self.k, y, h, &mut self.ytmp);
                f.rhs(t + c * h, &self.ytmp, &mut self.k[s])
                    .map_err(StepError::Rhs)?;
            }
            // the 7th stage point is y_{n+1} (FSAL)
            self.ynew.copy_from_slice(&self.ytmp);
            let err = self.error_norm(y, h);
            if err <= 1.0 || h <= self.opts.h_min_s {
                dense.t0 = t;
                dense.h = h;
                dense.implicit = false;
                dense.r.resize(5 * n, 0.0);
                self.dense_coefficients(y, h, &mut dense.r);
                if self.opts.stiff_switch {
                    self.stiffness_test(h);
                }
                y.copy_from_slice(&self.ynew);
                let (first, rest) = self.k.split_at_mut(1);
                first[0].copy_from_slice(&rest[5]);
                // the error estimate is of order 4: exponent 1/5
                let fac = next_step_factor((h, err), self.last_accepted, rejected, (0.2, 5.0));
                self.last_accepted = Some((h, err.max(1e-2)));
                self.h = h * fac;
                bump(ACCEPTED);
                return Ok(());
            }
            rejected = true;
            bump(REJECTED);
            self.h = h * (0.9 * err.powf(-0.2)).clamp(0.2, 1.0);
        }
    }

    /// DOPRI5's stiffness test on the accepted step of size `h` (before `k₇` becomes the next
    /// step's `k₁`): `h ‖k₇ − k₆‖ / ‖y₇ − y₆‖` over the components the error norm counts,
    /// `y₇ − y₆ = h Σ_j (a₇ⱼ − a₆ⱼ) k_j`. Switches to RODAS4 on the last of
    /// [`STIFF_POSITIVES`] positive tests in a row.
    fn stiffness_test(&mut self, h: f64) {
        let st = &mut self.stiffness;
        st.since_test += 1;
        if st.positives == 0 && st.since_test < STIFF_TEST_EVERY {
            return;
        }
        st.since_test = 0;
        let (mut num, mut den) = (0.0, 0.0);
        for (i, &w) in self.weights.iter().enumerate() {
            if w == 0.0 {
                continue;
            }
            let dk = self.k[6][i] - self.k[5][i];
            let dy: f64 = h
                * (0..6)
                    .map(|j| (A[6][j] - A[5][j]) * self.k[j][i])
                    .sum::<f64>();
            num += dk * dk;
            den += dy * dy;
        }
        if den > 0.0 && h * (num / den).sqrt() > STIFF_HLAMBDA {
            st.negatives = 0;
            st.positives += 1;
            if st.positives >= STIFF_POSITIVES << self.backoff {
                *st = StiffnessTest::default();
                self.implicit = true;
                self.implicit_steps = 0;
                self.switch_h = h;
                self.stretch = (0.0, 0);
                self.last_accepted = None;
                bump(SWITCHES);
            }
        } else {
            st.negatives += 1;
            if st.negatives >= STIFF_NEGATIVES {
                st.positives = 0;
            }
        }
    }

    /// One accepted RODAS4 step ([`Self::step`]'s contract), or `None` where DOPRI5 takes
    /// this step instead: an explicit step of RODAS4's size would be stable, or the Jacobian
    /// cannot be formed here. `k[0]` holds `f(t, y)` on entry and `f(t + h, y₁)` on return.
    fn step_implicit<E, S: OdeSystem<E> + ?Sized>(
        &mut self,
        f: &mut S,
        t: f64,
        y: &mut [f64],
        t_end: f64,
        dense: &mut DenseStep,
    ) -> Option<Result<(), StepError<E>>> {
        let n = y.len();
        let ros = self.rodas.get_or_insert_with(|| Box::new(Rodas4::new(n)));
        ros.jacobian(f, t, y, &self.k[0]).ok()?;
        // (not on a restart's first step: its size is the last segment's, not RODAS4's)
        if self.implicit_steps > 0
            && self.implicit_steps.is_multiple_of(EXPLICIT_CHECK_EVERY)
            && ros.spectral_radius() * self.h.min(self.opts.h_max_s) < EXPLICIT_HLAMBDA
        {
            return None;
        }
        let mut rejected = false;
        loop {
            let h = self.h.min(self.opts.h_max_s).min(t_end - t);
            if h < self.opts.h_min_s && t_end - t > self.opts.h_min_s {
                return Some(Err(StepError::StepTooSmall(h)));
            }
            self.trial_h = h;
            dense.r.resize(5 * n, 0.0);
            match ros.trial(f, t, y, &self.k[0], h, &mut self.ynew, &mut dense.r) {
                Err(Some(e)) => return Some(Err(StepError::Rhs(e))),
                Err(None) => {
                    // W = I/(hγ) − J singular at this h: another h is not
                    rejected = true;
                    bump(REJECTED);
                    self.h = h * 0.5;
                    continue;
                }
                Ok(()) => {}
            }
            let err = scaled_rms(
                ros.error(),
                y,
                &self.ynew,
                (&self.weights, self.counted),
                (self.opts.atol, &self.atol_scales, self.opts.rtol),
            );
            if err <= 1.0 || h <= self.opts.h_min_s {
                // the end point's derivative: the next step's first, and the last
                // evaluation of this one at its end point
                let (first, rest) = self.k.split_at_mut(1);
                if let Err(e) = f.rhs(t + h, &self.ynew, &mut rest[0]) {
                    return Some(Err(StepError::Rhs(e)));
                }
                first[0].copy_from_slice(&rest[0]);
                dense.t0 = t;
                dense.h = h;
                dense.implicit = true;
                y.copy_from_slice(&self.ynew);
                // the embedded solution is of order 3: exponent 1/4, growth up to 6 (RODAS)
                let fac = next_step_factor((h, err), self.last_accepted, rejected, (0.25, 6.0));
                self.last_accepted = Some((h, err.max(1e-2)));
                self.h = h * fac;
                self.implicit_steps += 1;
                self.stretch = (self.stretch.0 + h, self.stretch.1 + 1);
                bump(ACCEPTED);
                bump(IMPLICIT);
                return Some(Ok(()));
            }
            rejected = true;
            bump(REJECTED);
            self.h = if err.is_finite() {
                h * (0.9 * err.powf(-0.25)).clamp(0.2, 1.0)
            } else {
                h * 0.2
            };
        }
    }

    /// The weighted RMS norm of the error estimate `h Σ_s (b_s − b̂_s) k_s` of the trial step
    /// of size `h` from `y` (to `ynew`), scaled by `atolᵢ + rtol max(|y|, |y_new|)`
    /// (`atolᵢ = atol ·` the component's factor, [`Self::set_atol_scales`]).
    /// Each component's term first (one loop the compiler vectorizes), then their weighted
    /// sum in component order, over the components the norm counts.
    fn error_norm(&mut self, y: &[f64], h: f64) -> f64 {
        let n = y.len();
        let k: [&[f64]; 7] = std::array::from_fn(|j| &self.k[j][..n]);
        let (atol, rtol) = (self.opts.atol, self.opts.rtol);
        let (ynew, terms) = (&self.ynew[..n], &mut self.err_terms[..n]);
        let scales = &self.atol_scales[..n];
        for i in 0..n {
            let e: f64 = h * (0..7).map(|j| E[j] * k[j][i]).sum::<f64>();
            let sc = atol * scales[i] + rtol * y[i].abs().max(ynew[i].abs());
            terms[i] = (e / sc).powi(2);
        }
        let mut err = 0.0;
        for (&w, &term) in self.weights.iter().zip(terms.iter()) {
            if w != 0.0 {
                err += w * term;
            }
        }
        (err / self.counted).sqrt()
    }

    /// The coefficients `r₀ … r₄` of the accepted step of size `h` from `y` (to `ynew`), one
    /// after the other in `r` (`5 n` numbers).
    fn dense_coefficients(&self, y: &[f64], h: f64, r: &mut [f64]) {
        let n = y.len();
        let k: [&[f64]; 7] = std::array::from_fn(|j| &self.k[j][..n]);
        let ynew = &self.ynew[..n];
        let (r0, rest) = r.split_at_mut(n);
        let (r1, rest) = rest.split_at_mut(n);
        let (r2, rest) = rest.split_at_mut(n);
        let (r3, r4) = rest.split_at_mut(n);
        let r4 = &mut r4[..n];
        for i in 0..n {
            let dy = ynew[i] - y[i];
            let bspl = h * k[0][i] - dy;
            r0[i] = y[i];
            r1[i] = dy;
            r2[i] = bspl;
            r3[i] = dy - h * k[6][i] - bspl;
            r4[i] = h * (0..7).map(|j| D[j] * k[j][i]).sum::<f64>();
        }
    }
}

/// The factor from an accepted step of size `h` and error norm `err` to the next step's
/// size, for an error estimate of order `1/expo − 1`: `0.9 err^(−expo)` in `[0.2, fac_max]`,
/// no larger than Gustafsson's predictive controller (Hairer & Wanner, *Solving ODEs II*,
/// IV.8, as in RADAU5 and RODAS), which extrapolates the change of the error between the
/// last two accepted steps (`last_accepted`: size and error norm of the one before):
/// `0.9 (h / h_acc) (err_acc / err²)^expo` — where the error grows from step to step (a flow
/// speeding up towards a liftoff), the plain controller settles at `err ≈ 1` and rejects
/// every other step — and no growth right after a rejection (DOPRI5).
#[inline]
fn next_step_factor(
    (h, err): (f64, f64),
    last_accepted: Option<(f64, f64)>,
    rejected: bool,
    (expo, fac_max): (f64, f64),
) -> f64 {
    let mut fac = if err == 0.0 {
        fac_max
    } else {
        (0.9 * err.powf(-expo)).clamp(0.2, fac_max)
    };
    if let (Some((h_acc, err_acc)), true) = (last_accepted, err > 0.0) {
        let predicted = (h / h_acc) * 0.9 * (err_acc / (err * err)).powf(expo);
        fac = fac.min(predicted.clamp(0.2, fac_max));
    }
    if rejected {
        fac = fac.min(1.0);
    }
    fac
}

/// The point of stage `s` (1 … 6) of a step of size `h` from `y`: `out = y + h Σ_{j<s} a_sj k_j`,
/// each component's sum taken in the order of the tableau, from 0.
fn stage_point(s: usize, k: &[Vec<f64>; 7], y: &[f64], h: f64, out: &mut [f64]) {
    match s {
        1 => stage_sum::<1>(&A[1], k, y, h, out),
        2 => stage_sum::<2>(&A[2], k, y, h, out),
        3 => stage_sum::<3>(&A[3], k, y, h, out),
        4 => stage_sum::<4>(&A[4], k, y, h, out),
        5 => stage_sum::<5>(&A[5], k, y, h, out),
        _ => stage_sum::<6>(&A[6], k, y, h, out),
    }
}

/// The weighted RMS norm of an error estimate `e` of a step from `y` to `y_new`, each
/// component scaled by `atol · scaleᵢ + rtol max(|y|, |y_new|)`, over the components of
/// non-zero weight (`Σ weights = counted`).
fn scaled_rms(
    e: &[f64],
    y: &[f64],
    ynew: &[f64],
    (weights, counted): (&[f64], f64),
    (atol, scales, rtol): (f64, &[f64], f64),
) -> f64 {
    let mut err = 0.0;
    for i in 0..e.len() {
        if weights[i] != 0.0 {
            let sc = atol * scales[i] + rtol * y[i].abs().max(ynew[i].abs());
            err += weights[i] * (e[i] / sc).powi(2);
        }
    }
    (err / counted).sqrt()
}

/// [`stage_point`] for `S` stages known at compile time: one loop over the components on
/// slices of the state's length, which the compiler vectorizes (a component's operations,
/// and so its result, are those of the plain sum).
#[inline(always)]
fn stage_sum<const S: usize>(a: &[f64; 6], k: &[Vec<f64>; 7], y: &[f64], h: f64, out: &mut [f64]) {
    let n = out.len();
    let y = &y[..n];
    let k: [&[f64]; S] = std::array::from_fn(|j| &k[j][..n]);
    for i in 0..n {
        let mut acc = 0.0;
        for j in 0..S {
            acc += a[j] * k[j][i];
        }
        out[i] = y[i] + h * acc;
    }
}

/// Counters of the integration's work on the calling thread, split by phase: index 0 for a
/// contact mode with at least one active contact (stance), 1 for a mode with none (flight),
/// by the mode of the last flow evaluation ([`crate::flow::Flow::rhs`]). A diagnostic for
/// profiling (what a run's cost is made of); nothing in the engine reads them, so they
/// change no result. Read and cleared with [`work_counters`] and [`reset_work_counters`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WorkCounters {
    /// Accepted steps.
    pub accepted: [u64; 2],
    /// Trial steps rejected by the error test.
    pub rejected: [u64; 2],
    /// Restarts of the integrator (its stored derivative forgotten: a new segment, a
    /// projection, a time event).
    pub restarts: [u64; 2],
    /// Calls of the flow's right-hand side.
    pub rhs_calls: [u64; 2],
    /// Solves of the dynamics by the flow, for the right-hand side or anyone else (the
    /// guards, the set-up of a segment); an evaluation the flow's cache held is not one.
    pub solves: [u64; 2],
    /// Accepted steps of RODAS4 (among `accepted`; [`Dopri5`]).
    pub implicit: [u64; 2],
    /// Switches from DOPRI5 to RODAS4 by the stiffness test.
    pub switches: [u64; 2],
}

impl WorkCounters {
    /// `self − earlier`, component by component (the work between two readings).
    pub fn since(&self, earlier: &WorkCounters) -> WorkCounters {
        let d = |a: [u64; 2], b: [u64; 2]| [a[0] - b[0], a[1] - b[1]];
        WorkCounters {
            accepted: d(self.accepted, earlier.accepted),
            rejected: d(self.rejected, earlier.rejected),
            restarts: d(self.restarts, earlier.restarts),
            rhs_calls: d(self.rhs_calls, earlier.rhs_calls),
            solves: d(self.solves, earlier.solves),
            implicit: d(self.implicit, earlier.implicit),
            switches: d(self.switches, earlier.switches),
        }
    }
}

/// The counters' slots: each counter's two phases are `2 k` and `2 k + 1`.
const ACCEPTED: usize = 0;
const REJECTED: usize = 2;
const RESTARTS: usize = 4;
const RHS_CALLS: usize = 6;
const SOLVES: usize = 8;
const IMPLICIT: usize = 10;
const SWITCHES: usize = 12;

/// The counters of one thread: one cell per counter and phase, and the phase of the last
/// flow evaluation (0 stance, 1 flight). One thread-local access and one cell's increment per
/// count: the counters must cost nothing measurable in a leap.
struct WorkCells {
    counts: [std::cell::Cell<u64>; 14],
    phase: std::cell::Cell<usize>,
}

thread_local! {
    static WORK: WorkCells = const {
        WorkCells {
            counts: [const { std::cell::Cell::new(0) }; 14],
            phase: std::cell::Cell::new(0),
        }
    };
}

/// The work counters of this thread so far.
pub fn work_counters() -> WorkCounters {
    WORK.with(|w| {
        let pair = |k: usize| [w.counts[k].get(), w.counts[k + 1].get()];
        WorkCounters {
            accepted: pair(ACCEPTED),
            rejected: pair(REJECTED),
            restarts: pair(RESTARTS),
            rhs_calls: pair(RHS_CALLS),
            solves: pair(SOLVES),
            implicit: pair(IMPLICIT),
            switches: pair(SWITCHES),
        }
    })
}

/// Sets this thread's work counters to zero.
pub fn reset_work_counters() {
    WORK.with(|w| w.counts.iter().for_each(|c| c.set(0)));
}

/// Counts one call of the flow's right-hand side in a mode with (`flight == false`) or
/// without active contacts, and makes that the phase of the integrator's counts.
#[inline]
pub(crate) fn count_rhs(flight: bool) {
    let p = usize::from(flight);
    WORK.with(|w| {
        w.phase.set(p);
        let c = &w.counts[RHS_CALLS + p];
        c.set(c.get() + 1);
    });
}

/// Counts one solve of the dynamics by the flow (any caller: the integrator's stages, the
/// guards, the segment's set-up) in a mode with or without active contacts.
#[inline]
pub(crate) fn count_solve(flight: bool) {
    WORK.with(|w| {
        let c = &w.counts[SOLVES + usize::from(flight)];
        c.set(c.get() + 1);
    });
}

/// Adds one to `counter` in the phase of the last flow evaluation.
#[inline]
fn bump(counter: usize) {
    WORK.with(|w| {
        let c = &w.counts[counter + w.phase.get()];
        c.set(c.get() + 1);
    });
}

/// Why a step failed.
#[derive(Debug)]
pub enum StepError<E> {
    Rhs(E),
    StepTooSmall(f64),
}
