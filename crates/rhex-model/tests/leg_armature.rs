//! Massive legs carry their motors' rotors: a leap with Table 4.2's leg mass gives each leg
//! joint the armature `n J G²` of its actuator (`rhex_model::leap::rotor_reflected_inertia`,
//! the same value that bounds a massless leg's swing), and massless legs stay massless.
//!
//! Independent routes: the armature's scaling with the gear ratio (`G²`) and the motor count
//! (`n`) from its definition, and the saturated-torque idealization's X-RHex drive (28:1, two
//! motors); the massless swing's bound `stall / (n J G² + I_leg)` rebuilt from the stall
//! torque; the power balance `E(t) − E(0) = Σ τ_i (θ_i(t) − θ_i(0))` of the hybrid engine's
//! flight under constant leg torques, with the energy `½ q̇ᵀM̄q̇ + V` that carries the rotors'
//! `½ a θ̇²`; the default (massless) leap bit-identical whether or not a zero armature is
//! given explicitly.
mod common;
use common::{apex_error, default_leap_and, flight, tight};
use rhex_model::leap::leap_scenario;
use rhex_model::leap::{
    leap_params, leg_actuator, leg_armature, leg_inertia_about_hip, leg_swing,
    rotor_reflected_inertia, simulate_leap, GearedMotor, LeapConfig, LegActuator, X_RHEX_LEG,
};
use rhex_model::leap_sensitivity::leap_with_sensitivity;
use rhex_model::{LegPair, Rhex, RhexError, RhexParams};
use selfmanip_core::tangent::{BodyParameter, TangentError};
use selfmanip_core::{energy, Data};
use selfmanip_hybrid::ConstantTorque;
use selfmanip_hybrid::ControlPoint;

fn massive() -> RhexParams {
    leap_params().with_table_4_2_legs()
}

fn geared(gear_ratio: f64, motors_per_leg: u32) -> LeapConfig {
    LeapConfig {
        actuator: LegActuator::GearedMotor(GearedMotor {
            gear_ratio,
            current_limit_a: 20.0,
            motors_per_leg,
            gearbox_efficiency: None,
            gearbox_loss: Default::default(),
            battery_resistance_ohm: None,
        }),
        ..LeapConfig::default()
    }
}

#[test]
fn rotor_armature_scales_as_n_g_squared_and_is_the_swing_bounds_inertia() {
    let p = massive();
    let a28 = rotor_reflected_inertia(&p, &geared(28.0, 2)).unwrap();
    // Table 2.1's rotor (J = τ_m k_M²/R ≈ 7.2e-6 kg m²), two per planar leg, at 28:1
    assert!((a28 - 0.0112).abs() < 2e-4, "{a28}");
    let a40 = rotor_reflected_inertia(&p, &geared(40.0, 2)).unwrap();
    assert!((a40 / a28 - (40.0f64 / 28.0).powi(2)).abs() < 1e-13);
    let one = rotor_reflected_inertia(&p, &geared(28.0, 1)).unwrap();
    assert!((2.0 * one - a28).abs() < 1e-16);
    let saturated = LeapConfig {
        actuator: LegActuator::SaturatedTorque,
        ..LeapConfig::default()
    };
    assert_eq!(rotor_reflected_inertia(&p, &saturated).unwrap(), a28);
    // the massless leg's swing bound uses the same rotors: stall / (n J G² + I_leg)
    for cfg in [geared(28.0, 2), geared(40.0, 1)] {
        let massless = leap_params();
        let stall = leg_actuator(&massless, &cfg.actuator)
            .unwrap()
            .joint_torque_n_m(1.0, 0.0);
        let a = rotor_reflected_inertia(&massless, &cfg).unwrap();
        let (_, accel) = leg_swing(&massless, &cfg).unwrap();
        let expected = stall / (a + leg_inertia_about_hip(&massless));
        assert!(
            (accel - expected).abs() < 1e-12 * expected,
            "{accel} against {expected}"
        );
    }
}

#[test]
fn a_massive_leaps_legs_carry_the_armature_and_massless_legs_stay_massless() {
    let cfg = geared(35.0, 2);
    let q0 = simulate_leap(&leap_params(), &cfg).unwrap().run.q0;
    let built = |p: &RhexParams| leap_scenario(p, &cfg, &q0).unwrap().rhex.model;
    let a = rotor_reflected_inertia(&massive(), &cfg).unwrap();
    assert_eq!(leg_armature(&massive(), &cfg).unwrap(), a);
    let model = built(&massive());
    for j in 0..2 {
        assert_eq!(model.joints[j].armature_kg_m2, a);
        assert!(!model.distal_massless(j));
    }
    let model = built(&leap_params());
    assert!(model
        .joints
        .iter()
        .all(|j| j.is_massless() && j.armature_kg_m2 == 0.0));
    assert_eq!(leg_armature(&leap_params(), &cfg).unwrap(), 0.0);
    // an explicit armature wins, whatever the legs
    let bare = RhexParams {
        leg_armature_kg_m2: Some(0.0),
        ..massive()
    };
    assert!(built(&bare).joints.iter().all(|j| j.armature_kg_m2 == 0.0));
    // and a bad one is a typed error naming the field
    for bad in [-1e-3, f64::NAN, f64::INFINITY] {
        let p = RhexParams {
            leg_armature_kg_m2: Some(bad),
            ..massive()
        };
        match simulate_leap(&p, &cfg) {
            Err(RhexError::InvalidValue { field, .. }) => assert_eq!(field, "leg_armature_kg_m2"),
            other => panic!("{bad}: {:?}", other.map(|r| r.status)),
        }
    }
}

#[test]
fn the_default_leap_is_the_same_with_an_explicit_zero_armature() {
    let (a, b) = default_leap_and(|p| p.leg_armature_kg_m2 = Some(0.0));
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(a.word, b.word);
    assert_eq!(bits(&a.execution.q), bits(&b.execution.q));
    assert_eq!(bits(&a.execution.qd), bits(&b.execution.qd));
}

#[test]
fn flight_with_rotor_armature_balances_the_torques_work_in_the_engine() {
    let cfg = LeapConfig::default();
    let a = rotor_reflected_inertia(&massive(), &cfg).unwrap();
    let params = RhexParams {
        pairs: vec![LegPair::Front, LegPair::Rear],
        leg_armature_kg_m2: Some(a),
        ..massive()
    };
    let rhex = Rhex::new(params).unwrap();
    let model = &rhex.model;
    assert!(model.joints.iter().all(|j| j.armature_kg_m2 == a));
    let tau = [0.8, -0.5];
    let q0 = [0.4, -0.2, 0.0, -2.0, 0.05];
    let torques_n_m = tau.to_vec();
    let exec = flight(model, &ConstantTorque { torques_n_m }, &q0, 0.2);
    let seg = exec.segments.last().unwrap();
    let mut data = Data::new(model);
    let (t0, v0) = energy(model, &mut data, &q0, &[0.0; 5]).unwrap();
    let mut rotor_share = 0.0f64;
    for t in [0.05, 0.1, 0.15, 0.2] {
        let mut y = vec![0.0; 10];
        seg.eval(t, &mut y);
        let (q, qd) = y.split_at(5);
        let (tk, v) = energy(model, &mut data, q, qd).unwrap();
        let work = tau[0] * (q[0] - q0[0]) + tau[1] * (q[1] - q0[1]);
        let de = tk + v - (t0 + v0);
        assert!(
            (de - work).abs() < 1e-6 * work.abs(),
            "t = {t}: ΔE = {de}, work {work}"
        );
        let rotors = 0.5 * a * (qd[0] * qd[0] + qd[1] * qd[1]);
        rotor_share = rotor_share.max(rotors / work);
    }
    // the rotors take most of the torques' work: they are ~6× the legs' own inertia
    assert!(rotor_share > 0.5, "{rotor_share}");
}

/// The best agreement over three steps of `d t_e / d p` with central differences of whole
/// leaps, for the first `n` events (relative to `max(|fd|, floor)`).
fn worst_event_time_error(
    exact: &[f64],
    n: usize,
    floor: f64,
    steps: [f64; 3],
    leap: impl Fn(f64) -> Vec<selfmanip_sim::EventRecord>,
) -> f64 {
    let base = leap(0.0);
    (0..n)
        .map(|k| {
            steps
                .iter()
                .map(|&h| {
                    let (a, b) = (leap(h), leap(-h));
                    assert_eq!((a[k].kind, b[k].kind), (base[k].kind, base[k].kind));
                    let fd = (a[k].t_s - b[k].t_s) / (2.0 * h);
                    eprintln!(
                        "event {k} {}: exact {:.9}, fd {fd:.9} (h {h:e})",
                        base[k].kind, exact[k]
                    );
                    (exact[k] - fd).abs() / fd.abs().max(floor)
                })
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

/// On legs that carry their rotors the gear ratio moves the armature too, `a = n J G²`:
/// `d/dG` sums the torque line's and `(2a/G) ∂/∂a_j` of each leg joint, and the servo's
/// damping, critical for the leg's inertia with its armature, moves with both. Checked on a massive
/// (−,−) leap through its touchdown, a toe's slip and slide, and its liftoff (the events
/// before a leg's motion in the air started from its liftoff's state): `d t_e / dG` and
/// `d t_e / d a` (the legs' armature set by hand), and the apex's, against central
/// differences of whole leaps; the armature of legs without one is not a parameter (typed
/// errors, here and in the core).
#[test]
fn gear_ratio_and_armature_derivatives_through_the_rotors_equal_central_differences() {
    let cfg = tight("--", -0.1);
    let g = 28.0;
    let s = leap_with_sensitivity(&massive(), &cfg, &["gear_ratio", "leg_armature_kg_m2"]).unwrap();
    assert!(s.ok, "{:?}", s.reason);
    let kinds: Vec<&str> = s.result.events.iter().map(|e| e.kind).collect();
    assert_eq!(kinds[..3], ["touchdown", "slip", "liftoff"], "{kinds:?}");
    let col = |c: usize| -> Vec<f64> {
        (0..3)
            .map(|k| s.event_times[k].as_ref().expect("defined")[c])
            .collect()
    };
    // the leaps with the gear ratio moved by `dg` and with the armature moved by `da`
    let leap_g = |dg: f64| {
        let c = LeapConfig {
            actuator: X_RHEX_LEG.at_gear_ratio(g + dg),
            ..cfg.clone()
        };
        simulate_leap(&massive(), &c).unwrap()
    };
    let a = leg_armature(&massive(), &cfg).unwrap();
    let leap_a = |da: f64| {
        let p = RhexParams {
            leg_armature_kg_m2: Some(a + da),
            ..massive()
        };
        simulate_leap(&p, &cfg).unwrap()
    };
    let err_g = worst_event_time_error(&col(0), 3, 1e-5, [1e-4, 1e-3, 1e-2], |dg| {
        leap_g(dg).run.events
    });
    let err_a = worst_event_time_error(&col(1), 3, 1e-2, [1e-7, 1e-6, 1e-5], |da| {
        leap_a(da).run.events
    });
    assert!(
        err_g < 1e-5 && err_a < 1e-5,
        "d/dG {err_g:e}, d/da {err_a:e}"
    );
    // and the apex, through the legs' motions in the air started at their liftoffs
    let apex = |k: usize| [s.d_apex[2][k], s.d_apex[3][k], s.d_apex[1][k]];
    let apex_g = apex_error(apex(0), &[1e-4, 1e-3], 1e-4, |dg| leap_g(dg).apex.unwrap());
    let apex_a = apex_error(apex(1), &[1e-7, 1e-6], 1e-2, |da| leap_a(da).apex.unwrap());
    assert!(
        apex_g < 1e-4 && apex_a < 1e-4,
        "apex: d/dG {apex_g:e}, d/da {apex_a:e}"
    );
    // the rotors' share of d/dG is not small: without it (the armature held) it differs
    let fixed = RhexParams {
        leg_armature_kg_m2: Some(a),
        ..massive()
    };
    let held = leap_with_sensitivity(&fixed, &cfg, &["gear_ratio"]).unwrap();
    let d_held = held.event_times[0].as_ref().unwrap()[0];
    assert!(
        (d_held - col(0)[0]).abs() > 1e-3 * col(0)[0].abs(),
        "{d_held} {}",
        col(0)[0]
    );
    // legs without armature: not a parameter
    match leap_with_sensitivity(&leap_params(), &cfg, &["leg_armature_kg_m2"]) {
        Err(RhexError::Unsupported { field, .. }) => assert_eq!(field, "leg_armature_kg_m2"),
        other => panic!("{:?}", other.map(|s| s.reason)),
    }
    let bare = Rhex::new(RhexParams {
        pairs: vec![LegPair::Front, LegPair::Rear],
        ..leap_params()
    })
    .unwrap();
    for p in [BodyParameter::Armature(0), BodyParameter::Armature(7)] {
        assert!(matches!(
            p.check(&bare.model),
            Err(TangentError::NotAParameter { .. })
        ));
    }
    // massless legs: the gear ratio is the torque line's alone, as before
    assert!(leap_with_sensitivity(&leap_params(), &LeapConfig::default(), &["gear_ratio"]).is_ok());
}

/// `leg_rotors` chooses who carries the rotors: `Some(true)` gives massless links the
/// armature `n J G²` of the leap's actuator (following its gear ratio, as `G²`), which makes
/// them links with inertia; `Some(false)` takes it from massive legs; together with a
/// hand-set armature it is a typed error naming the field.
#[test]
fn leg_rotors_puts_the_actuators_rotors_on_any_leg_or_none() {
    let with = |p: RhexParams, rotors: Option<bool>| RhexParams {
        leg_rotors: rotors,
        ..p
    };
    let q0 = simulate_leap(&leap_params(), &LeapConfig::default())
        .unwrap()
        .run
        .q0;
    for g in [20.0, 28.0, 45.0] {
        let cfg = geared(g, 2);
        let built = |p: &RhexParams| leap_scenario(p, &cfg, &q0).unwrap().rhex.model;
        // the armature's own definition: n J G² with the catalog's rotor
        let n_j = rotor_reflected_inertia(&leap_params(), &geared(1.0, 2)).unwrap();
        let a = n_j * g * g;
        let rotors = with(leap_params(), Some(true));
        assert!((leg_armature(&rotors, &cfg).unwrap() - a).abs() < 1e-15 * a.max(1.0));
        let model = built(&rotors);
        for j in 0..2 {
            assert_eq!(
                model.joints[j].armature_kg_m2,
                leg_armature(&rotors, &cfg).unwrap()
            );
            assert!(
                !model.distal_massless(j),
                "a massless link with rotors has inertia"
            );
            assert_eq!(model.joints[j].mass_kg, 0.0);
        }
        // massive legs without them: bare links
        let bare = with(massive(), Some(false));
        assert_eq!(leg_armature(&bare, &cfg).unwrap(), 0.0);
        assert!(built(&bare).joints.iter().all(|j| j.armature_kg_m2 == 0.0));
        // None: the default's choice, massive legs carry them and massless legs do not
        assert_eq!(
            leg_armature(&massive(), &cfg).unwrap(),
            leg_armature(&with(massive(), Some(true)), &cfg).unwrap()
        );
        assert_eq!(leg_armature(&leap_params(), &cfg).unwrap(), 0.0);
    }
    // a leap with massless links and rotors runs
    let rotors = with(leap_params(), Some(true));
    let r = simulate_leap(&rotors, &LeapConfig::default()).unwrap();
    assert!(r.apex.is_some(), "{:?}", r.status);
    let both = RhexParams {
        leg_armature_kg_m2: Some(0.01),
        ..with(leap_params(), Some(true))
    };
    match simulate_leap(&both, &LeapConfig::default()) {
        Err(RhexError::InvalidValue { field, .. }) => assert_eq!(field, "leg_rotors"),
        other => panic!("{:?}", other.map(|r| r.status)),
    }
}

/// A massive leg's servo, as the preset's interpreter runs it, is critically damped on the
/// leg's inertia about its hip as the core's `M̄` has it (the joint's diagonal entry: the
/// leg's own inertia plus its rotors' armature): `ζ = k_d / (2 √(k_p M̄_jj)) = 1`, with
/// `k_p = −∂τ/∂q`, `k_d = −∂τ/∂q̇` read off the controller's partials at the start (both legs
/// waiting, the toes on the ground: the servo holds them, inside its limit). Massless legs
/// keep the files' damping `kd_hold = 0.5 s/rad` per N m of stall torque.
#[test]
fn a_massive_legs_servo_is_critically_damped_on_its_mass_matrix_entry() {
    use rhex_model::leap::LeapPreset;
    for (params, critical) in [(massive(), true), (leap_params(), false)] {
        let cfg = LeapConfig::default();
        let preset = LeapPreset::new(&params, &cfg).unwrap();
        let stall = leg_actuator(&params, &cfg.actuator)
            .unwrap()
            .joint_torque_n_m(1.0, 0.0);
        // each leg in turn waits while the other one's motor runs: at t = 0.01 s, with its own
        // motor starting at 0.05 s
        for (t2, i) in [(0.05, 1), (-0.05, 0)] {
            let (sim, _) = preset.simulation(t2).unwrap();
            let model = &sim.model;
            let nq = model.nq();
            let mut data = Data::new(model);
            let zeros = vec![0.0; nq];
            energy(model, &mut data, &sim.q0, &zeros).unwrap();
            let mut out = selfmanip_hybrid::ControllerPartials::zeros(nq, nq, 0);
            // the toes on the ground too (a massless leg's servo acts only there)
            let mode = preset.leap.rhex.mode("1111").unwrap();
            assert!(sim
                .controller
                .partials(&ControlPoint::new(0.01, &sim.q0, &zeros, mode), &mut out));
            let (kp, kd) = (-out.dtau.dq[(i, i)], -out.dtau.dqd[(i, i)]);
            assert!((kp - 20.0 * stall).abs() < 1e-12 * kp, "leg {i}: kp {kp}");
            if critical {
                let zeta = kd / (2.0 * (kp * data.m_bar[(i, i)]).sqrt());
                assert!((zeta - 1.0).abs() < 1e-12, "leg {i}: ζ = {zeta}");
            } else {
                assert!((kd - 0.5 * stall).abs() < 1e-12 * kd, "leg {i}: kd {kd}");
            }
        }
    }
}
