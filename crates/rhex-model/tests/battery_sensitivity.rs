//! The tangent of the leap's first segment in the gearbox efficiency η, with a battery
//! resistance set, over the knot where the swinging front leg reaches its no-load speed,
//! against central differences of whole leaps at the same instant (the apex's derivatives at
//! `R_b > 0`: `tests/drive_loss_sensitivity.rs`).
//!
//! The knot is where the leap's derivatives in η and `R_b` were once wrong (1e-4 … 1e-2
//! relative at some `R_b`, exact at others): the swing's partials (`StartedLaw::partials_full`) chose their piece by
//! durations formed as dual numbers, which round otherwise than the motion's own, so one ulp
//! past a knot they were the previous piece's; the first stage of the step after the knot
//! sits there (`t_k` + 1 ulp, the right limit) and carried `b₁ h Δ(∂q̈/∂η)` into the
//! tangent. Whether the two roundings differ depends on the numbers, so it came and went
//! with `R_b`. The dual durations now carry the motion's own values (`StartedLaw::shape`).
use rhex_model::leap::{
    leap_params, simulate_leap, GearedMotor, LeapConfig, LeapPreset, LegActuator,
};
use selfmanip_hybrid::sensitivity::{execution_sensitivity_columns, Parameter};

/// The `(−,−)` leap at `t2 = 0.04` s with efficiency `efficiency` on a battery of `r_b` Ω.
fn config(efficiency: f64, r_b: f64) -> LeapConfig {
    LeapConfig {
        strategy: "--".parse().unwrap(),
        t2_s: 0.04,
        actuator: LegActuator::GearedMotor(GearedMotor {
            gear_ratio: 28.0,
            current_limit_a: 20.0,
            motors_per_leg: 2,
            gearbox_efficiency: Some(efficiency),
            gearbox_loss: motor::GearboxLoss::Derating,
            battery_resistance_ohm: Some(r_b),
        }),
        rtol: 1e-12,
        event_tol_s: 1e-14,
        control_free_joints: true,
        ..LeapConfig::default()
    }
}

/// `d (q, q̇)(t_f) / dη` over the first segment (before the first touchdown) by the tangent,
/// and by central differences of whole leaps at the same instant.
fn first_segment_columns(r_b: f64, t_f: f64) -> (Vec<f64>, Vec<f64>) {
    let cfg = config(0.82, r_b);
    let r = simulate_leap(&leap_params(), &cfg).unwrap();
    let preset = LeapPreset::new(&leap_params(), &cfg).unwrap();
    let model = &preset.leap.rhex.model;
    let n2 = 2 * model.nq();
    let mut ex = r.execution.clone();
    ex.segments.truncate(1);
    ex.events.clear();
    assert!(t_f < ex.segments[0].t1);
    ex.segments[0].t1 = t_f;
    let mut y = vec![0.0; n2];
    ex.segments[0].eval(t_f, &mut y);
    (ex.t, ex.q, ex.qd) = (t_f, y[..n2 / 2].to_vec(), y[n2 / 2..].to_vec());
    ex.termination = selfmanip_hybrid::Termination::FinalTime;
    let p = [Parameter::Controller("gearbox_efficiency".into())];
    let dirs = nalgebra::DMatrix::zeros(n2, 0);
    let cs = execution_sensitivity_columns(model, &cfg.terrain, &ex, &dirs, &p).unwrap();
    let exact = cs.columns.unwrap().column(0).iter().copied().collect();
    let state = |eta: f64| {
        let mut y = vec![0.0; n2];
        let run = simulate_leap(&leap_params(), &config(eta, r_b)).unwrap();
        run.execution.segments[0].eval(t_f, &mut y);
        y
    };
    let h = 1e-5;
    let (a, b) = (state(0.82 + h), state(0.82 - h));
    (exact, (0..n2).map(|i| (a[i] - b[i]) / (2.0 * h)).collect())
}

/// Before, at and after the knot (≈ 0.0217 s at 0.05 Ω, 0.0222 s at 0.1 Ω): at 0.05 Ω the
/// leg's `dq̇/dη` after the knot was 0.376 where the leg runs at its no-load speed whatever
/// η (central differences: 0).
#[test]
fn efficiency_column_over_the_swing_knot_matches_central_differences() {
    for r_b in [0.05, 0.1] {
        for t_f in [0.0216, 0.022, 0.03] {
            let (exact, fd) = first_segment_columns(r_b, t_f);
            let worst = exact
                .iter()
                .zip(&fd)
                .map(|(e, f)| (e - f).abs() / (f.abs() + 1e-3))
                .fold(0.0, f64::max);
            eprintln!("R_b {r_b} t {t_f}: worst {worst:.1e}");
            assert!(
                worst < 1e-5,
                "R_b {r_b} t {t_f}: {worst:e}\n{exact:?}\n{fd:?}"
            );
        }
    }
}
