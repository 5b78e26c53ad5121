//! What the generic sweep gives any preset besides the pool: the names its points may set
//! across the serde records it reads (`sweep::RecordFields`), here a geared drive's and a
//! run's options (no robot's), and the status of a point that failed
//! (`sweep::preset_error_kind`); and the lag timing of a staggered run
//! (`staggered::LagReference`) on a function with a closed-form root.
use selfmanip_core::CoreError;
use selfmanip_hybrid::HybridError;
use selfmanip_sim::drive::GearedMotor;
use selfmanip_sim::path::record_with;
use selfmanip_sim::staggered::{d_first_start_d_lag, LagReference, TOUCHDOWN_SEARCH_TOL_S};
use selfmanip_sim::sweep::{preset_error_kind, RecordFields};
use selfmanip_sim::{SimError, SimOptions};
use serde_json::json;

fn records() -> RecordFields {
    RecordFields(vec![
        RecordFields::of::<GearedMotor>(&["motors_per_leg"]),
        RecordFields::of::<SimOptions>(&[]),
    ])
}

/// Every name once, record by record, but the skipped one; overrides go to the record that
/// reads them and set its fields as a direct assignment does (the second route).
#[test]
fn record_fields_sort_overrides_into_their_records() {
    let r = records();
    let names = r.names();
    let set: std::collections::BTreeSet<&String> = names.iter().collect();
    assert_eq!(set.len(), names.len());
    assert!(names.iter().any(|n| n == "gear_ratio") && names.iter().any(|n| n == "rtol"));
    assert!(!names.iter().any(|n| n == "motors_per_leg"));
    assert_eq!(r.unknown(["rtol", "colour", "gear_ratio"]), Some("colour"));
    assert_eq!(r.unknown(["rtol", "gear_ratio"]), None);
    let mut o = serde_json::Map::new();
    o.insert("rtol".into(), json!(1e-6));
    o.insert("gear_ratio".into(), json!(21.0));
    let sorted = r.sort(&o).unwrap();
    assert_eq!(sorted[0].len(), 1);
    assert_eq!(sorted[1].len(), 1);
    let base = GearedMotor {
        gear_ratio: 28.0,
        current_limit_a: 20.0,
        motors_per_leg: 2,
        gearbox_efficiency: None,
        gearbox_loss: Default::default(),
        battery_resistance_ohm: None,
    };
    let m = record_with(&base, &sorted[0]).unwrap();
    assert_eq!(
        m,
        GearedMotor {
            gear_ratio: 21.0,
            ..base
        }
    );
    let opts = record_with(&SimOptions::default(), &sorted[1]).unwrap();
    let direct = SimOptions {
        rtol: 1e-6,
        ..Default::default()
    };
    assert_eq!(opts, direct);
    o.insert("motors_per_leg".into(), json!(3));
    assert_eq!(r.sort(&o).unwrap_err(), "motors_per_leg");
}

/// An error of the inputs is `invalid_params`, an overflowing result `overflow`, a start off
/// its contacts `off_manifold`; any other engine error keeps its kind.
#[test]
fn preset_error_kinds() {
    let input = SimError::InvalidValue {
        field: "rtol".into(),
        reason: "must be positive".into(),
    };
    assert!(input.is_input_error());
    assert_eq!(preset_error_kind(&input), "invalid_params");
    let overflow = CoreError::NonFiniteResult { quantity: "qdd" };
    assert_eq!(
        preset_error_kind(&SimError::Core(overflow.clone())),
        "overflow"
    );
    let nested = SimError::Hybrid(HybridError::Core(overflow));
    assert_eq!(preset_error_kind(&nested), "overflow");
    let off = SimError::Hybrid(HybridError::OffManifold {
        field: "q0",
        residual: 1e-3,
    });
    assert_eq!(preset_error_kind(&off), "off_manifold");
    let mcap = SimError::Mcap {
        message: "disk full".into(),
    };
    assert_eq!(preset_error_kind(&mcap), mcap.kind());
}

/// Motor-start timing runs the lag as given; touchdown timing finds the motor lag whose
/// touchdown lag `T(s) = s + 2 s²` is the target, against its closed-form root
/// `s = (√(1 + 8 t) − 1) / 4`. The first drive's start moves with a negative lag only.
#[test]
fn lag_reference_times_the_run() {
    let run = |s: f64| Ok::<_, ()>((s, Some(s + 2.0 * s * s)));
    let target = 0.05;
    assert_eq!(LagReference::MotorStart.run(target, 1.0, run), Ok(target));
    let found = LagReference::Touchdown.run(target, 1.0, run).unwrap();
    let exact = ((1.0 + 8.0 * target).sqrt() - 1.0) / 4.0;
    assert!((found - exact).abs() < TOUCHDOWN_SEARCH_TOL_S);
    assert_eq!(LagReference::default(), LagReference::MotorStart);
    // the first drive starts at −min(0, lag) on the run's clock: its slope by the lag
    let start = |lag: f64| -f64::min(0.0, lag);
    for lag in [-0.1, 0.1] {
        let fd = (start(lag + 1e-6) - start(lag - 1e-6)) / 2e-6;
        assert!((fd - d_first_start_d_lag(lag)).abs() < 1e-9);
    }
}
