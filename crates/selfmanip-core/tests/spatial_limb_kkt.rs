#![allow(non_snake_case)]
//! The limb elimination (`spatial::limb_kkt`: a limb's rates fixed by as many contact rows,
//! the base's by a reduced `Nᵀ M N`) against a second route, the full KKT matrix
//! `[M Aᵀ; A 0]` solved densely by LU, on the contact sets where it applies — the quadruped
//! on four, three and two feet with friction (swing legs keep their rates), bolted down, an
//! impact, the six-legged RHex on its toes, a robot with prismatic and fixed joints held in a
//! plane — and, where it does not apply (frictionless feet on three-joint legs, a contact on
//! the trunk, a nearly stretched leg, massless shins), that the engine takes the other routes
//! and still satisfies the equations.
mod spatial_support;
use nalgebra::{DMatrix, DVector, Vector3};
use selfmanip_core::spatial::rhex::RhexSixLegs;
use selfmanip_core::spatial::*;
use spatial_support::*;

/// `[x; y]` of `[M Aᵀ; A 0][x; y] = [f; g]` by a dense LU of the whole matrix, refined three
/// times with residuals summed in doubled precision ([`residual`]): the exact solution of the
/// rounded system to a few ulps wherever its condition is well below 1e16 (an ill-conditioned
/// contact set, RHex's tripod with friction at about 1e7, leaves a plain LU's `λ` 1e-9 off).
fn dense_kkt(
    M: &DMatrix<f64>,
    A: &DMatrix<f64>,
    f: &DVector<f64>,
    g: &DVector<f64>,
) -> (DVector<f64>, DVector<f64>) {
    let (nv, c) = (M.nrows(), A.nrows());
    let mut kkt = DMatrix::zeros(nv + c, nv + c);
    kkt.view_mut((0, 0), (nv, nv)).copy_from(M);
    kkt.view_mut((nv, 0), (c, nv)).copy_from(A);
    kkt.view_mut((0, nv), (nv, c)).copy_from(&A.transpose());
    let mut rhs = DVector::zeros(nv + c);
    rhs.rows_mut(0, nv).copy_from(f);
    rhs.rows_mut(nv, c).copy_from(g);
    let lu = kkt.clone().lu();
    let mut x = lu.solve(&rhs).expect("a regular KKT matrix");
    for _ in 0..3 {
        x += lu.solve(&residual(&kkt, &x, &rhs)).expect("regular");
    }
    (x.rows(0, nv).into_owned(), x.rows(nv, c).into_owned())
}

/// `b − K x`, each entry summed exactly in two parts (Dekker's product by `mul_add`, Knuth's
/// sum) and rounded once.
fn residual(K: &DMatrix<f64>, x: &DVector<f64>, b: &DVector<f64>) -> DVector<f64> {
    DVector::from_fn(K.nrows(), |i, _| {
        let (mut hi, mut lo) = (b[i], 0.0);
        for j in 0..K.ncols() {
            let p = -K[(i, j)] * x[j];
            let e = (-K[(i, j)]).mul_add(x[j], -p);
            let s = hi + p;
            let v = s - hi;
            lo += (hi - (s - v)) + (p - v) + e;
            hi = s;
        }
        hi + lo
    })
}

fn rel(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    (a - b).amax() / b.amax().max(1.0)
}

/// The largest relative difference of `q̈`, `λ` (and, with `impacts`, of the plastic impact's
/// `v⁺` and impulse) from [`dense_kkt`] over `n` random states of `model` on `contacts`,
/// asserting each solve took the limb elimination.
fn worst_against_dense(
    model: &SpatialModel,
    contacts: &[PointContact],
    seed: u64,
    n: usize,
    impacts: bool,
) -> f64 {
    let mut data = SpatialData::new(model);
    let mut rng = rng(seed);
    let mut worst: f64 = 0.0;
    for _ in 0..n {
        let (q, v, tau) = random_state(model, &mut rng);
        dynamics_at(model, &mut data, contacts, (&q, &v, &tau)).unwrap();
        assert!(data.limbs_eliminated);
        assert_eq!(data.kkt_route, KktRoute::RangeSpace);
        let (qdd, y) = dense_kkt(&data.M, &data.A, &(&tau - &data.h), &(-&data.A_drift));
        worst = worst.max(rel(&data.qdd, &qdd)).max(rel(&data.lam, &(-&y)));
        if impacts {
            let imp = impact(model, &mut data, contacts, q.as_slice(), v.as_slice()).unwrap();
            assert!(data.limbs_eliminated);
            let (dv, y) = dense_kkt(
                &data.M,
                &data.A,
                &DVector::zeros(model.nv),
                &(-&data.A * &v),
            );
            worst = worst
                .max(rel(&imp.v_plus, &(&v + dv)))
                .max(rel(&imp.impulse, &(-y)));
        }
    }
    worst
}

/// [`worst_against_dense`] over `cases` (contacts, seed, states, with impacts), asserted
/// below 1e-10.
fn assert_agrees(model: &SpatialModel, cases: &[(&[PointContact], u64, usize, bool)]) {
    let worst = cases
        .iter()
        .map(|&(contacts, seed, n, impacts)| worst_against_dense(model, contacts, seed, n, impacts))
        .fold(0.0, f64::max);
    assert!(worst < 1e-10, "routes differ by {worst:e}");
}

#[test]
fn quadruped_on_its_feet_matches_the_dense_kkt_solve() {
    let model = quadruped();
    // four feet (every limb pinned), three and two (swing legs keep their rates)
    let four = feet(&model, [true; 4]);
    let two = [four[0].clone(), four[3].clone()];
    assert_agrees(
        &model,
        &[
            (&four, 43, 20, true),
            (&four[..3], 47, 10, false),
            (&two, 47, 10, false),
        ],
    );
}

/// On a fixed base no rate is left to the reduced system when every leg is pinned (`R` is
/// empty): the rows alone give `q̈`; with one leg free, `R` is that leg's block of `M`.
#[test]
fn bolted_down_quadruped_matches_the_dense_kkt_solve() {
    let model = SpatialModel::from_urdf_file(QUADRUPED, BaseKind::Fixed, None).unwrap();
    let four = feet(&model, [true; 4]);
    assert_agrees(
        &model,
        &[(&four, 53, 10, false), (&four[1..], 59, 10, false)],
    );
}

/// RHex's one-joint legs on frictionless toes (one row each): six toes, and four with two
/// legs in the air.
#[test]
fn rhex_toes_pin_their_one_joint_legs() {
    let p = RhexSixLegs::table_4_2().with_table_4_2_legs();
    let model = p.model().unwrap();
    let toes: Vec<PointContact> = rhex_legs()
        .iter()
        .map(|leg| p.toe(&model, leg, false).unwrap())
        .collect();
    assert_agrees(
        &model,
        &[(&toes, 61, 10, true), (&toes[..4], 67, 10, false)],
    );
}

/// A free-flying box on two legs, each a revolute hip and a prismatic shank carrying its foot
/// on a fixed joint (the right leg the left one mirrored): a foot held in the sagittal plane (two
/// rows) pins its two-rate leg.
fn biped() -> String {
    let links = |side: &str| {
        format!(
            r#"
  <link name="{side}_thigh"><inertial><origin xyz="0 0 -0.1"/><mass value="0.6"/>
    <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.001"/></inertial></link>
  <link name="{side}_shank"><inertial><origin xyz="0 0 -0.1"/><mass value="0.3"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.0005"/></inertial></link>
  <link name="{side}_foot"/>"#
        )
    };
    let joints = |side: &str, y: &str| {
        format!(
            r#"
  <joint name="{side}_hip" type="revolute"><parent link="body"/><child link="{side}_thigh"/>
    <origin xyz="0 {y} -0.05"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="10"/></joint>
  <joint name="{side}_slide" type="prismatic"><parent link="{side}_thigh"/><child link="{side}_shank"/>
    <origin xyz="0 0 -0.2"/><axis xyz="0 0 1"/><limit lower="-0.1" upper="0.1" effort="10" velocity="10"/></joint>
  <joint name="{side}_toe" type="fixed"><parent link="{side}_shank"/><child link="{side}_foot"/>
    <origin xyz="0.02 0 -0.2"/></joint>"#
        )
    };
    format!(
        r#"<robot name="biped">
  <link name="body"><inertial><origin xyz="0.01 0 0.02"/><mass value="5"/>
    <inertia ixx="0.05" ixy="0.001" ixz="0" iyy="0.08" iyz="0" izz="0.1"/></inertial></link>{}{}{}{}
</robot>"#,
        links("L"),
        links("R"),
        joints("L", "0.1"),
        joints("R", "-0.1")
    )
}

#[test]
fn prismatic_and_fixed_joints_pinned_in_a_plane() {
    let model = SpatialModel::from_urdf_str(&biped(), BaseKind::FreeFlyer, None).unwrap();
    assert_eq!(model.nv, 10);
    let contacts: Vec<PointContact> = ["L_foot", "R_foot"]
        .iter()
        .map(|f| {
            PointContact::new(&model, f, true)
                .unwrap()
                .in_plane(Vector3::x())
                .unwrap()
        })
        .collect();
    assert_agrees(
        &model,
        &[(&contacts, 71, 20, true), (&contacts[..1], 73, 10, false)],
    );
}

/// `forward_dynamics` at one random state of `model` on `contacts`: whether the limb
/// elimination took it, the route, and the relative residuals of the constraint and the
/// equations of motion.
fn route_at(
    model: &SpatialModel,
    contacts: &[PointContact],
    q: &DVector<f64>,
) -> (bool, KktRoute, f64, f64) {
    let mut data = SpatialData::new(model);
    let mut rng = rng(79);
    let (_, v, tau) = random_state(model, &mut rng);
    dynamics_at(model, &mut data, contacts, (q, &v, &tau)).unwrap();
    let (acc, eom) = dynamics_residuals(&data, &tau);
    (data.limbs_eliminated, data.kkt_route, acc, eom)
}

#[test]
fn other_contact_sets_take_the_other_routes() {
    let model = quadruped();
    let q = random_q(&model, &mut rng(83));
    let with = |extra: PointContact| {
        let mut c = feet(&model, [true; 4]);
        c.push(extra);
        c
    };
    let cases: [(&str, Vec<PointContact>, &SpatialModel, KktRoute); 4] = [
        // one row on a three-joint leg
        (
            "frictionless feet",
            feet(&model, [true, false, true, true]),
            &model,
            KktRoute::RangeSpace,
        ),
        // a row with no entry on any limb
        (
            "a contact on the trunk",
            with(PointContact::new(&model, "trunk", false).unwrap()),
            &model,
            KktRoute::RangeSpace,
        ),
        // four rows on one leg
        (
            "a knee and its foot",
            with(PointContact::new(&model, "FL_knee", false).unwrap()),
            &model,
            KktRoute::RangeSpace,
        ),
        ("massless shins", Vec::new(), &model, KktRoute::NullSpace),
    ];
    let shins = quadruped_massless_shins();
    for (name, contacts, model, route) in cases {
        let (model, contacts) = if name == "massless shins" {
            (&shins, feet(&shins, [true; 4]))
        } else {
            (model, contacts)
        };
        let (limbs, taken, acc, eom) = route_at(model, &contacts, &q);
        assert!(!limbs, "{name}: the limb elimination should decline");
        assert_eq!(taken, route, "{name}");
        assert!(acc < 1e-10 && eom < 1e-10, "{name}: {acc:e} {eom:e}");
    }
}

/// A leg nearly stretched (knee 1e-8 rad: its foot's rows nearly dependent on the hip's
/// flexion and the knee) makes a pivot of its `A_ll` fall below `LIMB_PIVOT_FRACTION`: the
/// elimination declines; bent by 1e-3 rad it applies and agrees with the dense solve.
#[test]
fn a_nearly_stretched_leg_declines_the_elimination() {
    let model = quadruped();
    let contacts = feet(&model, [true; 4]);
    let mut q = standing_q(&model, 0.4, 0.5);
    let mut data = SpatialData::new(&model);
    let mut rng = rng(89);
    let (_, v, tau) = random_state(&model, &mut rng);
    for (knee, applies) in [(1e-8, false), (1e-3, true)] {
        q[7 + 2] = knee;
        dynamics_at(&model, &mut data, &contacts, (&q, &v, &tau)).unwrap();
        assert_eq!(data.limbs_eliminated, applies, "knee {knee}");
        let (qdd, y) = dense_kkt(&data.M, &data.A, &(&tau - &data.h), &(-&data.A_drift));
        // the dense LU's own error grows with the rows' condition, about 1/knee
        let tol = 1e-12 / knee;
        let e = rel(&data.qdd, &qdd).max(rel(&data.lam, &(-y)));
        assert!(e < tol, "knee {knee}: routes differ by {e:e}");
    }
}

/// RHex's toes on the legs `legs` (indices into [`rhex_legs`]), with friction where
/// `friction`.
fn rhex_toes(p: &RhexSixLegs, model: &SpatialModel, legs: &[(usize, bool)]) -> Vec<PointContact> {
    let names = rhex_legs();
    legs.iter()
        .map(|&(i, friction)| p.toe(model, &names[i], friction).unwrap())
        .collect()
}

/// Rows beyond a limb's rates hold the base (`C x_b = h`, the reduced system's own
/// constraints): RHex's one-joint legs on toes with friction (three rows each, two of them
/// base rows) — a tripod, whose six base rows fix the base's rates; two toes, four base rows;
/// a mixed set — and a toe held in a plane (two rows), with impacts.
#[test]
fn rhex_toes_with_friction_hold_the_base_through_extra_rows() {
    let p = RhexSixLegs::table_4_2().with_table_4_2_legs();
    let model = p.model().unwrap();
    let tripod = rhex_toes(&p, &model, &[(0, true), (3, true), (4, true)]);
    let two = rhex_toes(&p, &model, &[(1, true), (5, true)]);
    let mixed = rhex_toes(&p, &model, &[(0, true), (1, false), (4, true), (5, false)]);
    let mut planar = rhex_toes(&p, &model, &[(0, false), (2, true), (5, false)]);
    planar[0] = planar[0].clone().in_plane(Vector3::x()).unwrap();
    let mut worst: f64 = 0.0;
    for (seed, contacts) in [(97, &tripod), (101, &two), (103, &mixed), (107, &planar)] {
        worst = worst.max(worst_against_dense(&model, contacts, seed, 10, true));
    }
    // the tripod's rows are ill-conditioned at some states (|λ| up to 8e5 N among these,
    // cond(A M⁻¹ Aᵀ) ~1e7, where the range-space route's λ is 4e-10 off): elimination
    // keeps λ to the rows' own condition
    assert!(worst < 1e-12, "routes differ by {worst:e}");
}

/// The biped's two-rate legs on feet with friction (three rows: one base row each).
#[test]
fn prismatic_legs_on_feet_with_friction() {
    let model = SpatialModel::from_urdf_str(&biped(), BaseKind::FreeFlyer, None).unwrap();
    let contacts: Vec<PointContact> = ["L_foot", "R_foot"]
        .iter()
        .map(|f| PointContact::new(&model, f, true).unwrap())
        .collect();
    assert_agrees(&model, &[(&contacts, 109, 20, true)]);
}

/// Where base rows cannot be taken the elimination declines and the row space's route solves
/// (each of these sets is redundant): more base rows than the base has rates (six toes with
/// friction: twelve), base rows on a fixed base (none to take them), and dependent base rows
/// (the biped's two legs on one hip at the same angles: one base row each, the same).
#[test]
fn base_rows_the_reduced_system_cannot_take_decline() {
    let p = RhexSixLegs::table_4_2().with_table_4_2_legs();
    let rhex = p.model().unwrap();
    let six: Vec<(usize, bool)> = (0..6).map(|i| (i, true)).collect();
    let fixed = SpatialModel::from_urdf_str(&biped(), BaseKind::Fixed, None).unwrap();
    let one_hip = SpatialModel::from_urdf_str(
        &biped().replace("0 -0.1 -0.05", "0 0.1 -0.05"),
        BaseKind::FreeFlyer,
        None,
    )
    .unwrap();
    let feet = |model: &SpatialModel| -> Vec<PointContact> {
        ["L_foot", "R_foot"]
            .iter()
            .map(|f| PointContact::new(model, f, true).unwrap())
            .collect()
    };
    let mut same = random_q(&one_hip, &mut rng(113));
    same[9] = same[7];
    same[10] = same[8];
    let cases = [
        (
            "six toes with friction",
            &rhex,
            rhex_toes(&p, &rhex, &six),
            None,
            KktRoute::NullSpace,
        ),
        (
            "a fixed base",
            &fixed,
            feet(&fixed),
            Some(random_vector(fixed.nq, 1.5, &mut rng(131))),
            KktRoute::NullSpace,
        ),
        (
            "one hip",
            &one_hip,
            feet(&one_hip),
            Some(same),
            KktRoute::NullSpace,
        ),
    ];
    for (name, model, contacts, q, route) in cases {
        let q = q.unwrap_or_else(|| random_q(model, &mut rng(127)));
        let tau = random_vector(model.nv, 5.0, &mut rng(137));
        // at rest: redundant rows' right-hand side (the drift) is then consistent
        let v = DVector::zeros(model.nv);
        let mut data = SpatialData::new(model);
        dynamics_at(model, &mut data, &contacts, (&q, &v, &tau)).unwrap();
        let (acc, eom) = dynamics_residuals(&data, &tau);
        assert!(
            !data.limbs_eliminated,
            "{name}: the limb elimination should decline"
        );
        assert_eq!(data.kkt_route, route, "{name}");
        assert!(acc < 1e-10 && eom < 1e-10, "{name}: {acc:e} {eom:e}");
    }
}

/// [`biped`] with a four-joint arm on its body (axes x, y, y, z; no contact): a limb of more
/// than three rates, whose definiteness the elimination checks by the general block (the
/// legs' by fixed-size ones). With the feet held in the plane the arm keeps its rates in the
/// reduced system; the routes agree with the dense solve, and with the arm's hand massless
/// (its wrist rate then moves no mass) the elimination declines.
#[test]
fn a_four_joint_arm_keeps_its_rates() {
    let link = |name: &str, mass: f64| {
        let i = 0.01 * mass;
        format!(
            r#"<link name="{name}"><inertial><origin xyz="0.05 0 0"/><mass value="{mass}"/>
            <inertia ixx="{i}" ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"/></inertial></link>"#
        )
    };
    let joint = |name: &str, parent: &str, child: &str, axis: &str| {
        format!(
            r#"<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>
            <origin xyz="0.1 0 0.05"/><axis xyz="{axis}"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>"#
        )
    };
    let arm = |hand_kg: f64| {
        let links = ["a1", "a2", "a3", "a4"];
        let axes = ["1 0 0", "0 1 0", "0 1 0", "0 0 1"];
        let mut extra = String::new();
        for (k, (l, axis)) in links.iter().zip(axes).enumerate() {
            extra += &link(l, if k == 3 { hand_kg } else { 0.4 });
            let parent = if k == 0 { "body" } else { links[k - 1] };
            extra += &joint(&format!("j{k}"), parent, l, axis);
        }
        let urdf = biped().replace("</robot>", &(extra + "</robot>"));
        SpatialModel::from_urdf_str(&urdf, BaseKind::FreeFlyer, None).unwrap()
    };
    let model = arm(0.2);
    assert_eq!(model.nv, 14);
    let held = |model: &SpatialModel| -> Vec<PointContact> {
        ["L_foot", "R_foot"]
            .iter()
            .map(|f| {
                PointContact::new(model, f, true)
                    .unwrap()
                    .in_plane(Vector3::x())
                    .unwrap()
            })
            .collect()
    };
    assert_agrees(&model, &[(&held(&model), 97, 10, false)]);
    // a massless hand (no mass, no rotational inertia): M is singular, the elimination declines
    let light = arm(0.0);
    let mut data = SpatialData::new(&light);
    let (q, v, tau) = random_state(&light, &mut rng(101));
    let _ = dynamics_at(&light, &mut data, &held(&light), (&q, &v, &tau));
    assert!(!data.limbs_eliminated);
}
