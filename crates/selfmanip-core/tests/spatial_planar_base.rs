//! A planar base (`BaseKind::Planar`, Python's `base="planar"`): a URDF robot whose root link
//! moves in the world's x–z plane, `q = [x, z, θ, joints]`, `v = q̇`. The second formulation
//! is the same URDF on a free-flying base held in that plane: at a planar state `(q, v)` the
//! free flyer's `q_f = [x, 0, z, R_y(θ), joints]` and `v_f = P v`, `P` taking `(ẋ, ż, θ̇)` to
//! the body twist `(R_y(θ)ᵀ (ẋ, 0, ż), (0, θ̇, 0))`. Then `M = Pᵀ M_f P`,
//! `h = Pᵀ (h_f + M_f Ṗ v)` (`Ṗ v`'s linear part `−ω × v_lin`, the body axes turning under the
//! world velocity), every frame's placement is the same, its Jacobian `J = J_f P` in every
//! reference frame, and a contact's drift `A_f Ṗ v + Ȧ_f q̇_f`; the constrained dynamics on four
//! feet solve the dense KKT system (LU), by the tree's range-space route where `M` is regular.
//! Quasi-static standing on four feet is the lever rule of a plate on two supports.
mod spatial_support;
use nalgebra::{DMatrix, DVector, UnitQuaternion, Vector3};
use rand::Rng;
use selfmanip_core::spatial::kinematics::{
    forward_kinematics, frame_jacobian, frame_origin, frame_placement,
};
use selfmanip_core::spatial::rigid_body::{crba, nonlinear_effects};
use selfmanip_core::spatial::*;
use spatial_support::*;

/// The quadruped as shipped, and with massless shins (its `M` singular).
fn models(base: BaseKind) -> Vec<SpatialModel> {
    vec![
        quadruped_scaled_on(base, &[], 1.0),
        quadruped_scaled_on(base, &["_shin", "_foot"], 0.0),
    ]
}

/// A random planar state: base within 1 m, turned by up to ±3 rad, joints in ±1.5 rad,
/// rates in ±2.
fn random_planar(
    model: &SpatialModel,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> (DVector<f64>, DVector<f64>) {
    let mut q = DVector::from_fn(model.nq, |_, _| rng.gen_range(-1.5..1.5));
    q[0] = rng.gen_range(-1.0..1.0);
    q[1] = rng.gen_range(-1.0..1.0);
    q[2] = rng.gen_range(-3.0..3.0);
    (q, random_vector(model.nv, 2.0, rng))
}

/// The free flyer's state of a planar one, `P` (nv_f × nv) and `Ṗ v`.
fn held_in_plane(
    q: &DVector<f64>,
    v: &DVector<f64>,
) -> (DVector<f64>, DVector<f64>, DMatrix<f64>, DVector<f64>) {
    let nj = q.len() - 3;
    let r = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), q[2]);
    let mut qf = DVector::zeros(7 + nj);
    qf.as_mut_slice()[..7].copy_from_slice(&[q[0], 0.0, q[1], r.i, r.j, r.k, r.w]);
    qf.rows_mut(7, nj).copy_from(&q.rows(3, nj));
    let rt = r.to_rotation_matrix().matrix().transpose();
    let mut p = DMatrix::zeros(6 + nj, 3 + nj);
    p.view_mut((0, 0), (3, 1)).copy_from(&rt.column(0));
    p.view_mut((0, 1), (3, 1)).copy_from(&rt.column(2));
    p[(4, 2)] = 1.0;
    for k in 0..nj {
        p[(6 + k, 3 + k)] = 1.0;
    }
    let vf = &p * v;
    let (lin, w) = (
        vf.fixed_rows::<3>(0).into_owned(),
        Vector3::new(0.0, v[2], 0.0),
    );
    let mut pdot_v = DVector::zeros(6 + nj);
    pdot_v.fixed_rows_mut::<3>(0).copy_from(&-w.cross(&lin));
    (qf, vf, p, pdot_v)
}

#[test]
fn planar_base_is_the_free_flyer_held_in_its_plane() {
    let frames = ["trunk", "imu", "FL_thigh", "HR_shin", "HL_knee", "FR_foot"];
    for (planar, free) in models(BaseKind::Planar)
        .iter()
        .zip(models(BaseKind::FreeFlyer))
    {
        let (model, mut data, mut rng) = setup(planar.clone(), 51);
        let mut fdata = SpatialData::new(&free);
        assert_eq!((model.nq, model.nv), (15, 15));
        assert_eq!(model.joints[0].name, "root_joint");
        let mut worst = [0.0f64; 6];
        for _ in 0..20 {
            let (q, v) = random_planar(&model, &mut rng);
            let (qf, vf, p, pdot_v) = held_in_plane(&q, &v);
            crba(&model, &mut data, q.as_slice()).unwrap();
            crba(&free, &mut fdata, qf.as_slice()).unwrap();
            let m_f = fdata.M.clone();
            worst[0] = worst[0].max((&data.M - p.transpose() * &m_f * &p).amax());
            nonlinear_effects(&model, &mut data, q.as_slice(), v.as_slice()).unwrap();
            nonlinear_effects(&free, &mut fdata, qf.as_slice(), vf.as_slice()).unwrap();
            let h = p.transpose() * (&fdata.h + &m_f * &pdot_v);
            worst[1] = worst[1].max((&data.h - h).amax() / fdata.h.amax().max(1.0));
            forward_kinematics(&model, &mut data, q.as_slice()).unwrap();
            forward_kinematics(&free, &mut fdata, qf.as_slice()).unwrap();
            for name in frames {
                let (f, ff) = (model.frame_id(name).unwrap(), free.frame_id(name).unwrap());
                let gap = frame_placement(&model, &data, f)
                    .max_abs_diff(&frame_placement(&free, &fdata, ff));
                worst[2] = worst[2].max(gap);
                for reference in [
                    ReferenceFrame::World,
                    ReferenceFrame::Local,
                    ReferenceFrame::LocalWorldAligned,
                ] {
                    frame_jacobian(&model, &mut data, f, reference);
                    frame_jacobian(&free, &mut fdata, ff, reference);
                    let j = DMatrix::from_column_slice(6, model.nv, data.J.as_slice());
                    let jf = DMatrix::from_column_slice(6, free.nv, fdata.J.as_slice());
                    worst[3] = worst[3].max((j - jf * &p).amax());
                }
            }
            // the feet's rows in the plane (x, z) and their drift
            let contacts: Vec<_> = FEET
                .iter()
                .map(|f| PointContact::new(&model, f, true).unwrap())
                .collect();
            let held: Vec<_> = FEET
                .iter()
                .map(|f| {
                    PointContact::new(&free, f, true)
                        .unwrap()
                        .in_plane(Vector3::x())
                        .unwrap()
                })
                .collect();
            let tau = random_vector(model.nv, 5.0, &mut rng);
            forward_dynamics(
                &model,
                &mut data,
                &contacts,
                q.as_slice(),
                v.as_slice(),
                tau.as_slice(),
            )
            .unwrap();
            let zero = vec![0.0; free.nv];
            forward_dynamics(
                &free,
                &mut fdata,
                &held,
                qf.as_slice(),
                vf.as_slice(),
                &zero,
            )
            .unwrap();
            let drift = &fdata.A * &pdot_v + &fdata.A_drift;
            worst[4] = worst[4]
                .max((&data.A - &fdata.A * &p).amax())
                .max((&data.A_drift - drift).amax() / fdata.A_drift.amax().max(1.0));
            // q̈ and λ against a dense LU of [M −Aᵀ; A 0][q̈; λ] = [τ − h; −Ȧq̇]
            let (n, c) = (model.nv, data.A.nrows());
            let mut kkt = DMatrix::zeros(n + c, n + c);
            kkt.view_mut((0, 0), (n, n)).copy_from(&data.M);
            kkt.view_mut((0, n), (n, c)).copy_from(&-data.A.transpose());
            kkt.view_mut((n, 0), (c, n)).copy_from(&data.A);
            let mut rhs = DVector::zeros(n + c);
            rhs.rows_mut(0, n).copy_from(&(&tau - &data.h));
            rhs.rows_mut(n, c).copy_from(&-&data.A_drift);
            let x = kkt.lu().solve(&rhs).unwrap();
            let scale = x.amax().max(1.0);
            worst[5] = worst[5]
                .max((&data.qdd - x.rows(0, n)).amax() / scale)
                .max((&data.lam - x.rows(n, c)).amax() / scale);
            // a massive robot takes the tree's range-space factorization, its rates a chain
            if model.total_mass() > 20.0 {
                assert_eq!(data.kkt_route, KktRoute::RangeSpace);
            }
        }
        assert_worst(
            &format!(
                "planar base vs free flyer held in the plane (mass {:.2} kg):",
                model.total_mass()
            ),
            &["M", "h", "placement", "J", "A, drift", "q̈, λ vs dense LU"],
            &worst,
            1e-12,
        );
    }
}

/// `q ⊕ v` adds (`v = q̇`), `⊖` subtracts, `neutral` is zero, Pinocchio's layout is ours (its
/// composite root joint of `PX`, `PZ`, `RY` has the same three coordinates).
#[test]
fn planar_configuration_is_a_vector_space() {
    let (model, _, mut rng) = setup(models(BaseKind::Planar).remove(0), 52);
    assert_eq!(neutral(&model), DVector::zeros(model.nq));
    let (q, v) = random_planar(&model, &mut rng);
    assert_eq!(
        integrate(&model, q.as_slice(), v.as_slice()).unwrap(),
        &q + &v
    );
    assert_eq!(
        difference(&model, q.as_slice(), (&q + &v).as_slice()).unwrap(),
        (&q + &v) - &q
    );
    assert_eq!(to_pinocchio(&model, q.as_slice()).unwrap(), q);
}

/// Standing level on four feet in the plane (rows `x`, `z` each, every leg bent alike so the
/// feet are at one height): the ground's external forces are those of a plate on two
/// supports, the lever rule about the centre of mass `x_c`,
/// `N_front = m g (x_hind − x_c) / (x_hind − x_front)` shared by the two front feet, and no
/// tangential force; the `8 − 3` internal forces push nothing into the base.
#[test]
fn planar_quasi_static_is_the_lever_rule() {
    let (model, mut data, _) = setup(models(BaseKind::Planar).remove(0), 53);
    let mut q = DVector::zeros(model.nq);
    q[1] = 0.3;
    for leg in 0..4 {
        q[3 + 3 * leg + 1] = 0.5;
        q[3 + 3 * leg + 2] = -1.0;
    }
    let contacts: Vec<_> = FEET
        .iter()
        .map(|f| PointContact::new(&model, f, true).unwrap())
        .collect();
    forward_kinematics(&model, &mut data, q.as_slice()).unwrap();
    let feet: Vec<Vector3<f64>> = contacts
        .iter()
        .map(|c| frame_origin(&model, &data, c.frame))
        .collect();
    let com = (0..model.joints.len())
        .map(|i| data.oMi[i].act_point(&model.inertias[i].com) * model.inertias[i].mass)
        .sum::<Vector3<f64>>()
        / model.total_mass();
    // FL, FR at the front, HL, HR at the back, all at one height
    assert!((feet[0].x - feet[1].x).abs() < 1e-12 && (feet[2].x - feet[3].x).abs() < 1e-12);
    assert!(feet.iter().all(|f| (f.z - feet[0].z).abs() < 1e-12));
    let (x_front, x_hind) = (feet[0].x, feet[2].x);
    let weight = -model.total_mass() * model.gravity.z;
    let front = weight * (x_hind - com.x) / (x_hind - x_front) / 2.0;
    let hind = weight / 2.0 - front;
    let want = DVector::from_column_slice(&[0.0, front, 0.0, front, 0.0, hind, 0.0, hind]);
    let qs = quasi_static(&model, &mut data, &contacts, q.as_slice()).unwrap();
    let lever = (&qs.lambda_external - &want).amax() / weight;
    let internal = (&qs.grasp * &qs.internal_basis).amax();
    assert_worst(
        "planar quadruped standing:",
        &["λ_e vs the lever rule", "G N"],
        &[lever, internal],
        1e-12,
    );
    assert_eq!(
        (
            qs.grasp.shape(),
            qs.internal_basis.ncols(),
            qs.tau_external.len()
        ),
        ((3, 8), 5, 12)
    );
}

/// A ground normal out of the plane, an unknown base name: typed errors naming the field.
#[test]
fn planar_bad_input_names_the_field() {
    let model = models(BaseKind::Planar).remove(0);
    let tilted = PointContact::with_normal(&model, "FL_foot", true, Vector3::new(0.0, 0.3, 1.0));
    assert!(
        matches!(&tilted, Err(SpatialError::InvalidArgument { field, .. }) if field == "normal"),
        "{tilted:?}"
    );
    let in_plane = PointContact::with_normal(&model, "FL_foot", true, Vector3::new(0.3, 0.0, 1.0));
    assert_eq!(in_plane.unwrap().n_rows(), 2);
    let unknown = BaseKind::from_name("sagittal");
    assert!(
        matches!(&unknown, Err(SpatialError::InvalidArgument { field, .. }) if field == "base"),
        "{unknown:?}"
    );
}
