//! Exact partials of the dynamics, the plastic impact and the contact guards in a link's
//! length and a point contact's position (`selfmanip_core::geometry_partials`) against an
//! independent route: Richardson central differences of the same quantity computed by the
//! model built from the perturbed description (steps `2e-4`, `1e-4` m: truncation `O(h⁴)` ≈
//! 1e-13 relative, rounding `ε|z|/h` ≈ 1e-11 of the largest `|z|`), to 1e-7 relative to the
//! largest entry.
//!
//! Robots: the newcomer's bounder of issue 30 (two two-link legs of 0.1 kg links, point feet),
//! with centres of mass given off the links' axes or left to default to the links' middles
//! (the length then moves the link's own centre too), and a variant with massless thighs
//! (a massless link's length moves the kinematics only).
use nalgebra::{DMatrix, DVector};
use selfmanip_core::contact::{contact_geometry, ContactGeometry, ContactKind};
use selfmanip_core::description::ShapeDescription;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::tangent::{
    dynamics_jvp, plastic_impact_body_derivatives, BodyParameter, FlowDirections,
};
use selfmanip_core::{
    forward_dynamics, plastic_impact, ContactMode, Data, FlatGround, Model, RobotDescription,
};

const TOL: f64 = 1e-7;

/// The bounder with the length of link `k` of leg `leg` and the feet's positions given.
/// `coms`: the links' centres (`None`: the description's default middle); `thigh_mass`: the
/// first links' mass (0: massless thighs).
fn bounder(lengths: [f64; 4], feet: [[f64; 2]; 2], coms: bool, thigh_mass: f64) -> Model {
    let link = |l: f64, m: f64, com: [f64; 2]| {
        let mut v = serde_json::json!({"length_m": l, "mass_kg": m,
            "inertia_kg_m2": if m > 0.0 { 1.875e-4 } else { 0.0 }});
        if coms {
            v["com_m"] = serde_json::json!(com);
        }
        v
    };
    let foot = |g: &str, p: [f64; 2]| {
        serde_json::json!({"name": format!("{g}_foot"), "leg": g,
        "shape": {"kind": "point", "position_m": p}, "friction": {"kind": "sticking", "mu": 0.8}})
    };
    let leg = |name: &str, hip: f64, i: usize| {
        serde_json::json!({"name": name, "hip_m": [hip, 0.0], "links": [
            link(lengths[2 * i], thigh_mass, [0.01, 0.07]),
            link(lengths[2 * i + 1], 0.1, [-0.005, 0.08])]})
    };
    let robot = serde_json::json!({"name": "bounder",
        "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.0267},
        "contacts": [foot("front", feet[0]), foot("hind", feet[1])],
        "legs": [leg("front", 0.2, 0), leg("hind", -0.2, 1)]});
    RobotDescription::from_json_str(&robot.to_string())
        .unwrap()
        .build()
        .unwrap()
}

/// The geometry `[l0, l1, l2, l3, fx0, fz0, fx1, fz1]` of a bounder, and a model of it.
type Geometry = [f64; 8];
const NOMINAL: Geometry = [0.15, 0.15, 0.14, 0.16, 0.01, 0.15, -0.02, 0.16];

fn model_of(g: &Geometry, coms: bool, thigh_mass: f64) -> Model {
    bounder(
        [g[0], g[1], g[2], g[3]],
        [[g[4], g[5]], [g[6], g[7]]],
        coms,
        thigh_mass,
    )
}

/// The parameter moving entry `i` of a [`Geometry`].
fn parameter(i: usize, coms: bool) -> BodyParameter {
    match i {
        0..=3 => BodyParameter::LinkLength {
            joint: i,
            com_follows: !coms,
        },
        _ => BodyParameter::ContactPosition((i - 4) / 2, (i - 4) % 2),
    }
}

/// `(exact, central difference)` of `value` in every geometric parameter of the bounder.
fn each_parameter(
    coms: bool,
    thigh_mass: f64,
    exact: impl Fn(&Model, BodyParameter) -> DVector<f64>,
    value: impl Fn(&Model) -> DVector<f64>,
) {
    let model = model_of(&NOMINAL, coms, thigh_mass);
    for i in 0..8 {
        let p = parameter(i, coms);
        p.check(&model).unwrap();
        let at = |s: f64| {
            let mut g = NOMINAL;
            g[i] += s;
            value(&model_of(&g, coms, thigh_mass))
        };
        let d = |h: f64| (at(h) - at(-h)) / (2.0 * h);
        let h = 2e-4;
        let fd = (4.0 * d(h / 2.0) - d(h)) / 3.0;
        let ex = exact(&model, p);
        let scale = fd.amax().max(ex.amax());
        let err = (&ex - &fd).amax() / scale.max(1e-300);
        eprintln!("{p:?}: |exact − FD| / max = {err:.1e} (max {scale:.2e})");
        assert!(err < TOL, "{p:?}: {err:e}\nexact {ex}\nfd {fd}");
    }
}

/// A state of the bounder with both feet near the ground, moving and turning.
fn state() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let q = vec![0.45, -0.95, 0.55, -1.05, 0.1, -0.2, 0.05];
    let qd = vec![1.2, -0.8, -0.5, 2.0, 0.7, 0.4, -0.9];
    let tau = vec![0.3, -0.2, 0.5, 0.1];
    (q, qd, tau)
}

fn both_stick(_: &Model) -> ContactMode {
    ContactMode::FLIGHT
        .with(0, ContactKind::Stick)
        .with(1, ContactKind::Stick)
}

/// `(q̈, λ)` of the flow in `mode` at the state, and the workspace it was solved in.
fn solved(model: &Model, mode: impl Fn(&Model) -> ContactMode) -> (DVector<f64>, Data) {
    let (q, qd, tau) = state();
    let mut data = Data::new(model);
    forward_dynamics(
        model,
        &mut data,
        &FlatGround,
        mode(model),
        &q,
        &qd,
        &tau,
        None,
    )
    .unwrap();
    let mut v: Vec<f64> = data.qdd.iter().copied().collect();
    v.extend(data.lambda.iter());
    (DVector::from_vec(v), data)
}

/// The flow's column of `p` by [`dynamics_jvp`] (no state or torque direction).
fn flow_column(model: &Model, data: &mut Data, qd: &[f64], p: BodyParameter) -> DVector<f64> {
    let (nq, n) = (model.nq(), model.n_joints());
    let z = DMatrix::zeros(nq, 1);
    let dirs = FlowDirections {
        dq: &z,
        dqd: &z,
        dtau: &DMatrix::zeros(n, 1),
        body: &[Some(p)],
        force: None,
    };
    let (dqdd, dl) = dynamics_jvp(model, data, qd, &dirs).unwrap();
    let mut v: Vec<f64> = dqdd.iter().copied().collect();
    v.extend(dl.iter());
    DVector::from_vec(v)
}

#[test]
fn flow_partials_match_rebuilt_models() {
    // sliding feet carry Coulomb friction (`mu_kinetic` defaults to `mu`): general sites,
    // folded into the solve, whose `B = μ_kσ A_t` moves with the geometry
    let modes: [fn(&Model) -> ContactMode; 5] = [
        |_| ContactMode::FLIGHT,
        |_| ContactMode::FLIGHT.with(1, ContactKind::Stick),
        both_stick,
        |_| ContactMode::FLIGHT.with(1, ContactKind::Slide),
        |_| {
            ContactMode::FLIGHT
                .with(0, ContactKind::Stick)
                .with(1, ContactKind::Slide)
        },
    ];
    for mode in modes {
        for (coms, thigh) in [(true, 0.1), (false, 0.1), (true, 0.0)] {
            let exact = |m: &Model, p| flow_column(m, &mut solved(m, mode).1, &state().1, p);
            each_parameter(coms, thigh, exact, |m| solved(m, mode).0);
        }
    }
}

/// `q̇⁺` of the plastic impact into both feet sticking.
fn impact(model: &Model) -> DVector<f64> {
    let (q, qd, _) = state();
    let mut data = Data::new(model);
    let i = plastic_impact(model, &mut data, &FlatGround, both_stick(model), &q, &qd).unwrap();
    i.qd_plus
}

#[test]
fn impact_partials_match_rebuilt_models() {
    for (coms, thigh) in [(true, 0.1), (false, 0.1), (true, 0.0)] {
        let exact = |m: &Model, p: BodyParameter| {
            let (q, qd, _) = state();
            let mut data = Data::new(m);
            let i = plastic_impact(m, &mut data, &FlatGround, both_stick(m), &q, &qd).unwrap();
            let d = plastic_impact_body_derivatives(m, &mut data, &i, &qd, &[p]);
            d.column(0).into_owned()
        };
        each_parameter(coms, thigh, exact, impact);
    }
}

/// Two numbers of each foot at the state, `per_foot(kinematics, foot, its geometry)`, stacked.
fn each_foot(
    model: &Model,
    per_foot: impl Fn(&Kinematics, usize, &ContactGeometry) -> [f64; 2],
) -> DVector<f64> {
    let (q, qd, _) = state();
    let mut kin = Kinematics::default();
    kin.compute(model, &q, &qd);
    let v: Vec<f64> = (0..2)
        .flat_map(|k| per_foot(&kin, k, &contact_geometry(model, &kin, &FlatGround, k)))
        .collect();
    DVector::from_vec(v)
}

/// Each foot's height above the ground and its sliding velocity at the state.
fn guards(model: &Model) -> DVector<f64> {
    each_foot(model, |kin, _, geo| {
        let vel = kin.material_velocity(geo.part, geo.point);
        [geo.gap_m, geo.plane.tangent().dot(&vel)]
    })
}

#[test]
fn guard_partials_match_rebuilt_models() {
    let exact = |m: &Model, p: BodyParameter| {
        each_foot(m, |kin, k, geo| {
            [
                p.height_partial(m, kin, k, geo.plane.normal()),
                p.sliding_velocity_partial(m, kin, k, geo.plane.tangent()),
            ]
        })
    };
    each_parameter(true, 0.1, exact, guards);
}

#[test]
fn arc_positions_and_unknown_parts_are_refused() {
    let m = model_of(&NOMINAL, true, 0.1);
    assert!(BodyParameter::ContactPosition(2, 0).check(&m).is_err());
    assert!(BodyParameter::ContactPosition(0, 2).check(&m).is_err());
    let p = BodyParameter::LinkLength {
        joint: 4,
        com_follows: false,
    };
    assert!(p.check(&m).is_err());
}

/// `tests/data/robots/legged_general_sliding.toml` with contact `k`'s position moved by `h`
/// along `axis`: a massive one-link leg's toe (`toe`, 0: a general sliding site, folded) and
/// a massless one-link leg's toe (`stub`, 3: resolved by its leg's statics).
fn legged(k: usize, axis: usize, h: f64) -> Model {
    let text = include_str!("../../../tests/data/robots/legged_general_sliding.toml");
    let mut d = RobotDescription::from_toml_str(text).unwrap();
    if let ShapeDescription::Point { position_m } = &mut d.contacts[k].shape {
        position_m[axis] += h;
    }
    d.build().unwrap()
}

/// Both kinds of Coulomb sliding site in one solve, the massive leg's toe and the massless
/// stub's, sliding backward: the flow's column of each toe's position against rebuilt models.
#[test]
fn sliding_toes_positions_match_rebuilt_models() {
    let mode = ContactMode::FLIGHT
        .with(0, ContactKind::Slide)
        .with(3, ContactKind::Slide);
    let (q, qd, tau) = (
        [0.1, 0.05, 0.0, 0.0, 0.05],
        [0.3, -0.2, -1.0, 0.1, 0.2],
        [0.4, -0.3],
    );
    let solve = |m: &Model| {
        let mut data = Data::new(m);
        forward_dynamics(m, &mut data, &FlatGround, mode, &q, &qd, &tau, None).unwrap();
        let mut v: Vec<f64> = data.qdd.iter().copied().collect();
        v.extend(data.lambda.iter());
        (DVector::from_vec(v), data)
    };
    for (k, axis) in [(0, 0), (0, 1), (3, 0), (3, 1)] {
        let model = legged(k, axis, 0.0);
        let (_, mut data) = solve(&model);
        let ex = flow_column(
            &model,
            &mut data,
            &qd,
            BodyParameter::ContactPosition(k, axis),
        );
        let d = |h: f64| (solve(&legged(k, axis, h)).0 - solve(&legged(k, axis, -h)).0) / (2.0 * h);
        let fd = (4.0 * d(1e-4) - d(2e-4)) / 3.0;
        let scale = fd.amax().max(ex.amax());
        let err = (&ex - &fd).amax() / scale;
        eprintln!("toe {k} axis {axis}: |exact − FD| / max = {err:.1e} (max {scale:.2e})");
        let why = format!("toe {k} axis {axis}: {err:e}\nexact {ex}\nfd {fd}");
        assert!(scale > 1e-3 && err < TOL, "{why}");
    }
}
