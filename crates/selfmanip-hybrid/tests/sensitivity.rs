//! Saltation matrices and whole-execution sensitivities ([`selfmanip_hybrid::sensitivity`])
//! against independent routes: closed forms derived here for a plastic ball, a rod landing on
//! one end and the rocking block with and without the pseudo-impulse, and central finite
//! differences of whole executions through several events.
//!
//! Notation: state `x = (x, z, φ, ẋ, ż, φ̇)` of a rigid body (mass `m`, centroidal inertia `I`),
//! z down, `g` gravity; `Ξ = D_xR + (f⁺ − D_xR f⁻) D_xg / (D_xg f⁻)`.
//!
//! **Pinned motion (used by the rod and the block).** A body pinned at a ground point `p`,
//! with `r = X − p` (world), moves along `v = (r_z, −r_x, 1)` (the velocity per unit `φ̇`,
//! since `Ẋ = φ̇ S r`, `S r = (r_z, −r_x)`). A plastic impact that pins it keeps the angular
//! momentum about `p` (the impulse acts at `p`): with `I_p = I + m|r|²`,
//! `φ̇⁺ = (m r_z ẋ⁻ − m r_x ż⁻ + I φ̇⁻) / I_p = wᵀq̇⁻ / I_p`, `q̇⁺ = v φ̇⁺`. Hence
//! `∂q̇⁺/∂q̇⁻ = v wᵀ / I_p`, and since `r` turns with `φ` only (`∂r/∂φ = S r`, so
//! `v' = ∂v/∂φ = (−r_x, −r_z, 0)` and `∂(wᵀq̇)/∂φ = m(−r_x ẋ − r_z ż)`, `|r|` constant):
//! `∂q̇⁺/∂φ = v' φ̇⁺ + v m(−r_x ẋ⁻ − r_z ż⁻)/I_p`, `∂q̇⁺/∂(x, z) = 0`. Its flow: gravity
//! `(0, m g)` at offset `r` has the moment `−r_x m g`, so `φ̈ = −r_x m g / I_p` and
//! `q̈ = φ̈ v + φ̇² v'`. The height of a body point `c` (offset `l = c − X`) is `−c_z`, with
//! gradient `(0, −1, −(S l)_z) = (0, −1, l_x)` over `q`.
mod systems;
use nalgebra::{DMatrix, DVector};
use selfmanip_core::{ContactKind, ContactMode, FlatGround, Model};
use selfmanip_hybrid::sensitivity::{simulate_with_sensitivity, SaltationStatus, Sensitivity};
use selfmanip_hybrid::{
    simulate, ConstantTorque, Controller, EventKind, Execution, HybridOptions, ZeroTorque,
};
use systems::{block, block_inertia, body, rotate, Friction, Servos, BLOCK, G};

/// Tight tolerances, so that finite differences of whole executions resolve 1e-6
/// ([`systems::tight`] with the pseudo-impulse's `delta_t_s` and the free joints out of the
/// step-size control).
fn tight(delta_t_s: f64) -> HybridOptions {
    HybridOptions {
        delta_t_s,
        control_free_joints: false,
        ..systems::tight()
    }
}

/// One run of the tests: a model under `ctrl` on flat ground from `y0 = (q, q̇)` in `mode`
/// until `tf`.
#[derive(Clone, Copy)]
struct Case<'a> {
    model: &'a Model,
    ctrl: &'a dyn Controller,
    mode: ContactMode,
    y0: &'a [f64],
    tf: f64,
    opts: HybridOptions,
}

/// No actuation, for cases that outlive the call that makes them.
static NO_TORQUE: ConstantTorque = ZeroTorque;

/// An event's kind and the mode after it.
type Step = (EventKind, ContactMode);

impl<'a> Case<'a> {
    /// A passive body (no joint torque) from `y0` in flight.
    fn passive(model: &'a Model, y0: &'a [f64], tf: f64, opts: HybridOptions) -> Self {
        Case {
            model,
            ctrl: &NO_TORQUE,
            mode: ContactMode::FLIGHT,
            y0,
            tf,
            opts,
        }
    }

    /// The execution and its sensitivities.
    fn sensitivity(&self) -> (Execution, Sensitivity) {
        let nq = self.model.nq();
        simulate_with_sensitivity(
            self.model,
            &FlatGround,
            self.ctrl,
            self.mode,
            &self.y0[..nq],
            &self.y0[nq..],
            self.tf,
            self.opts,
        )
        .unwrap()
    }

    /// `x(t_f)` and the event sequence of the run from `y0`.
    fn run_from(&self, y0: &[f64]) -> (Vec<f64>, Vec<Step>) {
        let nq = self.model.nq();
        let e = simulate(
            self.model,
            &FlatGround,
            self.ctrl,
            self.mode,
            &y0[..nq],
            &y0[nq..],
            self.tf,
            self.opts,
        )
        .unwrap();
        (final_state(&e), sequence(&e))
    }

    /// Central differences of `x(t_f)` along each direction `dirs[k]` of the initial state
    /// (step `h` along the direction), each with the unperturbed run's event sequence.
    fn fd_columns(&self, dirs: &[DVector<f64>], h: f64) -> DMatrix<f64> {
        let (_, seq) = self.run_from(self.y0);
        let n2 = self.y0.len();
        let mut out = DMatrix::zeros(n2, dirs.len());
        for (k, d) in dirs.iter().enumerate() {
            let shifted = |s: f64| -> Vec<f64> {
                self.y0
                    .iter()
                    .zip(d.iter())
                    .map(|(a, b)| a + s * h * b)
                    .collect()
            };
            let (xp, sp) = self.run_from(&shifted(1.0));
            let (xm, sm) = self.run_from(&shifted(-1.0));
            assert_eq!(sp, seq, "the mode sequence changed along direction {k}");
            assert_eq!(sm, seq, "the mode sequence changed along direction {k}");
            for i in 0..n2 {
                out[(i, k)] = (xp[i] - xm[i]) / (2.0 * h);
            }
        }
        out
    }

    /// The worst relative error of the whole-run Jacobian `jac` applied to `dirs` against
    /// central differences of whole executions (h = 1e-6) along them.
    fn whole_run_error(&self, jac: &DMatrix<f64>, dirs: &[DVector<f64>]) -> f64 {
        let fd = self.fd_columns(dirs, 1e-6);
        let ex = DMatrix::from_columns(&dirs.iter().map(|d| jac * d).collect::<Vec<_>>());
        rel(&ex, &fd)
    }

    /// [`Self::whole_run_error`] is below `tol` (`what` names the case in the messages).
    fn assert_whole_run_close(
        &self,
        jac: &DMatrix<f64>,
        dirs: &[DVector<f64>],
        tol: f64,
        what: &str,
    ) {
        let e = self.whole_run_error(jac, dirs);
        eprintln!("{what}: whole-run Jacobian vs central differences {e:e}");
        assert!(e < tol, "{what}: {e:e}");
    }
}

fn final_state(e: &Execution) -> Vec<f64> {
    e.q.iter().chain(&e.qd).copied().collect()
}

fn sequence(e: &Execution) -> Vec<Step> {
    e.events.iter().map(|e| (e.kind, e.mode_after)).collect()
}

fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).amax() / b.amax().max(1.0)
}

/// The saltation matrix of the first event of `sens` is `expected` (a closed form) to `tol`
/// relative ([`rel`]).
fn assert_first_saltation(sens: &Sensitivity, expected: &DMatrix<f64>, tol: f64, what: &str) {
    let xi = sens.events[0].saltation.as_ref().expect("defined");
    let e = rel(xi, expected);
    eprintln!("{what}: saltation vs closed form {e:e}");
    assert!(e < tol, "{what}: {xi} vs {expected}");
}

/// Every direction of an `n`-dimensional state.
fn units(n: usize) -> Vec<DVector<f64>> {
    (0..n).map(|k| unit(n, k)).collect()
}

fn unit(n: usize, k: usize) -> DVector<f64> {
    DVector::from_fn(n, |i, _| if i == k { 1.0 } else { 0.0 })
}

/// The pinned-motion quantities of the module docs for `r = X − p`.
struct Pinned {
    v: [f64; 3],
    vp: [f64; 3],
    w: [f64; 3],
    ip: f64,
    r: [f64; 2],
    m: f64,
}

impl Pinned {
    fn new(m: f64, inertia: f64, r: [f64; 2]) -> Self {
        Pinned {
            v: [r[1], -r[0], 1.0],
            vp: [-r[0], -r[1], 0.0],
            w: [m * r[1], -m * r[0], inertia],
            ip: inertia + m * (r[0] * r[0] + r[1] * r[1]),
            r,
            m,
        }
    }
    fn phidot_plus(&self, qd: &[f64]) -> f64 {
        (0..3).map(|i| self.w[i] * qd[i]).sum::<f64>() / self.ip
    }
    /// The flow `(q̇, q̈)` pinned at angular speed `phidot`.
    fn flow(&self, phidot: f64) -> DVector<f64> {
        let phidd = -self.r[0] * self.m * G / self.ip;
        let mut f = DVector::zeros(6);
        for i in 0..3 {
            f[i] = self.v[i] * phidot;
            f[3 + i] = phidd * self.v[i] + phidot * phidot * self.vp[i];
        }
        f
    }
    /// `D_xR` of the plastic impact that pins the body.
    fn reset_jacobian(&self, qd: &[f64]) -> DMatrix<f64> {
        let mut d = DMatrix::identity(6, 6);
        let pp = self.phidot_plus(qd);
        let dphi = self.m * (-self.r[0] * qd[0] - self.r[1] * qd[1]) / self.ip;
        for i in 0..3 {
            d[(3 + i, 2)] = self.vp[i] * pp + self.v[i] * dphi;
            for j in 0..3 {
                d[(3 + i, 3 + j)] = self.v[i] * self.w[j] / self.ip;
            }
        }
        d
    }
}

/// `D_xg` of the height of the body point at world offset `l` from the centre.
fn height_gradient(l: [f64; 2]) -> DMatrix<f64> {
    DMatrix::from_row_slice(1, 6, &[0.0, -1.0, l[0], 0.0, 0.0, 0.0])
}

fn saltation(
    dr: &DMatrix<f64>,
    fm: &DVector<f64>,
    fp: &DVector<f64>,
    dg: &DMatrix<f64>,
) -> DMatrix<f64> {
    let den = (dg * fm)[0];
    dr + (fp - dr * fm) * dg / den
}

/// A plastic ball (a body whose sticking contact is its centre) thrown down from height `h0`
/// with `ẋ⁻`: `g = −z`, `D_xg = (0, −1, 0, 0, 0, 0)`, `f⁻ = (ẋ, ż, φ̇, 0, g, 0)`,
/// `R` zeroes `ẋ, ż` (`D_xR = diag(1, 1, 1, 0, 0, 1)`), `f⁺ = (0, 0, φ̇, 0, 0, 0)`, so
/// `f⁺ − D_xR f⁻ = (−ẋ, −ż, 0, 0, 0, 0)`, `D_xg f⁻ = −ż` and
/// `Ξ = diag(1, 0, 1, 0, 0, 1)` with `Ξ_xz = −ẋ⁻/ż⁻`, `ż⁻ = √(ż₀² + 2 g h0)`: a later landing lands
/// further on, and nothing else survives the impact. Then the whole run against central
/// differences in all six directions.
#[test]
fn plastic_ball_saltation_and_run() {
    let model = body(1.0, 0.01, G, &[("c", 0.0, 0.0, Friction::Stick(None))]);
    // thrown downward (ż₀ > 0, z down), not dropped from rest: a run that starts at an apex
    // gains an apex event when its ż₀ is perturbed upward, and finite differences would
    // straddle that change of the event sequence
    let (h0, xd, zd0, phid) = (0.5, 1.0, 0.5, 0.3);
    let y0 = [0.0, -h0, 0.0, xd, zd0, phid];
    let case = Case::passive(&model, &y0, 0.4, tight(0.0));
    let (exec, sens) = case.sensitivity();
    assert_eq!(exec.events.len(), 1);
    assert_eq!(exec.events[0].kind, EventKind::Touchdown);
    let zd = (zd0 * zd0 + 2.0 * G * h0).sqrt();
    let mut expected =
        DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 0.0, 1.0, 0.0, 0.0, 1.0]));
    expected[(0, 1)] = -xd / zd;
    let es = &sens.events[0];
    assert_eq!(es.status, SaltationStatus::Defined);
    let xi = es.saltation.as_ref().unwrap();
    assert!((xi - &expected).amax() < 1e-9, "{xi} vs {expected}");
    // the landing time t = √(2 h0/g) − …: dt/dz0 = −1/ż⁻ (z down: a larger z0 is lower)
    let tg = es.time_gradient.as_ref().unwrap();
    assert!((tg[1] + 1.0 / zd).abs() < 1e-9, "{tg}");
    let fd = case.fd_columns(&units(6), 1e-6);
    let e = rel(sens.state_jacobian.as_ref().unwrap(), &fd);
    eprintln!("ball: whole-run Jacobian vs central differences {e:e}");
    assert!(e < 1e-6, "{e:e}");
}

/// A rod (length `L`, `I = m L²/12`) falling tilted lands on one end, which sticks: the
/// pinned closed forms of the module docs with `r = X − p` at the landing.
#[test]
fn rod_landing_on_one_end_saltation() {
    let (len, m) = (0.4, 1.0);
    let inertia = m * len * len / 12.0;
    let model = body(
        m,
        inertia,
        G,
        &[("end", -len / 2.0, 0.0, Friction::Stick(None))],
    );
    let phi0 = 0.5_f64;
    let l0 = rotate(phi0, [-len / 2.0, 0.0]);
    let y0 = [0.0, -0.05 - l0[1], phi0, 0.3, 0.2, 0.5];
    let (exec, sens) = Case::passive(&model, &y0, 0.15, tight(0.0)).sensitivity();
    assert_eq!(exec.events[0].kind, EventKind::Touchdown);
    let t = exec.events[0].t;
    let mut y = [0.0; 6];
    exec.segments[0].eval(t, &mut y);
    let l = rotate(y[2], [-len / 2.0, 0.0]);
    let pin = Pinned::new(m, inertia, [-l[0], -l[1]]);
    let qd = &y[3..];
    let fm = DVector::from_vec(vec![qd[0], qd[1], qd[2], 0.0, G, 0.0]);
    let fp = pin.flow(pin.phidot_plus(qd));
    let expected = saltation(&pin.reset_jacobian(qd), &fm, &fp, &height_gradient(l));
    assert_first_saltation(&sens, &expected, 1e-9, "rod");
}

/// The rocking block of section 5.1.4, pivoting on its left corner at `ω₀ < 0`, level at
/// the right corner's landing. Without the pseudo-impulse the pivot passes to the right
/// corner (see `stage_reset`): `Ξ` of a pinned impact about `r_R`, with `f⁻` the flow
/// pinned about `r_L`. With δt = 0.03 s the left corner stays (5.40) and the block stops:
/// `q̇⁺ ≡ 0` near the event (the two corners fix all three velocities), so
/// `D_xR = diag(I, 0)`, `f⁺ = 0`, and `Ξ = [[I − q̇⁻ D_qg / (D_qg q̇⁻), 0], [0, 0]]`.
#[test]
fn rocking_block_saltation_with_and_without_pseudo_impulse() {
    let (w, h, m) = BLOCK;
    let inertia = block_inertia(w, h, m);
    let model = block(G);
    let left = ContactMode::FLIGHT.with(0, ContactKind::Stick);
    let (phi0, omega0) = (0.02_f64, -1.0);
    // left corner at the origin
    let l_left = rotate(phi0, [-w / 2.0, h / 2.0]);
    let r0 = [-l_left[0], -l_left[1]];
    let y0 = [r0[0], r0[1], phi0, omega0 * r0[1], -omega0 * r0[0], omega0];
    for delta_t in [0.0, 0.03] {
        let (exec, sens) = Case {
            mode: left,
            ..Case::passive(&model, &y0, 0.05, tight(delta_t))
        }
        .sensitivity();
        let ev = &exec.events[0];
        assert_eq!(ev.kind, EventKind::Touchdown);
        assert_eq!(
            ev.mode_after.contains(0),
            delta_t > 0.0,
            "δt {delta_t}: {:?}",
            ev.mode_after
        );
        let mut y = [0.0; 6];
        exec.segments[0].eval(ev.t, &mut y);
        let qd = &y[3..];
        let ll = rotate(y[2], [-w / 2.0, h / 2.0]);
        let lr = rotate(y[2], [w / 2.0, h / 2.0]);
        let pin_l = Pinned::new(m, inertia, [-ll[0], -ll[1]]);
        let fm = pin_l.flow(qd[2]);
        let dg = height_gradient(lr);
        let expected = if delta_t == 0.0 {
            let pin_r = Pinned::new(m, inertia, [-lr[0], -lr[1]]);
            saltation(
                &pin_r.reset_jacobian(qd),
                &fm,
                &pin_r.flow(pin_r.phidot_plus(qd)),
                &dg,
            )
        } else {
            let mut dr = DMatrix::zeros(6, 6);
            dr.view_mut((0, 0), (3, 3)).fill_with_identity();
            saltation(&dr, &fm, &DVector::zeros(6), &dg)
        };
        assert_first_saltation(
            &sens,
            &expected,
            1e-8,
            &format!("rocking block δt {delta_t}"),
        );
    }
}

/// The block dropped tilted in flight lands on a corner, pivots, and rocks from corner to
/// corner (δt = 0): several touchdowns. The chain `Φ Ξ ⋯ Ξ Φ` against central differences
/// of whole executions in all six directions of the initial state, the event sequence
/// unchanged by each perturbation.
#[test]
fn rocking_block_whole_execution_jacobian_through_several_events() {
    let (w, h, _) = BLOCK;
    let model = block(G);
    let phi0 = 0.15_f64;
    let l_left = rotate(phi0, [-w / 2.0, h / 2.0]);
    let y0 = [0.0, -0.02 - l_left[1], phi0, 0.05, 0.1, -0.5];
    let tf = 0.464;
    let case = Case::passive(&model, &y0, tf, tight(0.0));
    let (exec, sens) = case.sensitivity();
    let kinds: Vec<_> = exec.events.iter().map(|e| e.kind).collect();
    eprintln!(
        "events: {kinds:?} at {:?}, termination {:?}",
        exec.events.iter().map(|e| e.t).collect::<Vec<_>>(),
        exec.termination
    );
    assert!(exec.events.len() >= 6, "{kinds:?}");
    for es in &sens.events {
        assert_eq!(es.status, SaltationStatus::Defined, "{es:?}");
    }
    let fd = case.fd_columns(&units(6), 1e-6);
    let jac = sens.state_jacobian.as_ref().expect("defined");
    let e = rel(jac, &fd);
    eprintln!(
        "rocking block, {} events: whole-run Jacobian vs central differences {e:e}",
        exec.events.len()
    );
    assert!(e < 1e-5, "{e:e}\n{jac}\n{fd}");
    // the default tolerances (rtol 1e-9, events to 1e-10 s), which finite differences resolve
    // only with a larger step (h = 1e-4: truncation ~1e-8, noise ~1e-9/1e-4)
    let case = Case::passive(&model, &y0, tf, HybridOptions::default());
    let (_, sens) = case.sensitivity();
    let fd = case.fd_columns(&units(6), 1e-4);
    let e = rel(sens.state_jacobian.as_ref().expect("defined"), &fd);
    eprintln!("rocking block, default tolerances: whole-run Jacobian vs central differences {e:e}");
    assert!(e < 1e-4, "{e:e}");
}

/// A body with one **massless** leg (singular `M̄`; the leg is a free joint in flight and
/// pinned by its toe in stance, Lemma 5.1) under a hip servo: it falls, lands on its toe,
/// leans over it until the toe slips, and lands on its belly, which releases the toe (three
/// events: a touchdown, a slip, a touchdown whose impact set is larger than the mode after).
/// The whole-run Jacobian (the servo's partials chained through `∂q̈/∂Υ`)
/// against central differences of whole executions in all eight directions.
#[test]
fn massless_leg_with_servo_whole_execution_jacobian() {
    let model = systems::one_leg(0.2, 0.0, G);
    let servo = Servos {
        k: 20.0,
        c: 0.5,
        target: vec![-0.3],
    };
    let y0 = [0.2, 0.0, -0.23, 0.1, -0.5, 0.4, 0.3, 0.2];
    let case = Case {
        ctrl: &servo,
        ..Case::passive(&model, &y0, 1.5, tight(0.0))
    };
    let (exec, sens) = case.sensitivity();
    eprintln!(
        "one massless leg: {:?} at {:?}, {:?}",
        sequence(&exec),
        exec.events.iter().map(|e| e.t).collect::<Vec<_>>(),
        exec.termination
    );
    assert!(!exec.events.is_empty());
    for es in &sens.events {
        assert_eq!(es.status, SaltationStatus::Defined, "{es:?}");
    }
    let jac = sens.state_jacobian.as_ref().expect("defined");
    case.assert_whole_run_close(jac, &units(8), 1e-5, "one massless leg");
}

/// A ball thrown up, stopped at its apex (`ż = 0`, the terminal apex event): `t_a = −ż₀/g`,
/// so `∂t_a/∂ż₀ = −1/g`, and `x(t_a) = x₀ + ẋ₀ t_a`, `z(t_a) = z₀ − ż₀²/(2g)`: `∂x_a/∂ż₀ =
/// −ẋ₀/g`, `∂z_a/∂ż₀ = −ż₀/g`, `∂ż_a/∂· = 0` (the apex projection `I − f D_xg/(D_xg f)`).
#[test]
fn apex_projection_and_time_gradient() {
    let model = body(1.0, 0.01, G, &[("c", 0.0, 0.0, Friction::Stick(None))]);
    let (xd, zd) = (0.7, -2.0);
    let opts = HybridOptions {
        stop_at_apex: true,
        ..tight(0.0)
    };
    let (exec, sens) =
        Case::passive(&model, &[0.0, -1.0, 0.0, xd, zd, 0.0], 2.0, opts).sensitivity();
    assert_eq!(exec.events.last().map(|e| e.kind), Some(EventKind::Apex));
    let es = sens.events.last().unwrap();
    let tg = es.time_gradient.as_ref().unwrap();
    assert!((tg[4] + 1.0 / G).abs() < 1e-12, "{tg}");
    let j = sens.state_jacobian.as_ref().unwrap();
    assert!((j[(0, 4)] + xd / G).abs() < 1e-9, "{j}");
    assert!((j[(1, 4)] + zd / G).abs() < 1e-9, "{j}");
    assert!(j.row(4).amax() < 1e-12, "{j}");
}

/// A body with one massive leg standing on its sliding toe (leg vertical, at rest) kicks
/// with a stiff hip servo: the toe's normal force reaches zero and it lifts off (5.50, `D_xg
/// = −∂λ_n/∂x`), the robot lands on its toe again (touchdown, (5.49)), which sticks until
/// its cone is reached (slip, (5.51): `D_xg = −μ ∂λ_n/∂x − sgn(λ_t) ∂λ_t/∂x`), and its belly
/// lands (touchdown). The initial state is on the manifold of the sliding toe (its height
/// and normal velocity zero); at the leg's vertical and at rest, `x, θ, φ` and any velocity
/// with `ż = 0` are tangent to it (the toe's height is stationary in `θ, φ` there, and its
/// normal velocity is `ż`). A velocity that starts the toe sliding ends in a stick event
/// instead (the run starts on that guard: another mode sequence), so the velocity directions
/// keep the sliding velocity `ẋ + β̇ L` zero: `(ẋ, θ̇) = (1, −s/L)`, `(φ̇, θ̇) = (1, −s)`.
#[test]
fn kicking_leg_liftoff_touchdown_slip_whole_execution_jacobian() {
    use EventKind::{Liftoff, Slip, Touchdown};
    let events = [Liftoff, Touchdown, Slip, Touchdown];
    // the toe's sliding velocity is ẋ + β̇ L (β = φ + s θ): velocity directions that keep it
    // zero, since a sliding velocity off zero would end in a stick event (another sequence)
    let dirs = |model: &Model| {
        let sgn = model.joints[0].axis_sign;
        vec![
            unit(8, 0),
            unit(8, 1),
            unit(8, 3),
            unit(8, 5) - (sgn / TOE_LEG_M) * unit(8, 4),
            unit(8, 7) - sgn * unit(8, 4),
        ]
    };
    assert_standing_toe_jacobian("kicking leg", 5.0, [0.0; 4], 0.3, &events, dirs);
}

/// The same robot with a soft servo, its toe sliding forward at 0.3 m/s: the sliding stops
/// and the toe sticks (stick, `g` the sliding velocity `t·v`, `D_xg = (t·D²c[q̇, ·], t·J_c)`),
/// later slips (5.51) and the belly lands (touchdown). Its initial state is off every
/// guard, and `x, θ, φ, ẋ, θ̇, φ̇` are tangent to the sliding toe's manifold there (leg
/// vertical, `β̇ = 0`): the whole-run Jacobian in those six columns.
#[test]
fn sliding_toe_stick_slip_touchdown_whole_execution_jacobian() {
    use EventKind::{Slip, Stick, Touchdown};
    let dirs = |_: &Model| [0, 1, 3, 4, 5, 7].iter().map(|&k| unit(8, k)).collect();
    let (events, qd0) = ([Stick, Slip, Touchdown], [0.0, 0.3, 0.0, 0.0]);
    assert_standing_toe_jacobian("sliding toe", 1.0, qd0, 0.4, &events, dirs);
}

/// The leg length of [`leg_with_hip_servo`] (m).
const TOE_LEG_M: f64 = 0.2;

/// The robot of the sliding-toe tests: a body with one massive leg ([`TOE_LEG_M`] long,
/// 0.2 kg) and a hip servo of stiffness `k` (N·m/rad; damping 0.5 N·m·s/rad) towards −1 rad.
fn leg_with_hip_servo(k: f64) -> (Model, Servos) {
    let model = systems::one_leg(TOE_LEG_M, 0.2, G);
    let servo = Servos {
        k,
        c: 0.5,
        target: vec![-1.0],
    };
    (model, servo)
}

/// The robot of [`leg_with_hip_servo`]`(k)` standing on its sliding toe, leg vertical, with
/// the velocities `qd0`, run to `tf`: its events are `events`, each with its saltation
/// defined, and its whole-run Jacobian along `dirs(model)` matches central differences of
/// whole runs to 1e-5 (`what` names the case in the messages).
fn assert_standing_toe_jacobian(
    what: &str,
    k: f64,
    qd0: [f64; 4],
    tf: f64,
    events: &[EventKind],
    dirs: impl Fn(&Model) -> Vec<DVector<f64>>,
) {
    let (model, servo) = leg_with_hip_servo(k);
    let y0: Vec<f64> = [0.0, 0.0, -TOE_LEG_M, 0.0].into_iter().chain(qd0).collect();
    let case = Case {
        ctrl: &servo,
        mode: ContactMode::FLIGHT.with(0, ContactKind::Slide),
        ..Case::passive(&model, &y0, tf, tight(0.0))
    };
    let (exec, sens) = case.sensitivity();
    let jac = defined_jacobian(what, &exec, &sens, events);
    case.assert_whole_run_close(jac, &dirs(&model), 1e-5, what);
}

/// The whole-run Jacobian of a run whose events are `kinds`, each with its saltation defined.
fn defined_jacobian<'s>(
    label: &str,
    exec: &Execution,
    sens: &'s Sensitivity,
    kinds: &[EventKind],
) -> &'s DMatrix<f64> {
    let seen: Vec<_> = exec.events.iter().map(|e| e.kind).collect();
    eprintln!(
        "{label}: {seen:?} at {:?}",
        exec.events.iter().map(|e| e.t).collect::<Vec<_>>()
    );
    assert_eq!(seen, kinds);
    for es in &sens.events {
        assert_eq!(es.status, SaltationStatus::Defined, "{es:?}");
    }
    sens.state_jacobian.as_ref().expect("defined")
}
