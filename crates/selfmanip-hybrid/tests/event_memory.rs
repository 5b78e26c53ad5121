//! A controller's memory of events in the sensitivities ([`selfmanip_hybrid::Controller::
//! memory_partials`], `docs/sensitivity.md`), on the engine alone: a hip servo whose
//! reference ramps from the angle and the time of the toe's touchdown. Its torque in
//! stance — hence the stance forces and the slip guard that ends it — depends on
//! `(t_k, θ_k)`; the whole-run Jacobian against central differences of whole executions,
//! and a controller that says it remembers events but gives no partials is a typed error.
mod systems;
use nalgebra::DMatrix;
use selfmanip_core::{ContactMode, FlatGround};
use selfmanip_hybrid::sensitivity::{execution_sensitivity_columns, Parameter, SensitivityError};
use selfmanip_hybrid::{
    ControlPoint, Controller, ControllerPartials, Event, EventKind, EventMemoryPartials,
};
use systems::{run_from_flight, G};

/// After the first touchdown (event `k` at `t_k`, hip at `θ_k`), a servo to the ramp
/// `θ*(t) = θ_k + ω_r (t − t_k)`: `τ = −K (θ − θ*) − C (θ̇ − ω_r)`; before it, a servo to
/// `target` at rest. Memory partials: `∂τ/∂t_k = −K ω_r`, `∂τ/∂θ_k = K`.
#[derive(Clone)]
struct RampFromTouchdown {
    k: f64,
    c: f64,
    target: f64,
    ramp: f64,
    /// `(event number, t_k, θ_k)` once the toe has touched down.
    started: Option<(usize, f64, f64)>,
    seen: usize,
    /// Whether it gives its memory partials (a controller that does not is flagged).
    gives_partials: bool,
    /// Whether it gives `∂τ/∂t` (the sensitivities difference its torque in time if not).
    gives_time_partials: bool,
}

impl RampFromTouchdown {
    fn reference(&self, t: f64) -> (f64, f64) {
        match self.started {
            Some((_, tk, th)) => (th + self.ramp * (t - tk), self.ramp),
            None => (self.target, 0.0),
        }
    }
}

impl Controller for RampFromTouchdown {
    fn torque(&self, t: f64, q: &[f64], qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        let (th, w) = self.reference(t);
        tau[0] = -self.k * (q[0] - th) - self.c * (qd[0] - w);
    }
    fn partials(&self, _at: &ControlPoint, out: &mut ControllerPartials) -> bool {
        out.dtau.dq[(0, 0)] = -self.k;
        out.dtau.dqd[(0, 0)] = -self.c;
        true
    }
    /// `∂τ/∂t = K ω*` (the ramp moves the reference at a fixed state).
    fn time_partials(&self, at: &ControlPoint, dtau_dt: &mut [f64]) -> bool {
        let ControlPoint { t, .. } = *at;
        dtau_dt[0] = self.k * self.reference(t).1;
        self.gives_time_partials
    }
    fn on_event(&mut self, e: &Event) {
        if self.started.is_none() && e.kind == EventKind::Touchdown {
            self.started = Some((self.seen, e.t, e.q[0]));
        }
        self.seen += 1;
    }
    fn has_event_memory(&self) -> bool {
        self.started.is_some()
    }
    fn memory_partials(&self, at: &ControlPoint, out: &mut Vec<EventMemoryPartials>) -> bool {
        let ControlPoint { q, free_joints, .. } = *at;
        if !self.gives_partials {
            return !self.has_event_memory();
        }
        if let Some((event, _, _)) = self.started {
            let mut dtau = DMatrix::zeros(1, 1 + 2 * q.len());
            dtau[(0, 0)] = -self.k * self.ramp;
            dtau[(0, 1)] = self.k;
            out.push(EventMemoryPartials {
                event,
                dtau,
                dfree: DMatrix::zeros(free_joints.len(), 1 + 2 * q.len()),
            });
        }
        true
    }
}

fn servo(gives_partials: bool) -> RampFromTouchdown {
    RampFromTouchdown {
        k: 20.0,
        c: 0.5,
        target: -0.3,
        ramp: 1.5,
        started: None,
        seen: 0,
        gives_partials,
        gives_time_partials: true,
    }
}

/// The massless one-legged body of `tests/sensitivity.rs` (falls, lands on its toe, leans
/// over it until the toe slips, lands on its belly) under the ramp servo: the whole-run
/// Jacobian of `execution_sensitivity` and the columns of `execution_sensitivity_columns`
/// against central differences (Richardson from h = 1e-6, 5e-7) of whole executions in all
/// eight directions (1.9e-9 relative). The memory reaches the slip guard (`∂λ/∂m_k`
/// through the stance torque) and the flows after the touchdown; the ramp makes the slip
/// guard depend on time at a fixed state (`Controller::time_partials`: without that term in
/// `ġ = D_xg f⁻ + ∂g/∂t` the slip's time gradient was off by 12 %, the Jacobian by 2e-2;
/// without `time_partials` the sensitivities difference the torque in time, to the same
/// Jacobian). The same controller without memory partials is a typed error.
#[test]
fn ramp_servo_from_a_touchdown_whole_execution_jacobian() {
    let model = systems::one_leg(0.2, 0.0, G);
    let y0 = [0.2, 0.0, -0.23, 0.1, -0.5, 0.4, 0.3, 0.2];
    let tf = 0.42;
    let ctrl = servo(true);
    let (exec, sens) = systems::flight_sensitivity(&model, &ctrl, &y0, tf).unwrap();
    let (_, seq) = run_from_flight(&model, &ctrl, &y0, tf);
    eprintln!(
        "events {seq:?} at {:?}",
        exec.events.iter().map(|e| e.t).collect::<Vec<_>>()
    );
    assert_eq!(seq[0], EventKind::Touchdown);
    let jac = sens.state_jacobian.expect("defined");
    let n2 = 8;
    let fd = systems::flight_run_jacobian_fd(&model, &ctrl, &y0, tf, &seq, 1e-6);
    let err = (&jac - &fd).amax() / fd.amax();
    eprintln!("ramp servo: |J − FD| / |FD| = {err:e}");
    assert!(err < 1e-6, "{err:e}");
    // the columns path (what parameters use) gives the same Jacobian
    let cols = execution_sensitivity_columns(
        &model,
        &FlatGround,
        &exec,
        &DMatrix::identity(n2, n2),
        &[] as &[Parameter],
    )
    .unwrap();
    assert_eq!(cols.columns.as_ref(), Some(&jac));
    // without its ∂τ/∂t the sensitivities difference the torque in time: the same Jacobian
    let mut timeless = servo(true);
    timeless.gives_time_partials = false;
    let (_, s) = systems::flight_sensitivity(&model, &timeless, &y0, tf).unwrap();
    let err_fd = (&s.state_jacobian.expect("defined") - &fd).amax() / fd.amax();
    eprintln!("ramp servo, ∂τ/∂t by differences: |J − FD| / |FD| = {err_fd:e}");
    assert!(err_fd < 1e-6, "{err_fd:e}");
    // held fixed, the derivative is wrong: a controller without memory partials is flagged
    let mut blind = servo(false);
    blind.gives_partials = false;
    let r = systems::flight_sensitivity(&model, &blind, &y0, tf);
    match r {
        Err(SensitivityError::EventMemoryWithoutPartials { t, .. }) => {
            assert!(t >= exec.events[0].t, "{t}")
        }
        other => panic!("{other:?}"),
    }
}
