//! The leap's exact derivatives with respect to the geared motor's loss options
//! (`gearbox_efficiency` η, `battery_resistance_ohm` R_b) and its gear ratio, at η = 0.7 and
//! at the defaults (the thesis's law, specialized at compile time, whose derivatives in η and
//! R_b must still be given), against Richardson-extrapolated central differences of whole
//! leaps (the execution `leap_with_sensitivity` differentiates: free legs under step
//! control), to 1e-5; and the power-flow law's jump at a stalled leg, flagged.
use rhex_model::leap::{
    leap_params, simulate_leap, GearedMotor, LeapConfig, LegActuator, Strategy,
};
use rhex_model::leap_sensitivity::{leap_with_sensitivity, APEX_COLUMNS};

/// The apex's `ż` column: 0 at the apex by definition; differences see only where each run
/// located its apex, so it is not compared.
const ZDOT: usize = 5;

fn geared(efficiency: Option<f64>, loss: motor::GearboxLoss, r_b: Option<f64>) -> LegActuator {
    LegActuator::GearedMotor(GearedMotor {
        gear_ratio: 28.0,
        current_limit_a: 20.0,
        motors_per_leg: 2,
        gearbox_efficiency: efficiency,
        gearbox_loss: loss,
        battery_resistance_ohm: r_b,
    })
}

/// A leap at tight tolerances (differences of whole leaps need them), free legs under step
/// control (the execution the sensitivities take).
fn config(strategy: Strategy, t2: f64, actuator: LegActuator) -> LeapConfig {
    LeapConfig {
        strategy,
        t2_s: t2,
        actuator,
        rtol: 1e-12,
        event_tol_s: 1e-14,
        control_free_joints: true,
        ..LeapConfig::default()
    }
}

/// `cfg`'s actuator with the named option set to `v`.
fn with(cfg: &LeapConfig, name: &str, v: f64) -> LeapConfig {
    let mut c = cfg.clone();
    if let LegActuator::GearedMotor(GearedMotor {
        gear_ratio,
        gearbox_efficiency,
        battery_resistance_ohm,
        ..
    }) = &mut c.actuator
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

/// The worst error of the exact derivatives over the apex columns and `names`, each relative
/// to the difference's size plus `floor`.
fn worst_error(cfg: &LeapConfig, names: &[(&str, f64, f64)], floor: f64) -> f64 {
    let list: Vec<&str> = names.iter().map(|n| n.0).collect();
    let s = leap_with_sensitivity(&leap_params(), cfg, &list).unwrap();
    assert!(s.ok, "{:?}", s.reason);
    let mut worst: f64 = 0.0;
    for (k, &(name, p, h)) in names.iter().enumerate() {
        let fd = richardson(cfg, name, p, h);
        for c in (0..7).filter(|&c| c != ZDOT) {
            let e = (s.d_apex[c][k] - fd[c]).abs() / (fd[c].abs() + floor);
            eprintln!(
                "{} {name}: {:e} vs {:e} ({e:.1e})",
                APEX_COLUMNS[c], s.d_apex[c][k], fd[c]
            );
            worst = worst.max(e);
        }
    }
    worst
}

#[test]
fn efficiency_derivatives_match_central_differences() {
    for (s, t2) in [("--", 0.04), ("++", 0.05)] {
        let strategy: Strategy = s.parse().unwrap();
        let cfg = config(
            strategy,
            t2,
            geared(Some(0.7), motor::GearboxLoss::Derating, None),
        );
        let names = [
            ("gearbox_efficiency", 0.7, 1e-3),
            ("gear_ratio", 28.0, 3e-3),
        ];
        let e = worst_error(&cfg, &names, 1e-3);
        eprintln!("{strategy} t2 {t2}: worst {e:.1e}");
        assert!(e < 1e-5, "{strategy} t2 {t2}: {e:e}");
    }
}

/// Under the power-flow gearbox law a leg that stalls in stance (the front leg of this leap
/// once it has landed, its speed at round-off) sits on the law's jump: the derivative is
/// flagged, with the reason, not formed silently.
#[test]
fn a_stalled_leg_under_the_power_flow_law_flags_the_derivative() {
    let cfg = config(
        "--".parse().unwrap(),
        0.04,
        geared(Some(0.7), motor::GearboxLoss::PowerFlow, None),
    );
    let s = leap_with_sensitivity(&leap_params(), &cfg, &["gearbox_efficiency"]).unwrap();
    assert!(!s.ok);
    assert!(s.d_apex.iter().flatten().all(|d| d.is_nan()));
    let reason = s.reason.unwrap();
    assert!(reason.contains("power-flow gearbox law"), "{reason}");
    // the leap itself runs, and its apex is the one the run without derivatives gives
    assert_eq!(s.result.apex.unwrap().z_m, apex(&cfg)[2]);
}

/// At the default options the leap runs the thesis's law (specialized at compile time), yet
/// its derivatives in η and R_b (at R_b = 0: one-sided differences, R_b ≥ 0) are exact.
#[test]
fn default_options_have_exact_loss_derivatives() {
    let cfg = config(
        "--".parse().unwrap(),
        0.04,
        geared(None, motor::GearboxLoss::Derating, None),
    );
    let e = worst_error(&cfg, &[("gearbox_efficiency", 0.82, 1e-3)], 1e-3);
    assert!(e < 1e-5, "{e:e}");
    // R_b ≥ 0: the one-sided derivative, `(−3 f(0) + 4 f(h) − f(2h)) / 2h` from h and h/2
    // Richardson-extrapolated
    let s = leap_with_sensitivity(&leap_params(), &cfg, &["battery_resistance_ohm"]).unwrap();
    assert!(s.ok, "{:?}", s.reason);
    let f0 = apex(&cfg);
    let d = |h: f64| {
        let (a, b) = (
            apex(&with(&cfg, "battery_resistance_ohm", h)),
            apex(&with(&cfg, "battery_resistance_ohm", 2.0 * h)),
        );
        std::array::from_fn::<f64, 7, _>(|c| (-3.0 * f0[c] + 4.0 * a[c] - b[c]) / (2.0 * h))
    };
    let (d1, d2) = (d(2e-3), d(1e-3));
    for c in (0..7).filter(|&c| c != ZDOT) {
        let fd = (4.0 * d2[c] - d1[c]) / 3.0;
        let e = (s.d_apex[c][0] - fd).abs() / (fd.abs() + 1e-3);
        eprintln!(
            "{} R_b: {:e} vs {fd:e} ({e:.1e})",
            APEX_COLUMNS[c], s.d_apex[c][0]
        );
        assert!(e < 1e-5, "{}: {e:e}", APEX_COLUMNS[c]);
    }
}

/// With a battery resistance set (`R_b` = 0.05 Ω and 0.3 Ω, where the swing's knot once
/// rounded the wrong way: `tests/battery_sensitivity.rs`), six leaps of four strategies: the
/// derivatives in η, `R_b` and the gear ratio to 1e-5.
#[test]
fn loss_derivatives_with_a_battery_resistance_match_central_differences() {
    for (s, t2, eta, r_b) in [
        ("--", 0.04, 0.82, 0.05),
        ("--", 0.1, 0.7, 0.05),
        ("--", 0.04, 0.82, 0.3),
        ("++", 0.04, 0.82, 0.05),
        ("+-", 0.1, 0.82, 0.05),
        ("-+", 0.04, 0.82, 0.3),
    ] {
        let loss = motor::GearboxLoss::Derating;
        let cfg = config(s.parse().unwrap(), t2, geared(Some(eta), loss, Some(r_b)));
        let names = [
            ("battery_resistance_ohm", r_b, 1e-3 * r_b),
            ("gearbox_efficiency", eta, 1e-3),
            ("gear_ratio", 28.0, 3e-3),
        ];
        let e = worst_error(&cfg, &names, 1e-3);
        eprintln!("{s} t2 {t2} η {eta} R_b {r_b}: worst {e:.1e}");
        assert!(e < 1e-5, "{s} t2 {t2} R_b {r_b}: {e:e}");
    }
}
