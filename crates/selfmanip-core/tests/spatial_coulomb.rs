//! Coulomb sliding and arc contacts of spatial robots (`spatial::coulomb`,
//! `ContactShape::{Sphere, Arc}`), each against an independent route: the closed forms of a
//! block sliding on a slope and of a ball sliding on its sphere, the fixed point of the
//! symmetric KKT solve with the friction as a known force, and finite differences of the
//! contact rows along the motion.
mod spatial_support;
use nalgebra::{DVector, Vector3};
use selfmanip_core::spatial::kinematics::{forward_kinematics, frame_jacobian, frame_placement};
use selfmanip_core::spatial::rhex::RhexSixLegs;
use selfmanip_core::spatial::*;
use spatial_support::*;

/// A free box (2 kg, COM at its origin) with three massless feet 0.1 m below it, a tripod.
const BLOCK: &str = r#"<robot name="block">
  <link name="block"><inertial><origin xyz="0 0 0"/><mass value="2.0"/><inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial></link>
  <link name="foot_a"/><joint name="a" type="fixed"><origin xyz="0.2 0.15 -0.1"/><parent link="block"/><child link="foot_a"/></joint>
  <link name="foot_b"/><joint name="b" type="fixed"><origin xyz="0.2 -0.15 -0.1"/><parent link="block"/><child link="foot_b"/></joint>
  <link name="foot_c"/><joint name="c" type="fixed"><origin xyz="-0.2 0 -0.1"/><parent link="block"/><child link="foot_c"/></joint>
</robot>"#;

/// A block on its three feet sliding along a slope of angle `α` (normal
/// `(sin α, 0, cos α)`, the block turned by `R_y(α)`): down the slope it accelerates at
/// `g(sin α − μ cos α)`, up the slope it decelerates at `g(sin α + μ cos α)`, with no
/// rotation and the normal forces summing to `m g cos α`.
#[test]
fn block_slides_on_a_slope_at_the_closed_form_rate() {
    let model = SpatialModel::from_urdf_str(BLOCK, BaseKind::FreeFlyer, None).unwrap();
    let mut data = SpatialData::new(&model);
    let (alpha, mu, g, m) = (0.3f64, 0.2, model.gravity.norm(), 2.0);
    let n = Vector3::new(alpha.sin(), 0.0, alpha.cos());
    let contacts: Vec<PointContact> = ["foot_a", "foot_b", "foot_c"]
        .iter()
        .map(|f| {
            PointContact::with_normal(&model, f, false, n)
                .unwrap()
                .sliding(mu)
                .unwrap()
        })
        .collect();
    let mut q = neutral(&model);
    q.as_mut_slice()[3..7].copy_from_slice(&[0.0, (alpha / 2.0).sin(), 0.0, (alpha / 2.0).cos()]);
    let tau = DVector::zeros(6);
    let mut worst = 0.0f64;
    for (speed, expected) in [
        (0.7, g * (alpha.sin() - mu * alpha.cos())),
        (-0.7, g * (alpha.sin() + mu * alpha.cos())),
    ] {
        let mut v = DVector::zeros(6);
        v[0] = speed;
        dynamics_at(&model, &mut data, &contacts, (&q, &v, &tau)).unwrap();
        let mut want = DVector::zeros(6);
        want[0] = expected;
        let normal_sum: f64 = data.lam.sum();
        worst = worst
            .max((&data.qdd - &want).amax() / g)
            .max((normal_sum - m * g * alpha.cos()).abs() / (m * g));
        assert!(data.lam.iter().all(|&l| l > 0.0), "{:?}", data.lam);
    }
    eprintln!("block on a slope: |q̈ − closed form|/g, |Σλ_n − m g cos α|/(m g) {worst:.1e}");
    assert!(worst < 1e-13, "{worst}");
}

/// A ball sliding and spinning on flat ground (contact on its sphere, `μ = 0.4`): the contact
/// point `c − r ẑ` slides along `ŝ = (v + ω × (−r ẑ))_t/|·|`, the ground pushes `m g` and
/// `−μ m g ŝ`, so the centre accelerates at `−μ g ŝ` and the spin at
/// `ω̇ = r μ m g (ẑ × ŝ)/I = (5 μ g/2r) ẑ × ŝ`; in the free flyer's body-frame rates at the
/// identity orientation, `v̇ = a − ω × v`.
#[test]
fn ball_slides_on_its_sphere_at_the_closed_form_rate() {
    let model = SpatialModel::from_urdf_str(BALL, BaseKind::FreeFlyer, None).unwrap();
    let mut data = SpatialData::new(&model);
    let (r, mu, g, m) = (0.1, 0.4, model.gravity.norm(), 1.5);
    let contact = PointContact::new(&model, "ball", false)
        .unwrap()
        .on_sphere(r)
        .unwrap()
        .sliding(mu)
        .unwrap();
    let mut q = neutral(&model);
    q[2] = r;
    let mut rng = rng(33);
    let mut worst = 0.0f64;
    for _ in 0..10 {
        let mut v = random_vector(6, 2.0, &mut rng);
        v[2] = 0.0;
        let (lin, w) = (
            Vector3::new(v[0], v[1], v[2]),
            Vector3::new(v[3], v[4], v[5]),
        );
        let slip = lin + w.cross(&Vector3::new(0.0, 0.0, -r));
        let s = slip / slip.norm();
        let a = -s * (mu * g);
        let w_dot = Vector3::z().cross(&s) * (5.0 * mu * g / (2.0 * r));
        let lin_dot = a - w.cross(&lin);
        let want = DVector::from_column_slice(&[
            lin_dot.x, lin_dot.y, lin_dot.z, w_dot.x, w_dot.y, w_dot.z,
        ]);
        dynamics_at(
            &model,
            &mut data,
            std::slice::from_ref(&contact),
            (&q, &v, &DVector::zeros(6)),
        )
        .unwrap();
        worst = worst
            .max((&data.qdd - &want).amax() / want.amax())
            .max((data.lam[0] - m * g).abs() / (m * g));
    }
    eprintln!("ball on its sphere: |q̈ − closed form| (relative) {worst:.1e}");
    assert!(worst < 1e-13, "{worst}");
}

/// The quadruped with its front feet sliding (`μ = 0.3`) and its hind feet sticking, at the
/// standing pose with random rates and torques: the nonsymmetric solve against the fixed point
/// of the symmetric one with the friction `−μ λ_n ŝ` of the last iterate applied as a known
/// force `J_pᵀ F` (frame Jacobians, local-world-aligned, at the feet).
#[test]
fn sliding_feet_match_the_fixed_point_of_the_symmetric_solve() {
    let (model, mut data, mut rng) = setup(quadruped(), 34);
    let mu = 0.3;
    let sliding: Vec<PointContact> = feet(&model, [false, false, true, true])
        .into_iter()
        .enumerate()
        .map(|(k, c)| if k < 2 { c.sliding(mu).unwrap() } else { c })
        .collect();
    let frictionless: Vec<PointContact> = feet(&model, [false, false, true, true]);
    let normal_rows = [0, 1];
    let q = standing_q(&model, 0.4, 0.5);
    let mut worst = 0.0f64;
    for _ in 0..10 {
        let v = random_vector(model.nv, 0.5, &mut rng);
        let mut tau = random_vector(model.nv, 3.0, &mut rng);
        tau.rows_mut(0, 6).fill(0.0);
        dynamics_at(&model, &mut data, &sliding, (&q, &v, &tau)).unwrap();
        let (qdd, lam) = (data.qdd.clone(), data.lam.clone());
        // the second route
        forward_kinematics(&model, &mut data, q.as_slice()).unwrap();
        let jacobians: Vec<_> = FEET[..2]
            .iter()
            .map(|f| {
                let id = model.frame_id(f).unwrap();
                frame_jacobian(&model, &mut data, id, ReferenceFrame::LocalWorldAligned);
                data.J.rows(0, 3).into_owned()
            })
            .collect();
        let slide: Vec<Vector3<f64>> = jacobians
            .iter()
            .map(|j| {
                let vel = j * &v;
                let t = Vector3::new(vel[0], vel[1], 0.0);
                t / t.norm()
            })
            .collect();
        let mut lam_n = [0.0; 2];
        for _ in 0..200 {
            let mut tau_f = tau.clone();
            for k in 0..2 {
                tau_f += jacobians[k].transpose() * (slide[k] * (-mu * lam_n[k]));
            }
            dynamics_at(&model, &mut data, &frictionless, (&q, &v, &tau_f)).unwrap();
            let next = [data.lam[normal_rows[0]], data.lam[normal_rows[1]]];
            let change = (next[0] - lam_n[0]).abs().max((next[1] - lam_n[1]).abs());
            lam_n = next;
            if change < 1e-14 * lam.amax() {
                break;
            }
        }
        worst = worst
            .max((&data.qdd - &qdd).amax() / qdd.amax())
            .max((&data.lam - &lam).amax() / lam.amax());
    }
    eprintln!("sliding feet: nonsymmetric solve vs fixed point {worst:.1e} (relative)");
    assert!(worst < 1e-10, "{worst}");
}

/// RHex's C-legs as arcs (the forward half circle from the toe to the hip): at random
/// tumbling states, the drift is `d/dt (A v)` by central differences whether the circle's
/// lowest point lies on the arc (rolling) or not (the lower end, a material point); where it
/// lies on the arc the rows are the whole circle's, and where it does not, `A v` is the
/// velocity of the end (differences of its position).
#[test]
fn arc_contacts_roll_on_the_arc_and_pivot_on_its_ends() {
    let p = RhexSixLegs::table_4_2().with_table_4_2_legs();
    let model = p.model().unwrap();
    let mut data = SpatialData::new(&model);
    let legs = ["front_left", "middle_right", "rear_left"];
    let arcs: Vec<PointContact> = legs
        .iter()
        .map(|l| p.leg_c_arc(&model, l, true).unwrap())
        .collect();
    let circles: Vec<PointContact> = legs
        .iter()
        .map(|l| p.leg_arc(&model, l, true).unwrap())
        .collect();
    let tau = vec![0.0; model.nv];
    let rows =
        |data: &mut SpatialData, contacts: &[PointContact], q: &DVector<f64>, v: &DVector<f64>| {
            forward_dynamics(&model, data, contacts, q.as_slice(), v.as_slice(), &tau).unwrap();
            (data.A.clone(), data.A_drift.clone())
        };
    let mut rng = rng(35);
    let (mut worst_drift, mut worst_rows, mut worst_end) = (0.0f64, 0.0f64, 0.0f64);
    let (mut on_arc, mut on_end) = (0, 0);
    for trial in 0..30 {
        let (q, v, _) = random_state(&model, &mut rng);
        let a = random_vector(model.nv, 3.0, &mut rng);
        // one leg at a time: three legs' rows together are redundant at some states
        let k = trial % arcs.len();
        let (arc, circle) = (&arcs[k], &circles[k]);
        let (a0, drift) = rows(&mut data, std::slice::from_ref(arc), &q, &v);
        let h = 1e-5;
        let at = |t: f64, data: &mut SpatialData| {
            let step = &v * t + &a * (0.5 * t * t);
            let qt = integrate(&model, q.as_slice(), step.as_slice()).unwrap();
            let vt = &v + &a * t;
            let (at, _) = rows(data, std::slice::from_ref(arc), &qt, &vt);
            at * vt
        };
        let fd = (at(h, &mut data) - at(-h, &mut data)) / (2.0 * h);
        let exact = &a0 * &a + &drift;
        worst_drift = worst_drift.max((fd - &exact).amax() / exact.amax().max(1.0));
        let (c0, cdrift) = rows(&mut data, std::slice::from_ref(circle), &q, &v);
        let (r, _) = arc.offset(&model, &data);
        let circle_point = {
            let ContactShape::Arc { axis, .. } = arc.shape else {
                unreachable!()
            };
            let a_w = frame_placement(&model, &data, arc.frame).rotation * axis;
            let down = -Vector3::z();
            let u = down - a_w * a_w.dot(&down);
            u * (0.5 * p.leg_length_m / u.norm())
        };
        if (r - circle_point).norm() < 1e-12 {
            on_arc += 1;
            let e = (&a0 - &c0).amax() + (&drift - &cdrift).amax();
            worst_rows = worst_rows.max(e);
        } else {
            on_end += 1;
            // the end, a material point: its world position along q ⊕ v t
            let body_r = frame_placement(&model, &data, arc.frame)
                .rotation
                .transpose()
                * r;
            let end = |t: f64, data: &mut SpatialData| {
                let qt = along(&model, &q, &v, t);
                forward_kinematics(&model, data, qt.as_slice()).unwrap();
                let placement = frame_placement(&model, data, arc.frame);
                placement.translation + placement.rotation * body_r
            };
            let vel = (end(h, &mut data) - end(-h, &mut data)) / (2.0 * h);
            let av = &a0 * &v;
            worst_end = worst_end.max((av - vel).amax() / vel.amax().max(1.0));
        }
    }
    eprintln!(
        "arcs: {on_arc} on the arc, {on_end} on an end; drift vs differences {worst_drift:.1e}, \
         rows vs the circle's {worst_rows:.1e}, A v vs the end's velocity {worst_end:.1e}"
    );
    assert!(on_arc > 5 && on_end > 5, "{on_arc} {on_end}");
    assert!(worst_drift < 1e-7 && worst_rows < 1e-13 && worst_end < 1e-8);
}

/// Bad input names the field: a negative or NaN coefficient, an arc's axis, zero direction
/// and angle range, a sphere's radius, and a sliding contact that does not slide.
#[test]
fn bad_sliding_and_arc_input_names_the_field() {
    let model = SpatialModel::from_urdf_str(BALL, BaseKind::FreeFlyer, None).unwrap();
    let c = PointContact::new(&model, "ball", false).unwrap();
    let field = |e: SpatialError| match e {
        SpatialError::InvalidArgument { field, .. } => field,
        other => panic!("{other}"),
    };
    assert_eq!(field(c.clone().sliding(-0.1).unwrap_err()), "friction");
    assert_eq!(field(c.clone().sliding(f64::NAN).unwrap_err()), "friction");
    assert_eq!(field(c.clone().on_sphere(-1.0).unwrap_err()), "radius_m");
    let (y, z) = (Vector3::y(), Vector3::z());
    assert_eq!(
        field(
            c.clone()
                .on_arc(0.1, Vector3::zeros(), z, (0.0, 1.0))
                .unwrap_err()
        ),
        "axis"
    );
    assert_eq!(
        field(c.clone().on_arc(0.1, y, y, (0.0, 1.0)).unwrap_err()),
        "zero"
    );
    assert_eq!(
        field(c.clone().on_arc(0.1, y, z, (1.0, 0.0)).unwrap_err()),
        "angle_range_rad"
    );
    assert_eq!(
        field(c.clone().on_arc(0.1, y, z, (0.0, 7.0)).unwrap_err()),
        "angle_range_rad"
    );
    let sliding = c.on_sphere(0.1).unwrap().sliding(0.5).unwrap();
    let mut data = SpatialData::new(&model);
    let mut q = neutral(&model);
    q[2] = 0.1;
    let e = forward_dynamics(
        &model,
        &mut data,
        &[sliding],
        q.as_slice(),
        &[0.0; 6],
        &[0.0; 6],
    );
    assert_eq!(field(e.unwrap_err()), "v");
}
