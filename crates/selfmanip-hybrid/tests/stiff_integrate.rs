//! The stiffness switch of the integrator (`integrate::Dopri5`, `StepOptions::stiff_switch`)
//! on a linear spring–damper on a light link, `I ẍ = −k x − c ẋ`, whose solution is a sum of
//! two exponentials (closed form below). Its fast eigenvalue `≈ −c/I` holds an explicit
//! method's step near `3.3 I / c`; the switch hands the stretch to RODAS4, whose steps are
//! set by accuracy on the slow mode `≈ −k/c`.
#[path = "../../selfmanip-core/tests/common/bisect.rs"]
mod bisect;

use bisect::bisect;
use selfmanip_hybrid::integrate::{
    reset_work_counters, work_counters, DenseOutput, DenseStep, Dopri5, StepOptions,
};

/// Inertia (kg m²), damping (N m s), stiffness (N m): `c/I = 5·10⁴ /s`, `k/c = 20 /s`.
const I: f64 = 2e-5;
const C: f64 = 1.0;
const K: f64 = 20.0;
const X0: f64 = 0.3;
const T_END: f64 = 0.5;

/// The eigenvalues `λ± = (−c ± √(c² − 4kI)) / 2I` (overdamped) and `x(t)` from `x(0) = X0`,
/// `ẋ(0) = 0`: `x = (λ₊ e^{λ₋t} − λ₋ e^{λ₊t}) X0 / (λ₊ − λ₋)`.
fn exact(t: f64) -> [f64; 2] {
    let disc = (C * C - 4.0 * K * I).sqrt();
    let (lp, lm) = ((-C + disc) / (2.0 * I), (-C - disc) / (2.0 * I));
    let a = X0 / (lp - lm);
    [
        a * (lp * (lm * t).exp() - lm * (lp * t).exp()),
        a * lp * lm * ((lm * t).exp() - (lp * t).exp()),
    ]
}

fn rhs(_t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), ()> {
    dy[0] = y[1];
    dy[1] = -(K * y[0] + C * y[1]) / I;
    Ok(())
}

/// Integrates to `T_END`; the dense output, the accepted steps, and the implicit ones.
fn integrate(stiff_switch: bool) -> (DenseOutput, [f64; 2], u64, u64) {
    let opts = StepOptions {
        rtol: 1e-8,
        atol: 1e-10,
        stiff_switch,
        ..StepOptions::default()
    };
    let mut ode = Dopri5::new(2, opts);
    let (mut t, mut y) = (0.0, [X0, 0.0]);
    let mut dense = DenseStep::default();
    let mut out = DenseOutput::default();
    reset_work_counters();
    while t < T_END {
        ode.step(&mut rhs, t, &mut y, T_END, &mut dense).unwrap();
        out.push(&dense);
        t = dense.t1();
    }
    let w = work_counters();
    (
        out,
        y,
        w.accepted[0] + w.accepted[1],
        w.implicit[0] + w.implicit[1],
    )
}

/// The end state to the tolerance's order against the closed form, in a number of steps
/// far below the explicit method's stability bound: DOPRI5 needs at least
/// `|λ₋| T / 3.3 ≈ 7,600` steps; RODAS4's accuracy on the slow mode (`|λ₊| T = 10`, a 4th-order
/// method at `rtol = 1e-8`: `(1e-8)^(−1/4) = 100` steps per unit of `|λ₊| t`, about 1,000 for the
/// run) and the initial transient (`~log(1e8)` steps across the fast mode's decay) bound it by
/// ~1,100; the test asks for 1,500, a fifth of the explicit count.
#[test]
fn stiff_damped_link_in_few_steps() {
    let explicit_bound = (C / I) * T_END / 3.3;
    let (_, y, steps, implicit) = integrate(true);
    let ex = exact(T_END);
    assert!(implicit > 0, "the switch never fired");
    assert!(
        (steps as f64) < 1500.0 && (steps as f64) < explicit_bound / 5.0,
        "{steps} steps (explicit bound {explicit_bound})"
    );
    // x ≈ 1.4e-5 by now: the tolerance's absolute part sets the error
    assert!((y[0] - ex[0]).abs() < 1e-8, "{:e} vs {:e}", y[0], ex[0]);
    assert!((y[1] - ex[1]).abs() < 1e-6, "{:e} vs {:e}", y[1], ex[1]);
    // without the switch, DOPRI5 pays the stability bound
    let (_, _, steps_explicit, implicit_explicit) = integrate(false);
    assert_eq!(implicit_explicit, 0);
    assert!(
        steps_explicit as f64 > 0.8 * explicit_bound,
        "{steps_explicit}"
    );
}

/// An event on the stiff stretch — `x` falling through `X0 / 10` — located on the dense
/// output of the implicit steps (bisection, as the guards are located) against the closed
/// form's crossing (bisection on `exact`).
#[test]
fn event_on_a_stiff_stretch_at_its_closed_form_time() {
    let (out, _, _, _) = integrate(true);
    let level = X0 / 10.0;
    let crossing = |g: &dyn Fn(f64) -> f64| {
        let (lo, hi) = bisect(0.0, T_END, 0.0, g);
        0.5 * (lo + hi)
    };
    let t_exact = crossing(&|t| exact(t)[0] - level);
    let t_dense = crossing(&|t| {
        let mut y = [0.0; 2];
        out.eval(t, &mut y);
        y[0] - level
    });
    // the crossing lies on an implicit step
    let on = out
        .steps()
        .find(|s| s.t0 <= t_dense && t_dense <= s.t1())
        .unwrap();
    assert!(on.implicit, "crossing at {t_dense} on an explicit step");
    // |ẋ| ≈ 2 X0/10 /s there: a state error of 1e-9 is a time error of ~2e-8 s
    assert!(
        (t_dense - t_exact).abs() < 1e-7,
        "{t_dense} vs {t_exact} (closed form)"
    );
}

/// Bit-identical results from run to run and from thread to thread.
#[test]
fn stiff_integration_is_deterministic() {
    let (a, ya, _, _) = integrate(true);
    let (b, yb) = std::thread::spawn(|| {
        let (b, yb, _, _) = integrate(true);
        (b, yb)
    })
    .join()
    .unwrap();
    assert_eq!(ya.map(f64::to_bits), yb.map(f64::to_bits));
    assert_eq!(a.len(), b.len());
    for (s, u) in a.steps().zip(b.steps()) {
        assert_eq!(
            (s.t0.to_bits(), s.h.to_bits()),
            (u.t0.to_bits(), u.h.to_bits())
        );
    }
}
