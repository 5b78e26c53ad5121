//! Bad input gets typed errors, never a panic or a NaN.
mod common;
use common::*;
use proptest::prelude::*;
use selfmanip::core::quasistatic::quasi_static;
use selfmanip::core::{
    energy, forward_dynamics, plastic_impact, ContactMode, CoreError, Data, FlatGround,
    RobotDescription, SingularityKind,
};
use selfmanip::rhex::{LegShape, Rhex, RhexError, RhexParams};

/// The massless half-circle RHex, a workspace for it and a level pose `q` of it: where the
/// typed-error tests feed in their bad inputs.
fn massless_rhex_and_pose() -> (Rhex, Data, [f64; 5]) {
    let rhex = rhex_massless(LegShape::HalfCircle);
    let d = Data::new(&rhex.model);
    (rhex, d, [0.1, 0.1, 0.0, -0.17, 0.0])
}

/// A bad state: `(q, q̇, Υ)` and what the error must name.
type StateCase<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a str);

#[test]
fn non_finite_and_wrong_length_states() {
    let (rhex, mut d, q) = massless_rhex_and_pose();
    let m = &rhex.model;
    let mode = rhex.mode("0101").unwrap();
    let (rest, idle) = ([0.0; 5], [0.0; 2]);
    // (q, q̇, Υ) with one bad entry or length each, and what the error must name
    let cases: [StateCase<'_>; 5] = [
        (
            &[0.1, f64::NAN, 0.0, 0.0, 0.0],
            &rest,
            &idle,
            "q[1] not finite",
        ),
        (
            &q,
            &[0.0, 0.0, f64::INFINITY, 0.0, 0.0],
            &idle,
            "qd[2] not finite",
        ),
        (&q, &rest, &[f64::NAN, 0.0], "tau[0] not finite"),
        (&q[..4], &rest, &idle, "q: length 4, not 5"),
        (&q, &rest, &[0.0; 3], "tau: length 3, not 2"),
    ];
    for (q, qd, tau, expected) in cases {
        let e = forward_dynamics(m, &mut d, &FlatGround, mode, q, qd, tau, None).unwrap_err();
        assert_eq!(input_error(&e), expected);
    }
    let e = plastic_impact(m, &mut d, &FlatGround, mode, &q, &[0.0; 6]).unwrap_err();
    assert_eq!(input_error(&e), "qd: length 6, not 5");
}

/// What a typed input error names: the non-finite entry, or the length found and wanted.
fn input_error(e: &CoreError) -> String {
    match e {
        CoreError::NonFinite { field, index, .. } => format!("{field}[{index}] not finite"),
        CoreError::WrongLength {
            field,
            expected,
            actual,
        } => format!("{field}: length {actual}, not {expected}"),
        other => panic!("not an input error: {other:?}"),
    }
}

#[test]
fn over_constrained_mode_is_a_typed_singularity() {
    let rhex = rhex_massless(LegShape::HalfCircle);
    let mut d = Data::new(&rhex.model);
    let mode = rhex.mode("1111").unwrap(); // c = 6 > q = 5
    let e = forward_dynamics(
        &rhex.model,
        &mut d,
        &FlatGround,
        mode,
        &[0.1, 0.1, 0.0, -0.17, 0.0],
        &[0.0; 5],
        &[0.0; 2],
        None,
    );
    match e {
        Err(CoreError::SingularKkt {
            kind: SingularityKind::RedundantConstraints,
            condition_estimate,
        }) => {
            assert!(condition_estimate > 1e12, "{condition_estimate}")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn unconstrained_massless_motion_violates_lemma_5_1() {
    // A massless two-link leg touching with a sliding foot: the knee can fold with no
    // kinetic energy, so M̃ is singular (Lemma 5.1).
    let m = data_robot("robots/massless_two_link_leg.toml");
    let mode = ContactMode::parse_names(&m, "foot").unwrap();
    let mut d = Data::new(&m);
    let e = forward_dynamics(
        &m,
        &mut d,
        &FlatGround,
        mode,
        &[0.3, -0.6, 0.0, -0.3, 0.0],
        &[0.0; 5],
        &[0.0; 2],
        None,
    );
    assert!(
        matches!(
            e,
            Err(CoreError::SingularKkt {
                kind: SingularityKind::UnconstrainedMasslessMotion,
                ..
            })
        ),
        "{e:?}"
    );
}

#[test]
fn bad_descriptions_and_labels() {
    let base = RhexParams::default().description();
    let mut d = base.clone();
    d.body.mass_kg = -1.0;
    assert!(
        matches!(d.build(), Err(CoreError::InvalidDescription { field, .. }) if field == "body.mass_kg")
    );
    let mut d = base.clone();
    d.legs[0].links[0].length_m = f64::NAN;
    assert!(
        matches!(d.build(), Err(CoreError::InvalidDescription { field, .. }) if field == "legs[0].links[0].length_m")
    );
    let mut d = base.clone();
    d.contacts[0].leg = Some("nope".into());
    assert!(
        matches!(d.build(), Err(CoreError::InvalidDescription { field, .. }) if field == "contacts[0].leg")
    );
    assert!(matches!(
        RobotDescription::from_toml_str("name = 3"),
        Err(CoreError::Parse { .. })
    ));
    assert!(matches!(
        RobotDescription::from_json_str("{}"),
        Err(CoreError::Parse { format: "json", .. })
    ));

    let rhex = Rhex::chapter4();
    assert!(matches!(rhex.mode("010"), Err(RhexError::ModeLabel { .. })));
    assert!(matches!(
        rhex.mode("01x1"),
        Err(RhexError::ModeLabel { .. })
    ));
    assert!(
        matches!(rhex.mode("s101"), Err(RhexError::ModeLabel { .. })),
        "the body cannot be marked sliding"
    );
    assert!(matches!(
        Rhex::new(RhexParams { m_b: -7.0, ..RhexParams::default() }),
        Err(RhexError::InvalidValue { field, .. }) if field == "m_b"
    ));
    assert!(matches!(
        Rhex::new(RhexParams { pairs: vec![], ..RhexParams::default() }),
        Err(RhexError::InvalidValue { field, .. }) if field == "pairs"
    ));
    // a sliding-only contact cannot stick
    let m = &rhex.model;
    assert!(matches!(
        ContactMode::parse_names(m, "front_body:stick"),
        Err(CoreError::InvalidMode { .. })
    ));
    assert!(matches!(
        ContactMode::parse_names(m, "nose"),
        Err(CoreError::UnknownContact { .. })
    ));
    assert!(ContactMode::from_bits(0b01, 0b10).is_err());
}

/// Velocities or torques of 1e200–1e308 are finite but overflow the dynamics (`C̄q̇ ∝ q̇²`,
/// `½ q̇ᵀM̄q̇`, `P = −ΛAq̇`): a typed error naming what overflowed — never inf or NaN, and
/// never blamed on the inputs, which are finite.
#[test]
fn huge_velocities_and_torques_are_typed_overflow_errors() {
    let (rhex, mut d, q) = massless_rhex_and_pose();
    let m = &rhex.model;
    let mode = rhex.mode("0101").unwrap();
    let overflow = |r: Result<(), CoreError>| {
        matches!(r, Err(CoreError::NonFiniteResult { .. })) || {
            // a finite answer is fine too, if it is finite
            r.is_ok()
        }
    };
    for v in [1e200, 1e250, 1e308] {
        let qd = [v, -v, v, v, -v];
        let e = forward_dynamics(m, &mut d, &FlatGround, mode, &q, &qd, &[0.0; 2], None);
        assert!(
            matches!(e, Err(CoreError::NonFiniteResult { .. })),
            "q̇ = {v}: {e:?}"
        );
        assert!(!format!("{}", e.unwrap_err()).contains("`qd`"));
        let e = plastic_impact(m, &mut d, &FlatGround, mode, &q, &qd);
        assert!(
            matches!(e, Err(CoreError::NonFiniteResult { .. })),
            "impact at q̇ = {v}: {e:?}"
        );
        let e = energy(m, &mut d, &q, &qd);
        assert!(
            matches!(e, Err(CoreError::NonFiniteResult { .. })),
            "energy at q̇ = {v}: {e:?}"
        );
        let r = forward_dynamics(m, &mut d, &FlatGround, mode, &q, &[0.0; 5], &[v, -v], None);
        assert!(overflow(r.clone()), "τ = {v}: {r:?}");
        if r.is_ok() {
            assert!(d.qdd.iter().chain(d.lambda.iter()).all(|x| x.is_finite()));
        }
    }
    // ordinary values still work, and the checked energy is the one by hand
    let qd = [1.0, -2.0, 0.3, 0.2, 0.5];
    let (t, _) = energy(m, &mut d, &q, &qd).unwrap();
    let p = &rhex.params;
    let by_hand = 0.5 * p.m_b * (0.3f64.powi(2) + 0.2f64.powi(2)) + 0.5 * p.I_b * 0.25;
    assert!((t - by_hand).abs() < 1e-12, "{t} vs {by_hand}");
}

/// A body mass of 1e308 is finite, but its weight `m g` is not: a typed error, not a
/// non-finite `q̈` or `λ`.
#[test]
fn body_mass_of_1e308_is_a_typed_error_not_a_nan() {
    let rhex = Rhex::new(RhexParams {
        m_b: 1e308,
        ..RhexParams::default()
    })
    .unwrap();
    let m = &rhex.model;
    let mut d = Data::new(m);
    let e = forward_dynamics(
        m,
        &mut d,
        &FlatGround,
        rhex.mode("0101").unwrap(),
        &[0.1, 0.1, 0.0, -0.17, 0.0],
        &[0.0; 5],
        &[0.0; 2],
        None,
    );
    assert!(matches!(e, Err(CoreError::NonFiniteResult { .. })), "{e:?}");
}

/// Quasi-static forces need something to hold the robot: in flight (`0000`), or on a robot
/// with no contact sites at all, a typed error — not a panic.
#[test]
fn quasi_static_without_contacts_is_a_typed_error() {
    let (rhex, mut d, q) = massless_rhex_and_pose();
    let m = &rhex.model;
    let t = nalgebra::DMatrix::zeros(2, 0);
    let e = quasi_static(m, &mut d, &FlatGround, rhex.mode("0000").unwrap(), &q, &t);
    assert!(
        matches!(e, Err(CoreError::IllPosedQuasiStatic { .. })),
        "{e:?}"
    );
    let bare = RobotDescription::from_toml_str(
        "name = \"bare\"\n[body]\nmass_kg = 1.0\ninertia_kg_m2 = 0.1\n",
    )
    .unwrap()
    .build()
    .unwrap();
    let mut d = Data::new(&bare);
    let e = quasi_static(
        &bare,
        &mut d,
        &FlatGround,
        ContactMode::FLIGHT,
        &[0.0, -1.0, 0.0],
        &nalgebra::DMatrix::zeros(0, 0),
    );
    assert!(
        matches!(e, Err(CoreError::IllPosedQuasiStatic { .. })),
        "{e:?}"
    );
}

/// A planar vector is exactly two numbers: `hip_m = [0.2, 0.0, 99.0]` is a parse error that
/// names the field, not a hip at `[0.2, 0.0]` with the 99 dropped.
#[test]
fn toml_vector_with_three_entries_is_an_error_naming_its_field() {
    let with = |hip: &str, toe: &str| {
        format!(
            "name = \"one leg\"\n[body]\nmass_kg = 1.0\ninertia_kg_m2 = 0.1\n\
             [[legs]]\nname = \"leg\"\nhip_m = {hip}\n[[legs.links]]\nlength_m = 0.2\n\
             [[contacts]]\nname = \"toe\"\nleg = \"leg\"\n\
             shape = {{ kind = \"point\", position_m = {toe} }}\nfriction = {{ kind = \"sliding\" }}\n"
        )
    };
    assert!(RobotDescription::from_toml_str(&with("[0.2, 0.0]", "[0.0, 0.2]")).is_ok());
    for (hip, toe, field) in [
        ("[0.2, 0.0, 99.0]", "[0.0, 0.2]", "hip_m"),
        ("[0.2]", "[0.0, 0.2]", "hip_m"),
        ("[0.2, 0.0]", "[0.0, 0.2, 1.0]", "position_m"),
    ] {
        match RobotDescription::from_toml_str(&with(hip, toe)) {
            Err(CoreError::Parse { message, .. }) => {
                assert!(message.contains(field), "{hip} {toe}: {message}")
            }
            other => panic!("{hip} {toe}: {other:?}"),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    /// Any finite state in any mode gives either finite outputs or a typed error.
    #[test]
    fn never_nan_never_panic(
        q in proptest::collection::vec(-10.0f64..10.0, 5),
        qd in proptest::collection::vec(-50.0f64..50.0, 5),
        tau in proptest::collection::vec(-100.0f64..100.0, 2),
        bits in 0u32..16,
        massive in any::<bool>(),
    ) {
        let rhex = if massive { rhex_massive(LegShape::HalfCircle) } else { rhex_massless(LegShape::HalfCircle) };
        let label: String = (0..4).map(|i| if bits >> (3 - i) & 1 == 1 { '1' } else { '0' }).collect();
        let mode = rhex.mode(&label).unwrap();
        let mut d = Data::new(&rhex.model);
        match forward_dynamics(&rhex.model, &mut d, &FlatGround, mode, &q, &qd, &tau, None) {
            Ok(()) => {
                prop_assert!(d.qdd.iter().all(|x| x.is_finite()));
                prop_assert!(d.lambda.iter().all(|x| x.is_finite()));
            }
            Err(CoreError::SingularKkt { .. }) => {}
            Err(other) => prop_assert!(false, "unexpected error {other:?}"),
        }
    }
}
