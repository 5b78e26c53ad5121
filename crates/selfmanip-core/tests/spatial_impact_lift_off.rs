//! Contacts leaving the ground in a plastic impact (`Separation::Allowed`), and the split of
//! redundant rows' impulse, each against an independent route: a table tipping onto one edge
//! whose impact lifts the other edge (the impulses of the Newton–Euler equations of one rigid
//! body solved by hand, and its energy loss), the conservation of the angular momentum about
//! the edge the table lands on (impulses on a line have no moment about it), and a table
//! skidding onto four feet whose least-norm split leaves a cone that another split satisfies
//! (the body stops: the impulses' sum and moment are the momenta it had).
mod spatial_support;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use selfmanip_core::spatial::rigid_body::crba;
use selfmanip_core::spatial::*;
use spatial_support::rng;

/// A table: a box top of mass `M_KG` whose centre of mass is the base's origin, and four
/// massless feet `HZ` below it at `(x, y)`.
const M_KG: f64 = 4.0;
const HZ: f64 = 0.3;
/// The top's principal inertia (kg m²): a 1.0 × 1.0 × 0.05 m box of `M_KG`.
fn top_inertia() -> Vector3<f64> {
    let (a, b, c) = (1.0f64, 1.0f64, 0.05f64);
    Vector3::new(b * b + c * c, a * a + c * c, a * a + b * b) * (M_KG / 12.0)
}

fn table(feet: &[(f64, f64); 4]) -> SpatialModel {
    let i = top_inertia();
    let mut urdf = format!(
        r#"<robot name="table"><link name="top"><inertial><origin xyz="0 0 0"/><mass value="{M_KG}"/><inertia ixx="{}" ixy="0" ixz="0" iyy="{}" iyz="0" izz="{}"/></inertial></link>"#,
        i.x, i.y, i.z
    );
    for (k, (x, y)) in feet.iter().enumerate() {
        urdf += &format!(
            r#"<link name="foot{k}"/><joint name="leg{k}" type="fixed"><parent link="top"/><child link="foot{k}"/><origin xyz="{x} {y} {}"/></joint>"#,
            -HZ
        );
    }
    urdf += "</robot>";
    SpatialModel::from_urdf_str(&urdf, BaseKind::FreeFlyer, None).unwrap()
}

/// The table level with its feet on the ground (`z = HZ`), twist `[v; ω]` (body = world axes).
fn level(model: &SpatialModel, v: Vector3<f64>, w: Vector3<f64>) -> (DVector<f64>, DVector<f64>) {
    let mut q = neutral(model);
    q[2] = HZ;
    let mut rates = DVector::zeros(6);
    rates.fixed_rows_mut::<3>(0).copy_from(&v);
    rates.fixed_rows_mut::<3>(3).copy_from(&w);
    (q, rates)
}

/// The impact of `model` into `contacts` at `(q, q̇⁻)`.
fn land(
    model: &SpatialModel,
    contacts: &[PointContact],
    (q, rates): (&DVector<f64>, &DVector<f64>),
    separation: Separation,
) -> SpatialResult<SpatialImpact> {
    let mut data = SpatialData::new(model);
    impact_with(
        model,
        &mut data,
        contacts,
        q.as_slice(),
        rates.as_slice(),
        separation,
    )
}

fn rel(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    (a - b).amax() / b.amax().max(1e-300)
}

/// The velocity change of the table's point `r` (from the centre of mass) per unit impulse at
/// the point `s`: `W(r, s) = (1/m) 𝟙 − [r]× I⁻¹ [s]×` (Newton–Euler of one rigid body).
fn response(r: Vector3<f64>, s: Vector3<f64>) -> Matrix3<f64> {
    let inv_i = Matrix3::from_diagonal(&top_inertia().map(|x| 1.0 / x));
    Matrix3::identity() / M_KG - r.cross_matrix() * inv_i * s.cross_matrix()
}

const TIP_FEET: [(f64, f64); 4] = [(0.3, -0.2), (-0.3, -0.2), (0.3, 0.2), (-0.3, 0.2)];

/// The table comes down (`v_z = −1`, skidding) rolling onto its `y = −0.2` edge (`ω_x = 3`,
/// some pitch and yaw): all four feet approach, the low edge at 1.6 m/s, the other at 0.4. The
/// impulse on the low edge alone (frictionless: `W_nn P = −v_n⁻` on its two feet, by hand from
/// [`response`]) lifts the other edge (its feet's `v_n⁺ > 0`, wide top, feet inset: the top's
/// roll inertia exceeds `m y²`), so that is the outcome, unique, with energy loss
/// `½ v⁻ᵀ W_nn⁻¹ v⁻`; holding all four feet ((5.10)) pulls on the high edge.
#[test]
#[allow(non_snake_case)]
fn table_tipping_onto_one_edge_lifts_the_other() {
    let model = table(&TIP_FEET);
    let mut data = SpatialData::new(&model);
    let (v, w) = (Vector3::new(0.3, 0.1, -1.0), Vector3::new(3.0, 0.4, 0.2));
    let (q, rates) = level(&model, v, w);
    let arm = |k: usize| Vector3::new(TIP_FEET[k].0, TIP_FEET[k].1, -HZ);
    let contacts: Vec<PointContact> = (0..4)
        .map(|k| PointContact::new(&model, &format!("foot{k}"), false).unwrap())
        .collect();
    // by hand: the two low feet's normal impulses
    let z = Vector3::z();
    let v_n = |k: usize| (v + w.cross(&arm(k))).z;
    let W = nalgebra::Matrix2::from_fn(|i, j| (response(arm(i), arm(j)) * z).z);
    let v_low = nalgebra::Vector2::new(v_n(0), v_n(1));
    let P = -W.try_inverse().unwrap() * v_low;
    let (dv, dw) = (
        z * (P[0] + P[1]) / M_KG,
        Matrix3::from_diagonal(&top_inertia().map(|x| 1.0 / x))
            * (arm(0).cross(&(z * P[0])) + arm(1).cross(&(z * P[1]))),
    );
    let (v_plus, w_plus) = (v + dv, w + dw);
    let lift: Vec<f64> = (2..4).map(|k| (v_plus + w_plus.cross(&arm(k))).z).collect();
    assert!(
        P.iter().all(|&p| p > 0.0) && lift.iter().all(|&u| u > 0.1),
        "{P} {lift:?}"
    );
    let out = land(&model, &contacts, (&q, &rates), Separation::Allowed).unwrap();
    use ImpactState::*;
    assert_eq!(out.states, [Frictionless, Frictionless, Separate, Separate]);
    let want_v = DVector::from_iterator(6, v_plus.iter().chain(w_plus.iter()).copied());
    let want_p = DVector::from_column_slice(&[P[0], P[1], 0.0, 0.0]);
    let (gap_v, gap_p) = (rel(&out.v_plus, &want_v), rel(&out.impulse, &want_p));
    // the energy lost, by the library's M, against ½ v⁻ᵀ W⁻¹ v⁻
    crba(&model, &mut data, q.as_slice()).unwrap();
    let energy = |r: &DVector<f64>| 0.5 * r.dot(&(&data.M * r));
    let lost = energy(&rates) - energy(&out.v_plus);
    let want_lost = 0.5 * v_low.dot(&(W.try_inverse().unwrap() * v_low));
    let gap_e = (lost - want_lost).abs() / want_lost;
    eprintln!(
        "tipping table: P = {:.4} {:.4} N s, high edge lifts at {:.4} {:.4} m/s, energy lost \
         {lost:.4} J; |ours − by hand| v⁺ {gap_v:.1e}, P {gap_p:.1e}, ΔT {gap_e:.1e}",
        P[0], P[1], lift[0], lift[1]
    );
    assert!(gap_v < 1e-12 && gap_p < 1e-12 && gap_e < 1e-12);
    // holding every foot ((5.10)) pulls the high edge down
    let held = impact(&model, &mut data, &contacts, q.as_slice(), rates.as_slice()).unwrap();
    assert!(
        held.impulse[2] < 0.0 && held.impulse[3] < 0.0,
        "{}",
        held.impulse
    );
}

/// The landing at random rates with friction on every foot (sticking, `μ = ∞`, and a cone
/// `μ = 0.9`): the low edge's two feet are held (six rows on a line when they stick: five
/// independent, the impulse along the edge split), the high edge lifts, the sticking feet
/// stop, and the angular momentum about the edge, `x̂ · ((c − p) × m v + I ω)` with `p` on
/// it, is what it was before (to round-off).
#[test]
fn angular_momentum_about_the_edge_landed_on_is_conserved() {
    let model = table(&TIP_FEET);
    let mut rng = rng(91);
    let (mut worst, mut stuck) = (0.0f64, 0);
    for mu in [f64::INFINITY, 0.9] {
        for _ in 0..5 {
            use rand::Rng;
            let v = Vector3::new(rng.gen_range(-0.3..0.3), rng.gen_range(-0.1..0.1), -1.0);
            let w = Vector3::new(rng.gen_range(3.5..4.5), rng.gen_range(-0.3..0.3), 0.2);
            let (q, rates) = level(&model, v, w);
            let contacts: Vec<PointContact> = (0..4)
                .map(|k| {
                    let c = PointContact::new(&model, &format!("foot{k}"), true).unwrap();
                    if mu.is_finite() {
                        c.with_impact_friction(mu).unwrap()
                    } else {
                        c
                    }
                })
                .collect();
            let out = land(&model, &contacts, (&q, &rates), Separation::Allowed).unwrap();
            let held = |s: &ImpactState| *s != ImpactState::Separate;
            assert!(
                out.states[..2].iter().all(held) && !out.states[2..].iter().any(held),
                "μ = {mu}: {:?}",
                out.states
            );
            stuck += out
                .states
                .iter()
                .filter(|s| **s == ImpactState::Stick)
                .count();
            let momentum = |r: &DVector<f64>| {
                let (v, w) = (r.fixed_rows::<3>(0), r.fixed_rows::<3>(3));
                let c_minus_p = Vector3::new(0.0, 0.2, HZ);
                (c_minus_p.cross(&(v * M_KG)) + top_inertia().component_mul(&w.into_owned())).x
            };
            let (before, after) = (momentum(&rates), momentum(&out.v_plus));
            worst = worst.max((after - before).abs() / before.abs());
            // the sticking feet stop
            for k in (0..2).filter(|&k| out.states[k] == ImpactState::Stick) {
                let r = Vector3::new(TIP_FEET[k].0, TIP_FEET[k].1, -HZ);
                let (v, w) = (
                    out.v_plus.fixed_rows::<3>(0).into_owned(),
                    out.v_plus.fixed_rows::<3>(3).into_owned(),
                );
                assert!((v + w.cross(&r)).amax() < 1e-12, "foot {k}");
            }
        }
    }
    eprintln!(
        "edge landing: {stuck} of 20 low feet stick; |Δ angular momentum about the edge| \
         (relative) {worst:.1e}"
    );
    assert!(worst < 1e-13 && stuck >= 10, "{worst}");
}

/// Feet of the skidding table: two at `x = −0.05`, two at `x = 0.6` (the centre of mass near
/// the back edge).
const SKID_FEET: [(f64, f64); 4] = [(-0.05, -0.3), (-0.05, 0.3), (0.6, -0.3), (0.6, 0.3)];

/// The table lands flat on four sticking feet (`μ = 0.5`) skidding forward (`v = (0.4, 0, −1)`,
/// no rotation): twelve rows on six rates. Four non-collinear points stopping stop the body,
/// so `q̇⁺ = 0` and the impulses' sum and moment about the centre of mass are `−m v` and 0.
/// The normal impulses are fixed by that moment (the front feet carry little), and the
/// least-norm tangential split (`G⁺ w`, computed here from the wrench map) puts a front foot
/// outside its cone; splitting the tangential impulse as the normal one (`|P_t|/P_n = 0.4`)
/// passes, so the impact sticks: the model's split has the impulses' sum and moment, every
/// foot in its cone, and a norm no smaller than the least-norm split's.
#[test]
#[allow(non_snake_case)]
fn four_feet_skidding_split_the_impulse_inside_their_cones() {
    let model = table(&SKID_FEET);
    let (v, w) = (Vector3::new(0.4, 0.0, -1.0), Vector3::zeros());
    let (q, rates) = level(&model, v, w);
    let mu = 0.5;
    let contacts: Vec<PointContact> = (0..4)
        .map(|k| {
            PointContact::new(&model, &format!("foot{k}"), true)
                .unwrap()
                .with_impact_friction(mu)
                .unwrap()
        })
        .collect();
    let arm = |k: usize| Vector3::new(SKID_FEET[k].0, SKID_FEET[k].1, -HZ);
    // the wrench map G (6 × 12): impulses at the feet → (force, moment about the centre of mass)
    let G = DMatrix::from_fn(6, 12, |r, c| {
        let (k, axis) = (c / 3, Vector3::ith(c % 3, 1.0));
        let f = if r < 3 { axis } else { arm(k).cross(&axis) };
        f[r % 3]
    });
    let wrench =
        DVector::from_column_slice(&[-M_KG * v.x, -M_KG * v.y, -M_KG * v.z, 0.0, 0.0, 0.0]);
    let least = G.clone().pseudo_inverse(1e-12).unwrap() * &wrench;
    let cone_excess = |p: &DVector<f64>| {
        (0..4)
            .map(|k| p.fixed_rows::<2>(3 * k).norm() - mu * p[3 * k + 2])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    assert!(
        cone_excess(&least) > 0.01,
        "the least-norm split leaves a cone"
    );
    for separation in [Separation::Forbidden, Separation::Allowed] {
        let out = land(&model, &contacts, (&q, &rates), separation).unwrap();
        assert!(
            out.states.iter().all(|s| *s == ImpactState::Stick),
            "{:?}",
            out.states
        );
        let stop = out.v_plus.amax();
        let balance = (&G * &out.impulse - &wrench).amax() / wrench.amax();
        let excess = cone_excess(&out.impulse) / out.impulse.amax();
        eprintln!(
            "skidding table ({separation:?}): |q̇⁺| {stop:.1e}, |G P − (−m v, 0)| {balance:.1e}, \
             cone excess {excess:.1e} (least-norm split's {:.3}), |P| {:.4} vs least-norm {:.4}",
            cone_excess(&least),
            out.impulse.norm(),
            least.norm()
        );
        assert!(stop < 1e-12 && balance < 1e-12 && excess < 1e-9);
        assert!(out.impulse.norm() >= least.norm() * (1.0 - 1e-12));
    }
}

/// More combinations of states than the enumeration's bound is a typed error naming `contacts`.
#[test]
fn too_many_contacts_to_enumerate_name_contacts() {
    let model = table(&TIP_FEET);
    let (q, rates) = level(&model, Vector3::new(0.0, 0.0, -1.0), Vector3::zeros());
    // 4 × 4 × … cones in a plane: 4⁷ > MAX_COMBINATIONS
    let c = PointContact::new(&model, "foot0", true)
        .unwrap()
        .in_plane(Vector3::x())
        .unwrap()
        .with_impact_friction(0.5)
        .unwrap();
    let many = vec![c; 7];
    let e = land(&model, &many, (&q, &rates), Separation::Allowed).unwrap_err();
    assert!(
        matches!(&e, SpatialError::InvalidArgument { field, .. } if field == "contacts"),
        "{e}"
    );
    assert!(4usize.pow(7) > MAX_COMBINATIONS && 4usize.pow(6) <= MAX_COMBINATIONS);
}
