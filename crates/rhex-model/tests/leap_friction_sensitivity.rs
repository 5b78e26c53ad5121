//! The leap's exact derivatives in its rear toes' friction coefficient (`mu_rear`: the
//! static `μ` and, with Coulomb toes, the kinetic one with it) and in the pseudo-impulse's
//! `delta_t_s`, against Richardson-extrapolated central differences of whole leaps.
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, Strategy};
use rhex_model::leap_sensitivity::{leap_with_sensitivity, APEX_COLUMNS};
use rhex_model::RhexParams;

/// The apex's `ż` column: 0 at the apex by definition, not compared.
const ZDOT: usize = 5;

fn config(strategy: Strategy, t2: f64) -> LeapConfig {
    LeapConfig {
        strategy,
        t2_s: t2,
        rtol: 1e-12,
        event_tol_s: 1e-14,
        control_free_joints: true,
        ..LeapConfig::default()
    }
}

fn apex(params: &RhexParams, cfg: &LeapConfig) -> Option<[f64; 7]> {
    Some(simulate_leap(params, cfg).ok()?.apex?.to_array())
}

fn with_mu_rear(mu: f64) -> RhexParams {
    RhexParams {
        mu_rear: Some(mu),
        ..leap_params()
    }
}

/// `d apex / d mu_rear` at `mu` by central differences, Richardson-extrapolated from `h`.
fn richardson(cfg: &LeapConfig, mu: f64, h: f64) -> Option<[f64; 7]> {
    let d = |h: f64| -> Option<[f64; 7]> {
        let (a, b) = (
            apex(&with_mu_rear(mu + h), cfg)?,
            apex(&with_mu_rear(mu - h), cfg)?,
        );
        Some(std::array::from_fn(|c| (a[c] - b[c]) / (2.0 * h)))
    };
    let (d1, d2) = (d(h)?, d(0.5 * h)?);
    Some(std::array::from_fn(|c| (4.0 * d2[c] - d1[c]) / 3.0))
}

/// `(+,−)` and `(−,+)` at `t2 = 0.04 s`: the rear toes hold and push through the leap's
/// stance, where `μ_rear = 2.5` moves the apex (by 0.3 m/s of `ẋ` per unit of `μ` in the
/// first); each apex column against central differences, relative to the difference's size
/// plus 1e-3, to 1e-5. The leap's `δt = 0.03 s` selects its impacts' modes only: its
/// column is zero, and so are the differences (the leaps at `δt ± h` are the leap).
#[test]
fn mu_rear_and_delta_t_match_central_differences() {
    let mut worst: f64 = 0.0;
    for (s, t2) in [("+-", 0.04), ("-+", 0.04)] {
        let cfg = config(s.parse().unwrap(), t2);
        let sens = leap_with_sensitivity(&leap_params(), &cfg, &["mu_rear", "delta_t_s"]).unwrap();
        assert!(sens.ok, "{:?}", sens.reason);
        let fd = richardson(&cfg, 2.5, 2.5e-4).expect("every leap has an apex");
        let scale = fd.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            scale > 1e-2,
            "{s}: the apex does not depend on mu_rear ({scale:e})"
        );
        for c in (0..7).filter(|&c| c != ZDOT) {
            let e = (sens.d_apex[c][0] - fd[c]).abs() / (fd[c].abs() + 1e-3);
            eprintln!(
                "{s} {} mu_rear: {:e} vs {:e} ({e:.1e})",
                APEX_COLUMNS[c], sens.d_apex[c][0], fd[c]
            );
            worst = worst.max(e);
            assert_eq!(
                sens.d_apex[c][1], 0.0,
                "{s}: d {} / d delta_t_s",
                APEX_COLUMNS[c]
            );
        }
        let at = |dt: f64| {
            apex(
                &leap_params(),
                &LeapConfig {
                    delta_t_s: dt,
                    ..cfg.clone()
                },
            )
            .unwrap()
        };
        assert_eq!(
            at(0.03 + 3e-6),
            at(0.03 - 3e-6),
            "{s}: the leap moves with δt"
        );
        assert_eq!(at(0.03 + 3e-6), at(0.03), "{s}");
    }
    eprintln!("worst {worst:.1e}");
    assert!(worst < 1e-5, "{worst:e}");
}

/// At `δt = 0` the impacts take another rule (the limit `δt → 0⁺`): the name is refused.
#[test]
fn delta_t_at_zero_is_refused() {
    let cfg = LeapConfig {
        delta_t_s: 0.0,
        ..config("+-".parse().unwrap(), 0.04)
    };
    let e = leap_with_sensitivity(&leap_params(), &cfg, &["delta_t_s"]).unwrap_err();
    assert!(e.to_string().contains("delta_t_s"), "{e}");
}
