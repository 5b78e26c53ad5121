//! The six-legged RHex (Table 4.2) as a spatial robot: the shipped URDF is the generator's,
//! its structure and massless legs, the contact Jacobian's drift of rolling C-legs and
//! rounded body ends by finite differences, and redundant (statically indeterminate) toe sets.
mod spatial_support;
use nalgebra::DVector;
use selfmanip_core::spatial::rhex::RhexSixLegs;
use selfmanip_core::spatial::*;
use spatial_support::*;

const RHEX6: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/urdf/rhex6.urdf"
);

/// The shipped `tests/data/urdf/rhex6.urdf` (Table 4.2's legs, for Pinocchio, which needs a
/// mass on every moving link) is what the generator writes; regenerate it with
/// `cargo test -p selfmanip-core --test spatial_rhex -- --ignored`.
#[test]
fn shipped_urdf_is_the_generators() {
    let text = RhexSixLegs::table_4_2()
        .with_table_4_2_legs()
        .urdf()
        .unwrap();
    let shipped = std::fs::read_to_string(RHEX6).unwrap();
    assert!(
        text == shipped,
        "tests/data/urdf/rhex6.urdf is stale: regenerate it"
    );
}

#[test]
#[ignore = "writes tests/data/urdf/rhex6.urdf"]
fn regenerate_shipped_urdf() {
    let text = RhexSixLegs::table_4_2()
        .with_table_4_2_legs()
        .urdf()
        .unwrap();
    std::fs::write(RHEX6, text).unwrap();
}

/// nq 13, nv 12, the hips in pair order, Table 4.2's masses (the URDF read back, not the
/// generator's numbers: 7.15 + 6 × 0.063 kg); with massless legs `M`'s six leg rows and
/// columns are exactly zero and the body block is `diag(m_b 1, I_b)` at the centre of mass.
#[test]
fn structure_and_massless_legs() {
    let p = RhexSixLegs::table_4_2().with_table_4_2_legs();
    let model = SpatialModel::from_urdf_file(RHEX6, BaseKind::FreeFlyer, None).unwrap();
    assert_eq!((model.nq, model.nv), (13, 12));
    let hips: Vec<String> = model.joints[1..].iter().map(|j| j.name.clone()).collect();
    let want: Vec<String> = rhex_legs().iter().map(|l| format!("{l}_hip")).collect();
    assert_eq!(hips, want);
    assert!((model.total_mass() - (7.15 + 6.0 * 0.063)).abs() < 1e-12);
    for l in rhex_legs() {
        for f in ["toe", "arc", "leg"] {
            model.frame_id(&format!("{l}_{f}")).unwrap();
        }
    }
    let massless = RhexSixLegs::table_4_2().model().unwrap();
    let mut data = SpatialData::new(&massless);
    let mut rng = rng(31);
    let q = random_q(&massless, &mut rng);
    rigid_body::crba(&massless, &mut data, q.as_slice()).unwrap();
    assert_eq!(data.M.columns(6, 6).amax(), 0.0);
    let body = data.M.view((0, 0), (6, 6));
    let diag = [
        7.15,
        7.15,
        7.15,
        p.body_roll_inertia_kg_m2,
        0.15,
        p.body_yaw_inertia_kg_m2,
    ];
    let want = nalgebra::DMatrix::from_diagonal(&DVector::from_column_slice(&diag));
    assert!((body - want).amax() < 1e-14);
}

/// `Ȧq̇` of every contact shape is the time derivative of `A q̇` along the motion: with
/// `q(t) = q ⊕ (v t + ½ a t²)` and `v(t) = v + a t`, `(A v)(±h)` by central differences is
/// `A a + Ȧq̇` to O(h²). Toes (points), C-legs rolling on their arcs and the rounded body
/// ends (circles), at random tumbling orientations where the arcs' axes tilt and the contact
/// point's direction `d` turns (`ḋ ≠ 0`).
#[test]
fn contact_drift_is_the_rate_of_the_rows() {
    let p = RhexSixLegs::table_4_2().with_table_4_2_legs();
    let (model, mut data, mut rng) = setup(p.model().unwrap(), 32);
    let contacts = vec![
        p.toe(&model, "front_left", true).unwrap(),
        p.leg_arc(&model, "middle_right", true).unwrap(),
        p.leg_arc(&model, "rear_left", false).unwrap(),
        p.body_end(&model, "front_right").unwrap(),
        p.toe(&model, "rear_right", true)
            .unwrap()
            .in_plane(nalgebra::Vector3::new(1.0, 0.3, 0.0))
            .unwrap(),
    ];
    let rows = |data: &mut SpatialData, q: &DVector<f64>, v: &DVector<f64>| {
        let tau = vec![0.0; model.nv];
        forward_dynamics(&model, data, &contacts, q.as_slice(), v.as_slice(), &tau).unwrap();
        (data.A.clone(), data.A_drift.clone())
    };
    let mut worst = 0.0f64;
    for _ in 0..20 {
        let (q, v, _) = random_state(&model, &mut rng);
        let a = random_vector(model.nv, 3.0, &mut rng);
        let (a0, drift) = rows(&mut data, &q, &v);
        let h = 1e-5;
        let at = |t: f64, data: &mut SpatialData| {
            let step = &v * t + &a * (0.5 * t * t);
            let qt = integrate(&model, q.as_slice(), step.as_slice()).unwrap();
            let vt = &v + &a * t;
            let (at, _) = rows(data, &qt, &vt);
            at * vt
        };
        let fd = (at(h, &mut data) - at(-h, &mut data)) / (2.0 * h);
        let exact = &a0 * &a + drift;
        worst = worst.max((fd - &exact).amax() / exact.amax().max(1.0));
    }
    eprintln!("|d/dt(A v) by differences − (A a + Ȧq̇)| {worst:.1e} (relative)");
    assert!(worst < 1e-7, "{worst}");
}

/// Statically indeterminate toe sets: the front and rear toes with friction (12 rows on the
/// body and four legs, rank ≤ 10; the middle legs, with mass, swing free), and with massless
/// legs all six toes held in the sagittal plane (rows `x`, `z`: 12 rows of rank 11, the body
/// free to slide sideways). The plastic impact gives `A q̇⁺ = 0`; from there (a state the
/// contacts allow) `q̈` is unique and solves the constraints, the equations of motion hold,
/// and `λ` has no component in `ker Aᵀ` (the minimum-norm forces). At rates the redundant
/// rows contradict (`A v ≠ 0`) the drift leaves `A`'s range: the typed redundant-constraints
/// error.
#[test]
fn redundant_toes_give_the_unique_motion_and_minimum_norm_forces() {
    let massive = RhexSixLegs::table_4_2().with_table_4_2_legs();
    let massless = RhexSixLegs::table_4_2();
    let four = ["front_left", "front_right", "rear_left", "rear_right"];
    for (p, legs, in_plane) in [
        (massive, four.map(String::from).to_vec(), false),
        (massless, rhex_legs(), true),
    ] {
        let model = p.model().unwrap();
        let mut data = SpatialData::new(&model);
        let contacts: Vec<_> = legs
            .iter()
            .map(|l| {
                let toe = p.toe(&model, l, true).unwrap();
                if in_plane {
                    toe.in_plane(nalgebra::Vector3::x()).unwrap()
                } else {
                    toe
                }
            })
            .collect();
        let mut rng = rng(33);
        let (mut w_acc, mut w_eom, mut w_null, mut w_imp) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for _ in 0..10 {
            let (q, v_minus, tau) = random_state(&model, &mut rng);
            let err = dynamics_at(&model, &mut data, &contacts, (&q, &v_minus, &tau)).unwrap_err();
            assert!(
                matches!(
                    err,
                    SpatialError::Core(selfmanip_core::CoreError::SingularKkt {
                        kind: selfmanip_core::SingularityKind::RedundantConstraints,
                        ..
                    })
                ),
                "{err:?}"
            );
            let imp = impact(
                &model,
                &mut data,
                &contacts,
                q.as_slice(),
                v_minus.as_slice(),
            )
            .unwrap();
            w_imp = w_imp.max((&data.A * &imp.v_plus).amax() / v_minus.amax());
            let v = imp.v_plus;
            dynamics_at(&model, &mut data, &contacts, (&q, &v, &tau)).unwrap();
            assert!(data.row_basis.is_some(), "the rows are redundant");
            assert!(
                v.amax() > 1e-2 && data.qdd.amax() > 1e-2,
                "a motion: {v} {}",
                data.qdd
            );
            let (acc, eom) = dynamics_residuals(&data, &tau);
            (w_acc, w_eom) = (w_acc.max(acc), w_eom.max(eom));
            // orthogonal to ker Aᵀ ⟺ in A's range: λ equals its projection there (an
            // independent SVD)
            let svd = data.A.clone().svd(true, false);
            let u = svd.u.unwrap();
            let top = svd.singular_values.max();
            let mut projected = DVector::zeros(data.lam.len());
            for k in 0..svd.singular_values.len() {
                if svd.singular_values[k] > 1e-9 * top {
                    projected += u.column(k) * u.column(k).dot(&data.lam);
                }
            }
            w_null = w_null.max((&data.lam - projected).amax() / data.lam.amax());
        }
        eprintln!(
            "{} toe contacts (legs {} kg): |A q̈ + Ȧq̇| {w_acc:.1e}, |EOM| {w_eom:.1e}, |λ·ker Aᵀ| {w_null:.1e}, |A q̇⁺| {w_imp:.1e}",
            contacts.len(),
            p.leg_mass_kg
        );
        assert!(w_acc < 1e-12 && w_eom < 1e-12 && w_null < 1e-12 && w_imp < 1e-12);
    }
}

/// Bad parameters and contact shapes are typed errors naming the field.
#[test]
fn bad_input_names_the_field() {
    let field = |e: SpatialError| match e {
        SpatialError::InvalidArgument { field, .. } => field,
        other => panic!("{other:?}"),
    };
    let bad = |f: fn(&mut RhexSixLegs)| {
        let mut p = RhexSixLegs::table_4_2();
        f(&mut p);
        field(p.model().unwrap_err())
    };
    assert_eq!(bad(|p| p.leg_mass_kg = -0.1), "leg_mass_kg");
    assert_eq!(bad(|p| p.hip_half_width_m = 0.0), "hip_half_width_m");
    assert_eq!(
        bad(|p| p.body_pitch_inertia_kg_m2 = f64::NAN),
        "body_pitch_inertia_kg_m2"
    );
    let model = RhexSixLegs::table_4_2().model().unwrap();
    let toe = PointContact::new(&model, "front_left_toe", true).unwrap();
    assert_eq!(
        field(
            toe.clone()
                .on_circle(-1.0, nalgebra::Vector3::y())
                .unwrap_err()
        ),
        "radius_m"
    );
    assert_eq!(
        field(
            toe.clone()
                .on_circle(0.1, nalgebra::Vector3::zeros())
                .unwrap_err()
        ),
        "axis"
    );
    assert_eq!(
        field(toe.clone().in_plane(nalgebra::Vector3::z()).unwrap_err()),
        "tangent"
    );
    assert!(matches!(
        toe.in_plane(nalgebra::Vector3::new(f64::NAN, 0.0, 0.0))
            .unwrap_err(),
        SpatialError::Core(selfmanip_core::CoreError::NonFinite {
            field: "tangent",
            ..
        })
    ));
}
