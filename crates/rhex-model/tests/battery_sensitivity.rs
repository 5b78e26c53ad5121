//! The leap's exact derivatives in the gearbox efficiency η, the battery resistance `R_b`
//! and the gear ratio with a battery resistance set (`R_b > 0`), against Richardson-
//! extrapolated central differences of whole leaps, to 1e-5; and the tangent of the first
//! segment over the knot where the swinging front leg reaches its no-load speed.
//!
//! The knot is where these derivatives were once wrong (1e-4 … 1e-2 relative at some `R_b`,
//! exact at others): the swing's partials (`StartedLaw::partials_full`) chose their piece by
//! durations formed as dual numbers, which round otherwise than the motion's own, so one ulp
//! past a knot they were the previous piece's; the first stage of the step after the knot
//! sits there (`t_k` + 1 ulp, the right limit) and carried `b₁ h Δ(∂q̈/∂η)` into the
//! tangent. Whether the two roundings differ depends on the numbers, so it came and went
//! with `R_b`. The motion and its partials now take one piece decision
//! (`JointMotion::piece_at`).
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LeapPreset, LegActuator, Strategy};
use rhex_model::leap_sensitivity::{leap_with_sensitivity, APEX_COLUMNS};
use selfmanip_hybrid::sensitivity::{execution_sensitivity_columns, Parameter};

/// The apex's `ż` column: 0 at the apex by definition (not compared).
const ZDOT: usize = 5;

fn config(strategy: &str, t2: f64, efficiency: f64, r_b: f64) -> LeapConfig {
    LeapConfig {
        strategy: strategy.parse::<Strategy>().unwrap(),
        t2_s: t2,
        actuator: LegActuator::GearedMotor {
            gear_ratio: 28.0,
            current_limit_a: 20.0,
            motors_per_leg: 2,
            gearbox_efficiency: Some(efficiency),
            gearbox_loss: motor::GearboxLoss::Derating,
            battery_resistance_ohm: Some(r_b),
        },
        rtol: 1e-12,
        event_tol_s: 1e-14,
        control_free_joints: true,
        ..LeapConfig::default()
    }
}

/// `cfg`'s actuator with the named number set to `v`.
fn with(cfg: &LeapConfig, name: &str, v: f64) -> LeapConfig {
    let mut c = cfg.clone();
    if let LegActuator::GearedMotor {
        gear_ratio,
        gearbox_efficiency,
        battery_resistance_ohm,
        ..
    } = &mut c.actuator
    {
        match name {
            "gear_ratio" => *gear_ratio = v,
            "gearbox_efficiency" => *gearbox_efficiency = Some(v),
            "battery_resistance_ohm" => *battery_resistance_ohm = Some(v),
            _ => unreachable!("{name}"),
        }
    }
    c
}

fn apex(cfg: &LeapConfig) -> [f64; 7] {
    let a = simulate_leap(&leap_params(), cfg)
        .unwrap()
        .apex
        .expect("an apex");
    [
        a.t_s,
        a.x_m,
        a.z_m,
        a.phi_rad,
        a.xdot_m_s,
        a.zdot_m_s,
        a.phidot_rad_s,
    ]
}

/// `d apex / d name` at `p` by central differences, Richardson-extrapolated from `h`, `h/2`.
fn richardson(cfg: &LeapConfig, name: &str, p: f64, h: f64) -> [f64; 7] {
    let d = |h: f64| {
        let (a, b) = (apex(&with(cfg, name, p + h)), apex(&with(cfg, name, p - h)));
        std::array::from_fn::<f64, 7, _>(|c| (a[c] - b[c]) / (2.0 * h))
    };
    let (d1, d2) = (d(h), d(0.5 * h));
    std::array::from_fn(|c| (4.0 * d2[c] - d1[c]) / 3.0)
}

/// Leaps that fly with `R_b > 0` (at 0.05 Ω and 0.3 Ω the swing's knot rounded the wrong
/// way before the fix; 0.1 Ω did not), several strategies, both efficiencies.
#[test]
fn loss_derivatives_with_a_battery_resistance_match_central_differences() {
    let mut worst: f64 = 0.0;
    for (s, t2, eta, r_b) in [
        ("--", 0.04, 0.82, 0.05),
        ("--", 0.1, 0.7, 0.05),
        ("--", 0.04, 0.82, 0.3),
        ("++", 0.04, 0.82, 0.05),
        ("+-", 0.1, 0.82, 0.05),
        ("-+", 0.04, 0.82, 0.3),
    ] {
        let cfg = config(s, t2, eta, r_b);
        let names = [
            ("battery_resistance_ohm", r_b, 1e-3 * r_b),
            ("gearbox_efficiency", eta, 1e-3),
            ("gear_ratio", 28.0, 3e-3),
        ];
        let list: Vec<&str> = names.iter().map(|n| n.0).collect();
        let sens = leap_with_sensitivity(&leap_params(), &cfg, &list).unwrap();
        assert!(sens.ok, "{s} {t2} {r_b}: {:?}", sens.reason);
        for (k, &(name, p, h)) in names.iter().enumerate() {
            let fd = richardson(&cfg, name, p, h);
            for c in (0..7).filter(|&c| c != ZDOT) {
                let e = (sens.d_apex[c][k] - fd[c]).abs() / (fd[c].abs() + 1e-3);
                eprintln!(
                    "{s} t2 {t2} η {eta} R_b {r_b}: d {} / d {name} {:e} vs {:e} ({e:.1e})",
                    APEX_COLUMNS[c], sens.d_apex[c][k], fd[c]
                );
                assert!(
                    e < 1e-5,
                    "{s} t2 {t2} R_b {r_b} {name} {}: {e:e}",
                    APEX_COLUMNS[c]
                );
                worst = worst.max(e);
            }
        }
    }
    eprintln!("worst {worst:.1e}");
}

/// `d (q, q̇)(t_f) / dη` over the first segment (before the first touchdown) by the tangent,
/// and by central differences of whole leaps at the same instant.
fn first_segment_columns(r_b: f64, t_f: f64) -> (Vec<f64>, Vec<f64>) {
    let cfg = config("--", 0.04, 0.82, r_b);
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
        let run = simulate_leap(&leap_params(), &with(&cfg, "gearbox_efficiency", eta)).unwrap();
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
