//! A controller's law with a kink — a servo that saturates, `τ = clamp(−K (θ − θ₀) − C θ̇,
//! ±L)`: continuous, its partials not — in the sensitivities (`docs/sensitivity.md`, "Kinks
//! of a controller's law"). No saltation is due there (`f⁺ = f⁻`), but a tangent step that
//! straddles the kink integrates `Ẋ = F X` to first order only; the controller says where its
//! law switches piece (`Controller::partials_piece`) and the tangent's steps are split there.
//! Checked against central differences of whole executions (the independent route).
mod systems;
use selfmanip_core::{ContactMode, Model};
use selfmanip_hybrid::{ControlPoint, Controller, ControllerPartials};
use systems::{flight_run_jacobian_fd, run_from_flight, G};

/// A hip servo to `target` at rest, saturating at `±limit`; it reports its pieces
/// (0 linear, 1 at `+limit`, 2 at `−limit`) when `pieces`.
#[derive(Clone)]
struct Saturating {
    k: f64,
    c: f64,
    target: f64,
    limit: f64,
    pieces: bool,
}

impl Saturating {
    fn raw(&self, q: &[f64], qd: &[f64]) -> f64 {
        -self.k * (q[0] - self.target) - self.c * qd[0]
    }
}

impl Controller for Saturating {
    fn torque(&self, _t: f64, q: &[f64], qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        tau[0] = self.raw(q, qd).clamp(-self.limit, self.limit);
    }
    fn partials(&self, at: &ControlPoint, out: &mut ControllerPartials) -> bool {
        let ControlPoint { q, qd, .. } = *at;
        if self.raw(q, qd).abs() < self.limit {
            out.dtau.dq[(0, 0)] = -self.k;
            out.dtau.dqd[(0, 0)] = -self.c;
        }
        true
    }
    fn partials_piece(&self, _t: f64, q: &[f64], qd: &[f64], _mode: ContactMode) -> u64 {
        let r = self.raw(q, qd);
        match () {
            _ if !self.pieces || r.abs() < self.limit => 0,
            _ if r > 0.0 => 1,
            _ => 2,
        }
    }
}

/// The whole-run Jacobian's worst error relative to central differences (Richardson from
/// h = 1e-3, 5e-4) in all eight directions, and how many times the servo's piece changes
/// inside a segment. The steps are large for central differences: the executions' states
/// across a kink carry errors of the tolerance that move with the kink's place in the
/// engine's step, so differences over 1e-6 are noisy to ~1e-6 (the split tangent itself
/// agrees with itself at rtol 1e-11, 1e-12 and 1e-13 to 2e-11).
fn jacobian_error(model: &Model, ctrl: &Saturating, y0: &[f64], tf: f64) -> (f64, usize) {
    let (exec, sens) = systems::flight_sensitivity(model, ctrl, y0, tf).unwrap();
    let (_, seq) = run_from_flight(model, ctrl, y0, tf);
    let probe = Saturating {
        pieces: true,
        ..ctrl.clone()
    };
    let mut kinks = 0;
    for seg in &exec.segments {
        let mut y = vec![0.0; 8];
        let mut last = None;
        for k in 1..400 {
            let t = seg.t0 + (seg.t1 - seg.t0) * f64::from(k) / 400.0;
            seg.eval(t, &mut y);
            let p = probe.partials_piece(t, &y[..4], &y[4..], seg.mode);
            kinks += usize::from(last.is_some_and(|l| l != p));
            last = Some(p);
        }
    }
    let jac = sens.state_jacobian.expect("defined");
    let fd = flight_run_jacobian_fd(model, ctrl, y0, tf, &seq, 1e-3);
    eprintln!("events {seq:?}");
    ((&jac - &fd).amax() / fd.amax(), kinks)
}

/// The massless one-legged body of `tests/sensitivity.rs` (falls, lands on its toe and
/// leans over it) under a hip servo that saturates at 1 N m: its piece changes four times in
/// stance. Split there, the whole-run Jacobian agrees with central differences to 4.2e-8;
/// straddled (the same controller not saying where its pieces change) it was 3.6e-5 off
/// (1.2e-6 with one kink at a 5 N m limit; the error falls only as the steps do).
#[test]
fn a_saturating_servos_kink_splits_the_tangents_steps() {
    let model = systems::one_leg(0.2, 0.0, G);
    let y0 = [0.2, 0.0, -0.23, 0.1, -0.5, 0.4, 0.3, 0.2];
    let mut ctrl = Saturating {
        k: 20.0,
        c: 0.5,
        target: -0.3,
        limit: 1.0,
        pieces: true,
    };
    let (split, kinks) = jacobian_error(&model, &ctrl, &y0, 0.42);
    ctrl.pieces = false;
    let (straddled, _) = jacobian_error(&model, &ctrl, &y0, 0.42);
    eprintln!("{kinks} kinks: split {split:e}, straddled {straddled:e}");
    assert!(kinks >= 2, "{kinks}");
    assert!(split < 1e-6, "{split:e}");
    // the same run straddling its kinks: the test can tell the difference
    assert!(straddled > 1e-5, "{straddled:e}");
}
